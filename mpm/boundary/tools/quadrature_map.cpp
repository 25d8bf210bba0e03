// pfm-quadrature-map: the error of distributing a surface load on a curved boundary to the
// nodes of the background grid (thesis 6.1.1, figure 6.4), for the thesis formula eq. 6.12
// and for the exact integration of this library, against an adaptive high-order reference
// (reference_nodal_forces: adaptive 12-point Gauss-Legendre with bisection, hat functions
// evaluated independently of the stencil code).
//
// Sample runs:
//   pfm-quadrature-map --out results/quadrature            (defaults: 201, 1000 segments, seed 1)
//   pfm-quadrature-map --out /tmp/q --resolution 51 --random-segments 100 --seed 7
//   pfm-quadrature-map --out /tmp/q --cell-size 1           (the same picture on 2 x 2 cells)
//
// error_map.csv, the figure 6.4 set-up: cubic segment A = (-1, 1), C, D = (0.75, -0.75),
// B = (1, -1), C on a resolution x resolution lattice over [-1, 1]^2. In the thesis A and B
// sit on the corners of ONE element and the curve (inside the convex hull of A, B, C, D)
// never leaves it, so the thesis's coordinates are the natural coordinates of one bilinear
// element. We keep them as physical coordinates on a grid with origin (-1, -1) and cell size
// 2 (one cell = the thesis's element). Relative errors do not change when the whole picture is
// scaled, so this is the thesis's set-up for any cell size h (e.g. h = 1 with all points
// halved). --cell-size 1 instead puts 2 x 2 cells under the same curve (then the curve crosses
// up to 4 cells and splitting matters).
// Load: the thesis's vertical pressure q = 1 kPa on the whole segment, t = q (.) n with
// q = (0, -1) (the face filter and x-range of the solver are off); exact total force
// q (x_b - x_a) = (0, -2) (eq. 6.13).
// Columns: cx, cy, mode (thesis | exact), k (2..8 Gauss points), split (0 | 1: cut at cell
// edges first), total_force_rel_error = |sum_I f_I - F_exact| / |F_exact|,
// nodal_force_rel_error = max_I |f_I - f_ref,I| / max_I |f_ref,I|.
//
// random_segments.csv: cubic segments with all four control points uniform in [1, 3]^2 on a
// grid of 4 x 4 unit cells from (0, 0), so each curve crosses 1 to 4 cells; same load.
// Columns: segment, n_cells_crossed, mode, k, split, nodal_force_rel_error (as above),
// total_force_rel_error = |sum_I f_I - F_exact| / (q L) with L the arc length (x_b - x_a
// can vanish for a random segment; q L bounds the applied load).
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <random>
#include <set>
#include <string>
#include <vector>

#include "mpm/boundary/surface_load.hpp"

namespace {

using pfm::Grid;
using pfm::Vec2;
using namespace pfm::boundary;

struct Options {
  std::string out;
  int resolution = 201;
  int random_segments = 1000;
  unsigned seed = 1;
  double cell_size = 2.0;
};

[[noreturn]] void usage(const std::string& message) {
  std::cerr << "pfm-quadrature-map: " << message << "\n"
            << "usage: pfm-quadrature-map --out DIR [--resolution 201] [--random-segments 1000]"
               " [--seed 1] [--cell-size 2]\n";
  std::exit(2);
}

Options parse(int argc, char** argv) {
  Options options;
  for (int i = 1; i < argc; ++i) {
    const std::string key = argv[i];
    if (i + 1 >= argc) usage("missing value after " + key);
    const std::string value = argv[++i];
    try {
      if (key == "--out") {
        options.out = value;
      } else if (key == "--resolution") {
        options.resolution = std::stoi(value);
      } else if (key == "--random-segments") {
        options.random_segments = std::stoi(value);
      } else if (key == "--seed") {
        options.seed = static_cast<unsigned>(std::stoul(value));
      } else if (key == "--cell-size") {
        options.cell_size = std::stod(value);
      } else {
        usage("unknown option " + key);
      }
    } catch (const std::logic_error&) {
      usage("bad value for " + key + ": " + value);
    }
  }
  if (options.out.empty()) usage("--out DIR is required");
  if (options.resolution < 2) usage("--resolution must be >= 2");
  if (options.random_segments < 0) usage("--random-segments must be >= 0");
  if (!(options.cell_size > 0.0)) usage("--cell-size must be > 0");
  return options;
}

double max_norm(const std::vector<Vec2>& forces) {
  double largest = 0.0;
  for (const auto& f : forces) largest = std::max(largest, f.norm());
  return largest;
}

struct Errors {
  double total = 0.0;  // |sum f - F_exact|, absolute
  double nodal = 0.0;  // max_I |f_I - f_ref,I|, absolute
};

Errors measure(BoundaryLoadIntegrator& integrator, const BezierSegment& segment,
               const TractionLaw& law, const QuadratureOptions& options,
               const std::vector<Vec2>& reference, const Vec2& exact_total,
               std::vector<Vec2>& forces) {
  integrator.add_segment(segment, 0.0, 1.0, law, options);
  integrator.take_forces(forces);
  Errors errors;
  Vec2 total = Vec2::Zero();
  for (std::size_t k = 0; k < forces.size(); ++k) {
    total += forces[k];
    errors.nodal = std::max(errors.nodal, (forces[k] - reference[k]).norm());
  }
  errors.total = (total - exact_total).norm();
  return errors;
}

int count_cells(const Grid& grid, const BezierSegment& segment) {
  std::vector<double> breaks;
  grid_crossing_parameters(segment, grid, 0.0, 1.0, breaks);
  std::set<std::pair<int, int>> cells;
  for (std::size_t p = 0; p + 1 < breaks.size(); ++p) {
    const Vec2 x = segment.point(0.5 * (breaks[p] + breaks[p + 1]));
    cells.insert({grid.cell_i(x.x()), grid.cell_j(x.y())});
  }
  return static_cast<int>(cells.size());
}

}  // namespace

int main(int argc, char** argv) {
  const Options options = parse(argc, argv);
  const auto start = std::chrono::steady_clock::now();
  std::filesystem::create_directories(options.out);
  const TractionLaw law{Vec2(0.0, -1.0), Vec2::Zero()};  // q_v = 1 kPa, t = q (.) n
  const char* mode_names[2] = {"thesis", "exact"};
  const IntegrationMode modes[2] = {IntegrationMode::kThesis, IntegrationMode::kExact};

  // --- error_map.csv (figure 6.4) ---
  Grid map_grid;
  map_grid.origin = Vec2(-1.0, -1.0);
  map_grid.cell_size = options.cell_size;
  map_grid.n_cells_x = map_grid.n_cells_y =
      std::max(1, static_cast<int>(std::ceil(2.0 / options.cell_size - 1e-12)));
  const std::string map_path = options.out + "/error_map.csv";
  FILE* map_file = std::fopen(map_path.c_str(), "w");
  if (!map_file) usage("cannot write " + map_path);
  std::fprintf(map_file, "cx,cy,mode,k,split,total_force_rel_error,nodal_force_rel_error\n");
  BoundaryLoadIntegrator map_integrator(map_grid);
  std::vector<Vec2> forces(static_cast<std::size_t>(map_grid.n_nodes()));
  const Vec2 a(-1.0, 1.0), b(1.0, -1.0), d(0.75, -0.75);
  double worst_thesis_k5 = 0.0;
  for (int row = 0; row < options.resolution; ++row) {
    for (int column = 0; column < options.resolution; ++column) {
      const Vec2 c(-1.0 + 2.0 * column / (options.resolution - 1),
                   -1.0 + 2.0 * row / (options.resolution - 1));
      const BezierSegment segment = BezierSegment::cubic(a, c, d, b);
      const std::vector<Vec2> reference = reference_nodal_forces(map_grid, segment, law);
      const Vec2 exact_total = exact_total_force(segment, law);
      const double reference_scale = max_norm(reference);
      for (int m = 0; m < 2; ++m) {
        for (int k = 2; k <= 8; ++k) {
          for (int split = 0; split <= 1; ++split) {
            const QuadratureOptions quadrature{modes[m], k, split == 1, false};
            const Errors e =
                measure(map_integrator, segment, law, quadrature, reference, exact_total, forces);
            const double total_rel = e.total / exact_total.norm();
            if (m == 0 && k == 5 && split == 0)
              worst_thesis_k5 = std::max(worst_thesis_k5, total_rel);
            std::fprintf(map_file, "%.10g,%.10g,%s,%d,%d,%.6e,%.6e\n", c.x(), c.y(), mode_names[m],
                         k, split, total_rel, e.nodal / reference_scale);
          }
        }
      }
    }
  }
  std::fclose(map_file);

  // --- random_segments.csv ---
  Grid random_grid;
  random_grid.origin = Vec2::Zero();
  random_grid.cell_size = 1.0;
  random_grid.n_cells_x = random_grid.n_cells_y = 4;
  BoundaryLoadIntegrator random_integrator(random_grid);
  std::vector<Vec2> random_forces(static_cast<std::size_t>(random_grid.n_nodes()));
  std::mt19937_64 generator(options.seed);
  std::uniform_real_distribution<double> uniform(1.0, 3.0);
  const std::string random_path = options.out + "/random_segments.csv";
  FILE* random_file = std::fopen(random_path.c_str(), "w");
  if (!random_file) usage("cannot write " + random_path);
  std::fprintf(
      random_file,
      "segment,n_cells_crossed,mode,k,split,nodal_force_rel_error,total_force_rel_error\n");
  double worst_exact_k5 = 0.0;
  for (int s = 0; s < options.random_segments; ++s) {
    std::array<Vec2, 4> p;
    for (auto& point : p) {
      const double x = uniform(generator);
      point = Vec2(x, uniform(generator));
    }
    const BezierSegment segment = BezierSegment::cubic(p[0], p[1], p[2], p[3]);
    const std::vector<Vec2> reference = reference_nodal_forces(random_grid, segment, law);
    const Vec2 exact_total = exact_total_force(segment, law);
    const double applied = segment.length();  // q L with q = 1
    const double reference_scale = max_norm(reference);
    const int n_cells = count_cells(random_grid, segment);
    for (int m = 0; m < 2; ++m) {
      for (int k = 2; k <= 8; ++k) {
        for (int split = 0; split <= 1; ++split) {
          const QuadratureOptions quadrature{modes[m], k, split == 1, false};
          const Errors e = measure(random_integrator, segment, law, quadrature, reference,
                                   exact_total, random_forces);
          const double nodal_rel = e.nodal / reference_scale;
          if (m == 1 && k == 5 && split == 1) worst_exact_k5 = std::max(worst_exact_k5, nodal_rel);
          std::fprintf(random_file, "%d,%d,%s,%d,%d,%.6e,%.6e\n", s, n_cells, mode_names[m], k,
                       split, nodal_rel, e.total / applied);
        }
      }
    }
  }
  std::fclose(random_file);
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf("wrote %s and %s in %.1f s\n", map_path.c_str(), random_path.c_str(), seconds);
  std::printf("thesis eq. 6.12, k = 5, no split: max total-force error %.4f %%\n",
              100.0 * worst_thesis_k5);
  std::printf("exact, k = 5, split: max nodal error vs reference on random segments %.3e\n",
              worst_exact_k5);
  return 0;
}

#include "fuzz_harness.hpp"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <vector>

#include "mpm/boundary/load_input.hpp"
#include "mpm/core/json_input.hpp"
#include "mpm/detect/detect_command.hpp"
#include "mpm/detect/detect_internal.hpp"
#include "mpm/detect/detector.hpp"
#include "mpm/detect/improved_field.hpp"
#include "mpm/step/case.hpp"
#include "tests/cpp/detect/detect_test_support.hpp"

namespace pfm::fuzz {

namespace {

void check(bool condition, const std::string& path, const char* what) {
  if (!condition) throw InvariantViolation(path + ": accepted input breaks: " + what);
}

bool finite(const Vec2& v) {
  return std::isfinite(v.x()) && std::isfinite(v.y());
}

void check_case(const Case& c, const std::string& path) {
  const Grid& g = c.grid;
  check(std::isfinite(g.cell_size) && g.cell_size > 0.0, path, "cell_size finite and > 0");
  check(finite(g.origin), path, "grid origin finite");
  check(g.n_cells_x >= 1 && g.n_cells_y >= 1, path, "n_cells >= 1");
  check(static_cast<long long>(g.n_cells_x) + 1 <= 50'000'001LL &&
            (static_cast<long long>(g.n_cells_x) + 1) * (static_cast<long long>(g.n_cells_y) + 1) <=
                50'000'000LL,
        path, "at most 5e7 grid nodes");
  check(!c.materials.empty(), path, "at least one material");
  check(!c.bodies.empty(), path, "at least one body");
  const Vec2 lo = g.origin, hi = g.upper_corner();
  for (const BodySpec& b : c.bodies) {
    check(b.material >= 0 && b.material < static_cast<int>(c.materials.size()), path,
          "body material index in range");
    check(b.polygon.size() >= 3, path, "body polygon has >= 3 vertices");
    check(b.points_per_cell >= 1 && b.points_per_cell <= 8, path, "points_per_cell in 1..8");
    for (const Vec2& v : b.polygon) {
      check(finite(v), path, "polygon vertices finite");
      check(v.x() >= lo.x() && v.y() >= lo.y() && v.x() <= hi.x() && v.y() <= hi.y(), path,
            "polygon vertices inside the grid");
    }
    check(polygon_signed_area(b.polygon) > 0.0, path, "polygon counter-clockwise, area > 0");
  }
  check(std::isfinite(c.time.end_time) && c.time.end_time > 0.0, path, "end_time > 0");
  check(c.time.cfl > 0.0 && c.time.cfl <= 1.0, path, "cfl in (0, 1]");
  check(!c.time.dt || (std::isfinite(*c.time.dt) && *c.time.dt > 0.0), path, "dt > 0");
  check(std::isfinite(c.output.interval) && c.output.interval > 0.0, path, "output interval > 0");
  check(std::isfinite(c.output.timeseries_interval) && c.output.timeseries_interval > 0.0, path,
        "timeseries interval > 0");
  check(std::isfinite(c.gravity.g) && c.gravity.g >= 0.0, path, "g >= 0");
  for (const LoadSpec& load : c.loads) {
    if (load.apply_on == LoadTarget::kGridTopNodes) {
      check(load.x0 < load.x1 && load.pressure >= 0.0, path, "load x0 < x1 and pressure >= 0");
    } else {
      check(load.surface.has_value() && c.detection.has_value(), path,
            "a detected-boundary load has its specification and a detection block");
    }
  }
  check(!c.detection || c.detection->every_steps >= 1, path, "detection every_steps >= 1");
}

Outcome run_case(const std::string& path) {
  Case c;
  try {
    c = read_case(path);
  } catch (const InputError&) {
    return Outcome::kRejected;
  }
  check_case(c, path);
  return Outcome::kAccepted;
}

Outcome run_particle_csv(const std::string& path) {
  ParticleTable t;
  try {
    t = read_particle_csv(path);
  } catch (const InputError&) {
    return Outcome::kRejected;
  }
  const std::size_t n = t.position.size();
  check(n >= 1, path, "at least one particle");
  check(t.volume.size() == n, path, "one volume per particle");
  check(t.deformation_gradient.empty() || t.deformation_gradient.size() == n, path,
        "no or one deformation gradient per particle");
  for (std::size_t p = 0; p < n; ++p) {
    check(finite(t.position[p]), path, "finite positions");
    check(std::isfinite(t.volume[p]) && t.volume[p] > 0.0, path, "finite volumes > 0");
    if (!t.deformation_gradient.empty()) {
      check(t.deformation_gradient[p].allFinite() && t.deformation_gradient[p].determinant() > 0.0,
            path, "finite F with det F > 0");
    }
  }
  return Outcome::kAccepted;
}

Outcome run_config(const std::string& path) {
  nlohmann::json document;
  try {
    document = read_json_file(path);
  } catch (const InputError&) {
    return Outcome::kRejected;
  }
  const JsonView root(document, path);
  bool accepted = false;
  try {
    const DetectorConfig config = parse_detector_config(root);
    check(config.pfm.refinement >= 1 && config.pfm.refinement <= 64, path, "pfm refinement");
    check(config.improved.refinement >= 0 && config.improved.refinement <= 64, path,
          "improved refinement");
    check(config.improved.level > 0.0 && config.improved.level < 1.0, path, "improved level");
    accepted = true;
  } catch (const InputError&) {
  }
  try {
    const boundary::BoundaryLoadSpec spec = boundary::parse_boundary_load(root);
    check(spec.quadrature.gauss_points >= 1 && spec.quadrature.gauss_points <= 20, path,
          "gauss_points in 1..20");
    accepted = true;
  } catch (const InputError&) {
  }
  return accepted ? Outcome::kAccepted : Outcome::kRejected;
}

// The bytes of a detector input as a particle cloud on its field grid (tests/fuzz/README.md):
//   0, 1  grid cells n_x, n_y = 3 + b % 10 (cells of 0.5 m, origin 0)
//   2     points per cell k = 2 + b % 4 (spacing 0.5 / k); bit 2: deformation gradients;
//         bit 3: no mirroring at the grid edges; bit 4: kernels shaped by the neighbours
//         (neighbour_shape 0.7)
//   3-6   a block of k x k points per cell: lattice columns i0 .. i1 - 1, rows j0 .. j1 - 1
//         (spacing units, b % (n k)), points at the lattice centres
//   7-10  the block's deformation gradient I + (b - 128) / 160 (about its centre), with bit 2
//   then  8 bytes per free point (at most 128): x, y (16 bits each over the grid) and its own
//         F = I + (b - 128) / 160 with bit 2
// A deformation gradient outside the invariants' domain (J in [0.5, 2], stretch ratio <= 4) is
// replaced by I. Points that land outside the grid are left out. Volume: spacing^2 det F.
struct DetectInput {
  test::OwnedCloud cloud;
  Grid grid;
  bool mirror = true;
  bool shaped = false;
};

DetectInput decode_detect(const std::vector<std::uint8_t>& bytes) {
  const auto byte = [&](std::size_t k) -> int { return k < bytes.size() ? bytes[k] : 0; };
  DetectInput in;
  in.grid.cell_size = 0.5;
  in.grid.n_cells_x = 3 + byte(0) % 10;
  in.grid.n_cells_y = 3 + byte(1) % 10;
  const int k = 2 + byte(2) % 4;
  const bool deformed = (byte(2) & 4) != 0;
  in.mirror = (byte(2) & 8) == 0;
  in.shaped = (byte(2) & 16) != 0;
  const double spacing = in.grid.cell_size / k;
  in.cloud.initial_spacing = spacing;
  const auto gradient = [&](std::size_t at) {
    Mat2 f = Mat2::Identity();
    if (!deformed) return f;
    f(0, 0) += (byte(at) - 128) / 160.0;
    f(0, 1) += (byte(at + 1) - 128) / 160.0;
    f(1, 0) += (byte(at + 2) - 128) / 160.0;
    f(1, 1) += (byte(at + 3) - 128) / 160.0;
    // The domain of the invariants (issue 3): J in [0.5, 2], stretch ratio up to 4.
    double largest = 0.0, smallest = 0.0;
    detail::singular_values(f, largest, smallest);
    const double j = f.determinant();
    return j >= 0.5 && j <= 2.0 && largest <= 4.0 * smallest ? f : Mat2::Identity();
  };
  const Vec2 upper = in.grid.upper_corner();
  const auto add = [&](const Vec2& x, const Mat2& f) {
    if (!(x.x() > 0.0 && x.y() > 0.0 && x.x() < upper.x() && x.y() < upper.y())) return;
    in.cloud.position.push_back(x);
    in.cloud.volume.push_back(spacing * spacing * f.determinant());
    in.cloud.deformation_gradient.push_back(f);
  };
  const int columns = in.grid.n_cells_x * k, rows = in.grid.n_cells_y * k;
  const int i0 = byte(3) % columns, j0 = byte(4) % rows;
  const int i1 = i0 + byte(5) % (columns - i0 + 1), j1 = j0 + byte(6) % (rows - j0 + 1);
  const Mat2 block = gradient(7);
  const Vec2 centre = 0.5 * spacing * Vec2(i0 + i1, j0 + j1);
  for (int j = j0; j < j1; ++j) {
    for (int i = i0; i < i1; ++i) {
      add(centre + block * (spacing * Vec2(i + 0.5, j + 0.5) - centre), block);
    }
  }
  for (std::size_t at = 11; at + 8 <= bytes.size() && at < 11 + 8 * 128; at += 8) {
    const double u = (byte(at) * 256 + byte(at + 1)) / 65536.0;
    const double v = (byte(at + 2) * 256 + byte(at + 3)) / 65536.0;
    add(Vec2(u * upper.x(), v * upper.y()), gradient(at + 4));
  }
  if (!deformed) in.cloud.deformation_gradient.clear();
  return in;
}

// The improved detector on the decoded cloud: the contour invariants of issue 3 (closed or
// ending on the grid edge, no shared point, no crossing, orientation, every material point
// inside), the narrow band bitwise equal to the reference detector.
Outcome run_detect(const std::string& path) {
  std::ifstream file(path, std::ios::binary);
  const std::vector<std::uint8_t> bytes((std::istreambuf_iterator<char>(file)),
                                        std::istreambuf_iterator<char>());
  const DetectInput in = decode_detect(bytes);
  if (in.cloud.position.empty()) return Outcome::kRejected;
  DetectorConfig band;
  band.method = DetectorMethod::kImproved;
  band.improved.mirror_grid_edges = in.mirror;
  band.improved.neighbour_shape = in.shaped ? 0.7 : 0.0;
  DetectorConfig full = band;
  full.improved.narrow_band = false;
  const ParticleCloud cloud = in.cloud.view();
  DetectorState band_state, full_state;
  const DetectedBoundary a = detect(cloud, in.grid, band, band_state);
  const DetectedBoundary b = detect(cloud, in.grid, full, full_state);
  check(test::same_contours(a, b), path, "the narrow band gives the reference detector's contours");
  if (a.contours.empty()) {
    // No contour: the material covers the whole grid (every edge a wall), and then the field is
    // inside at every node along the grid edge; otherwise a contour was missed.
    // (The field of the detection: with the neighbours' shapes when they are on.)
    const std::vector<Mat2> shapes =
        in.shaped ? detail::neighbour_shaped_deformation(cloud, band.improved)
                  : std::vector<Mat2>{};
    const ParticleCloud field_cloud =
        in.shaped ? ParticleCloud{cloud.position, cloud.volume, shapes, cloud.initial_spacing}
                  : cloud;
    const ImprovedField field(field_cloud, band.improved, in.mirror ? &in.grid : nullptr);
    for (int i = 0; i <= in.grid.n_cells_x; ++i) {
      for (int j = 0; j <= in.grid.n_cells_y; ++j) {
        if (i != 0 && j != 0 && i != in.grid.n_cells_x && j != in.grid.n_cells_y) continue;
        check(field(in.grid.node_position(i, j)) > band.improved.level, path,
              "no contour although the grid edge is not all material");
      }
    }
    return Outcome::kAccepted;
  }
  const test::Violations v = test::check_invariants(a, in.grid, in.cloud.position);
  if (v.total() != 0) {
    char what[200];
    std::snprintf(what, sizeof what,
                  "contour invariants (open off the edge %ld, shared points %ld, crossings %ld, "
                  "orientation %ld, winding %ld, points outside %ld)",
                  v.open_not_on_edge, v.shared_points, v.self_intersections, v.orientation,
                  v.winding, v.particles_outside);
    check(false, path, what);
  }
  return Outcome::kAccepted;
}

}  // namespace

const char* target_name(Target target) {
  switch (target) {
    case Target::kCase:
      return "case";
    case Target::kParticleCsv:
      return "particle_csv";
    case Target::kConfig:
      return "config";
    case Target::kDetect:
      return "detect";
  }
  return "unknown";
}

std::optional<Target> target_from_name(std::string_view name) {
  for (const Target t : kAllTargets) {
    if (name == target_name(t)) return t;
  }
  return std::nullopt;
}

Outcome run_file(Target target, const std::string& path) {
  switch (target) {
    case Target::kCase:
      return run_case(path);
    case Target::kParticleCsv:
      return run_particle_csv(path);
    case Target::kConfig:
      return run_config(path);
    case Target::kDetect:
      return run_detect(path);
  }
  return Outcome::kRejected;
}

Outcome run_bytes(Target target, const std::uint8_t* data, std::size_t size) {
  // A scratch file per process and target, removed again after each input (it stays behind
  // only when the reader crashes, as the input that crashed it).
  struct Scratch {
    std::string path;
    ~Scratch() {
      std::error_code ignored;
      std::filesystem::remove(path, ignored);
    }
  };
  const Scratch scratch{
      (std::filesystem::temp_directory_path() /
       ("pfm-fuzz-" + std::to_string(::getpid()) + "-" + target_name(target) + ".input"))
          .string()};
  {
    std::ofstream out(scratch.path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    if (!out) throw std::runtime_error(scratch.path + ": cannot write the fuzz input");
  }
  return run_file(target, scratch.path);
}

}  // namespace pfm::fuzz

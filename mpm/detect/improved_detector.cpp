// The improved detector's pipeline (see detector.hpp): one survey of the cloud, the narrow band of
// cells near the boundary, the coarse screening, the guards, and the contours of the exact field
// (improved_field.cpp) on the refined grid with their containment check.
#include <omp.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <unordered_map>
#include <vector>

#include "mpm/detect/detect_internal.hpp"
#include "mpm/detect/improved_field.hpp"
#include "mpm/detect/improved_pipeline.hpp"
#include "mpm/detect/loop_classes.hpp"
#include "mpm/detect/marching_squares.hpp"
#include "mpm/detect/vector_loops.hpp"

namespace pfm::detail {

namespace {

// Wall-clock laps of the improved detector's parts (DetectionTimings::FieldParts).
class Laps {
 public:
  /// Adds the time since the last lap (or restart()) to `part`.
  void operator()(double& part) {
    part += seconds_since(start_);
    start_ = std::chrono::steady_clock::now();
  }
  void restart() { start_ = std::chrono::steady_clock::now(); }

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

// With phi alone (the guards are not decided yet; max(phi, guard) >= phi): cells no kernel
// reaches are exactly void; reached cells whose corners and centre all exceed level +
// band_margin are interior ("deep"), those all below level - band_margin are exterior ("far")
// unless they hold a guarded particle. The rest is "active". The screening is a heuristic
// (detector.hpp). Cells interior by volume (empty span: none) are deep without evaluation.
Screening screen_cells(const ImprovedField& field, const Grid& grid, const ImprovedConfig& config,
                       std::span<const char> interior_by_volume, long& field_evaluations) {
  const int ncx = grid.n_cells_x, ncy = grid.n_cells_y;
  const std::size_t n_cells = static_cast<std::size_t>(ncx) * ncy;
  const double h = grid.cell_size;
  const auto positions = field.positions();
  Screening screen;
  screen.reached.assign(n_cells, 0);
  // The cells each particle's box reaches, as the 2D prefix sums of +-1 at the corners of the
  // boxes (four writes per particle instead of one per cell of its box).
  const std::size_t stride = static_cast<std::size_t>(ncx) + 1;
  std::vector<int> boxes(stride * (static_cast<std::size_t>(ncy) + 1), 0);
  for (std::size_t p = 0; p < positions.size(); ++p) {
    const Vec2 half = field.reach_box(p);
    const int i0 = std::max(grid.cell_i(positions[p].x() - half.x()), 0);
    const int i1 = std::min(grid.cell_i(positions[p].x() + half.x()), ncx - 1);
    const int j0 = std::max(grid.cell_j(positions[p].y() - half.y()), 0);
    const int j1 = std::min(grid.cell_j(positions[p].y() + half.y()), ncy - 1);
    if (i0 > i1 || j0 > j1) continue;
    const std::size_t low = static_cast<std::size_t>(j0) * stride;
    const std::size_t high = static_cast<std::size_t>(j1 + 1) * stride;
    ++boxes[low + static_cast<std::size_t>(i0)];
    --boxes[low + static_cast<std::size_t>(i1) + 1];
    --boxes[high + static_cast<std::size_t>(i0)];
    ++boxes[high + static_cast<std::size_t>(i1) + 1];
  }
  for (int j = 0; j < ncy; ++j) {
    int* row = boxes.data() + static_cast<std::size_t>(j) * stride;
    if (j > 0) {
      const int* below = row - stride;
      for (int i = 0; i < ncx; ++i) row[i] += below[i];  // the column sums, up to this row
    }
    int along = 0;
    char* reached = screen.reached.data() + static_cast<std::size_t>(j) * ncx;
    for (int i = 0; i < ncx; ++i) {
      along += row[i];
      reached[i] = along > 0 ? 1 : 0;
    }
  }
  // phi at the corners of the reached cells that the volume does not call interior (the coarse
  // nodes are sparse: a particle would visit few of them, a block evaluation would cost more).
  const std::size_t n_nodes = static_cast<std::size_t>(ncx + 1) * (ncy + 1);
  std::vector<char> listed_node(n_nodes, 0);
  std::vector<int> screened, listed;  // cells, nodes
  for (int j = 0; j < ncy; ++j) {
    for (int i = 0; i < ncx; ++i) {
      const std::size_t c = static_cast<std::size_t>(j) * ncx + i;
      if (!screen.reached[c] || (!interior_by_volume.empty() && interior_by_volume[c])) continue;
      screened.push_back(static_cast<int>(c));
      for (const int k : {j * (ncx + 1) + i, j * (ncx + 1) + i + 1, (j + 1) * (ncx + 1) + i,
                          (j + 1) * (ncx + 1) + i + 1}) {
        if (listed_node[static_cast<std::size_t>(k)]) continue;
        listed_node[static_cast<std::size_t>(k)] = 1;
        listed.push_back(k);
      }
    }
  }
  screen.coarse.assign(n_nodes, std::numeric_limits<double>::quiet_NaN());
  for_each_on_threads(listed.size(), kEvaluationChunk, [&](std::size_t k) {
    const int i = listed[k] % (ncx + 1), j = listed[k] / (ncx + 1);
    screen.coarse[static_cast<std::size_t>(listed[k])] =
        field.volume_fraction(grid.node_position(i, j));
  });
  field_evaluations += static_cast<long>(listed.size());
  // A screened cell all of whose corners lie above (below) the band is deep (far) if its centre
  // does too; cells interior by volume are deep.
  if (interior_by_volume.empty()) {
    screen.deep.assign(n_cells, 0);
  } else {
    screen.deep.assign(interior_by_volume.begin(), interior_by_volume.end());
  }
  screen.far.assign(n_cells, 0);
  const double interior = config.level + config.band_margin;
  const double exterior = config.level - config.band_margin;
  std::vector<int> centred;
  for (const int cell : screened) {
    const auto c = static_cast<std::size_t>(cell);
    const int i = cell % ncx, j = cell / ncx;
    const double* corner = screen.coarse.data() + static_cast<std::size_t>(j) * (ncx + 1) + i;
    const double v[4] = {corner[0], corner[1], corner[ncx + 1], corner[ncx + 2]};
    screen.deep[c] = v[0] > interior && v[1] > interior && v[2] > interior && v[3] > interior;
    screen.far[c] = v[0] < exterior && v[1] < exterior && v[2] < exterior && v[3] < exterior;
    if (screen.deep[c] || screen.far[c]) centred.push_back(cell);
  }
  for_each_on_threads(centred.size(), kEvaluationChunk, [&](std::size_t k) {
    const auto c = static_cast<std::size_t>(centred[k]);
    const int i = centred[k] % ncx, j = centred[k] / ncx;
    const double vc = field.volume_fraction(grid.node_position(i, j) + Vec2(0.5 * h, 0.5 * h));
    screen.deep[c] = screen.deep[c] && vc > interior;
    screen.far[c] = screen.far[c] && vc < exterior;
  });
  field_evaluations += static_cast<long>(centred.size());
  return screen;
}

// Guard candidates (step 2): every particle outside the deep cells.
std::vector<char> guard_candidates(std::span<const Vec2> positions, const Grid& grid,
                                   const std::vector<char>& deep) {
  const int ncx = grid.n_cells_x, ncy = grid.n_cells_y;
  std::vector<char> candidate(positions.size(), 1);
  for (std::size_t p = 0; p < positions.size(); ++p) {
    const int i = grid.cell_i(positions[p].x()), j = grid.cell_j(positions[p].y());
    if (i >= 0 && j >= 0 && i < ncx && j < ncy && deep[static_cast<std::size_t>(j) * ncx + i]) {
      candidate[p] = 0;
    }
  }
  return candidate;
}

}  // namespace

namespace {
std::atomic<bool> keep_nodes{true};
}  // namespace

bool keep_nodes_between_passes(bool on) {
  return keep_nodes.exchange(on);
}

namespace {

// The deformation of the field's particles with their kernels shaped by their neighbours: for the
// band, the neighbours in the cells within a kernel reach of its particles' (the sums do not
// depend on which other particles the search holds).
std::vector<Mat2> shaped_kernels(const ParticleCloud& cloud, const Grid& grid,
                                 const CloudSurvey& survey, const std::optional<Band>& band,
                                 const ParticleCloud& field_cloud, const ImprovedConfig& config,
                                 double kernel_reach) {
  NeighbourCloud near;
  if (band) near = neighbours_of_band(cloud, grid, survey, *band, kernel_reach);
  const NeighbourSearch search(
      band ? ParticleCloud{near.position, near.volume, {}, cloud.initial_spacing} : cloud,
      kernel_reach);
  return neighbour_shaped_deformation(search, field_cloud, config);
}

// The fine nodes of a pass at refinement r: the pass before's, raised by the guards and bridges
// added where the field changed (`changed`), when it had the same refinement (its edge roots kept
// outside those cells: `memo`); else new ones.
FineNodes& pass_nodes(std::optional<FineNodes>& kept_nodes, EdgeRoots::Memo& memo,
                      const std::vector<char>& changed, int r, const Grid& grid,
                      const ImprovedField& field, const ImprovedConfig& config,
                      double initial_spacing, long& field_evaluations) {
  const double h = grid.cell_size;
  if (kept_nodes && kept_nodes->refinement() == r && keep_nodes) {
    kept_nodes->raise(changed);
    memo.index(grid, changed);
  } else {
    kept_nodes.emplace(grid, r,
                       FineNodes::gather_square(r, h, config.radius_factor * initial_spacing),
                       field, config.level, field_evaluations);
    memo.clear();
  }
  return *kept_nodes;
}

// The contours of the fine cells `cells` by marching squares, their edge points Brent's roots
// (`roots`) and the saddles decided on the exact field.
DetectedBoundary contour_cells(FineNodes& nodes, const ImprovedField& field,
                               const ImprovedConfig& config, const std::vector<int>& cells,
                               EdgeRoots& roots, long& field_evaluations) {
  const std::function<double(const Vec2&)> exact_sample = [&](const Vec2& x) {
    ++field_evaluations;
    return field(x);
  };
  return marching_squares_cells(
      nodes.geometry(), [&nodes](int i, int j) { return nodes.value(i, j); }, cells, config.level,
      config.saddle_rule, std::ref(roots), exact_sample);
}

// The passes' totals in the timings: the edge points' and the contours' seconds and counts, and
// the field evaluations (nodes, screening, guards and roots), the field's parts summed.
void record_pass_totals(double edge_seconds, double connection_seconds, long edge_points,
                        long root_evaluations, long field_evaluations, DetectionTimings& timings) {
  const auto& parts = timings.field_parts;
  timings.edge_points = edge_seconds;
  timings.connection = connection_seconds;
  timings.edge_point_count = edge_points;
  timings.root_evaluations = root_evaluations;
  timings.field_evaluations = field_evaluations + root_evaluations;
  timings.field = parts.survey + parts.band + parts.shape + parts.setup + parts.screening +
                  parts.guards + parts.nodes;
}

}  // namespace

// The pipeline: survey (0), band (0), field setup, coarse screening (1), guards (2), then per
// contour pass the fine cells (3), the contours with their edge points (4) and the containment
// check (5); a second pass, with bridges (join_spurious_loops) or the particles left outside
// guarded, only if a particle is outside or an island is in contact; a third at the guards'
// refinement if a particle is still outside; then the spurious loops are removed.
DetectedBoundary detect_improved(const ParticleCloud& input, const Grid& grid,
                                 const ImprovedConfig& config, DetectionTimings& timings) {
  const double h = grid.cell_size;
  auto& parts = timings.field_parts;
  Laps lap;

  // 0. One sweep over the cloud. The fixed-point unit of the kernel sums follows from the whole
  //    cloud's largest weight, so that a field built on part of the particles gives bitwise the
  //    sums of one built on all of them (the sums are of integers: any order gives the same).
  CloudSurvey survey = survey_cloud(input, grid, config.max_stretch);
  //    The kernels' stretch cap (ImprovedConfig::max_stretch, cap_stretch()): F with its
  //    singular values clamped to [1 / cap, cap], the volume following det F both ways, so that
  //    a kernel holds the volume of its own capped ellipse. The survey's cell volumes, which the
  //    band's solid cells read, take the capped volumes where they shrank but not where they
  //    grew: a cell the band calls interior is then interior for the field too. The cap is taken
  //    only when some F may be outside it: by the narrow band on its own copies (the particles
  //    away from the boundary are neither copied nor capped); without the band, or with kernels
  //    shaped by the neighbours (which read the capped volumes outside the band), on a copy of
  //    all. The weight bound V / det F (weight_bound()) holds for V' / det F' = V / det F.
  ParticleCloud cloud = input;
  std::vector<Mat2> capped;
  std::vector<double> capped_volume;
  const bool capping =
      !input.deformation_gradient.empty() &&
      may_exceed_stretch_cap(survey.largest_stretch, survey.smallest_det, config.max_stretch);
  if (capping) survey.largest_stretch = std::min(survey.largest_stretch, config.max_stretch);
  const double kernel_reach = config.radius_factor * cloud.initial_spacing * survey.largest_stretch;
  const double particle_reach =
      ImprovedField::reference_reach(config, cloud.initial_spacing) * survey.largest_stretch;
  const double widest = std::max(grid.n_cells_x, grid.n_cells_y);
  const bool banded = !cloud.position.empty() && particle_reach / h < widest;
  const bool band_caps = capping && banded && config.neighbour_shape == 0.0;
  if (capping && !band_caps) {
    capped.assign(input.deformation_gradient.begin(), input.deformation_gradient.end());
    capped_volume.assign(input.volume.begin(), input.volume.end());
    cap_stretch(capped, config.max_stretch, capped_volume);
    cloud.deformation_gradient = capped;
    cloud.volume = capped_volume;
  }
  lap(parts.survey);
  //    Kernels shaped by the neighbours only narrow (det F' >= (1 - beta) det F): the reaches of
  //    F bound theirs, and their weights are at most 1 / (1 - beta) times those of F.
  const double shaped_weights = 1.0 / (1.0 - config.neighbour_shape);
  const ImprovedField::CloudBounds bounds{
      shaped_weights * ImprovedField::weight_bound(config, cloud.initial_spacing,
                                                   survey.largest_volume, survey.smallest_det),
      4 * cloud.position.size()};
  //    The narrow band; a kernel reaching across the whole grid (a huge stretch or radius) leaves
  //    nothing to screen.
  std::optional<Band> band;
  if (banded) {
    band = select_band(cloud, grid, config, survey, kernel_reach, particle_reach);
    if (band_caps) cap_stretch(band->deformation, config.max_stretch, band->volume);
  }
  ParticleCloud field_cloud =
      band ? ParticleCloud{band->position, band->volume, band->deformation, cloud.initial_spacing}
           : cloud;
  const std::span<const char> interior_by_volume =
      band ? std::span<const char>(band->interior_by_volume) : std::span<const char>();
  lap(parts.band);
  std::vector<Mat2> shaped;
  if (config.neighbour_shape > 0.0) {
    shaped = shaped_kernels(cloud, grid, survey, band, field_cloud, config, kernel_reach);
    field_cloud.deformation_gradient = shaped;
  }
  lap(parts.shape);
  // The wall contacts found by the band are those of the whole cloud, which the band holds a
  // part of.
  ImprovedField field(field_cloud, config, ImprovedField::DeferGuards{},
                      config.mirror_grid_edges ? &grid : nullptr, &bounds,
                      band && config.mirror_grid_edges ? &band->contacts : nullptr);
  timings.field_particles = static_cast<long>(field_cloud.position.size());
  lap(parts.setup);
  long field_evaluations = 0;
  const auto positions = field.positions();

  // 1. Coarse screening.
  const Screening screen = screen_cells(field, grid, config, interior_by_volume, field_evaluations);
  lap(parts.screening);
  // 2. Guards: every particle outside the deep cells is a candidate.
  const std::vector<char> candidate = guard_candidates(positions, grid, screen.deep);
  field.decide_guards(candidate);
  field_evaluations += static_cast<long>(std::count(candidate.begin(), candidate.end(), 1));
  lap(parts.guards);

  // Steps 3-5 run again when the contours of the first pass leave a particle outside (step 5) or
  // split material in contact: bridges, then, for a particle still outside, guards.
  const double guard_reach =
      ImprovedField::reference_guard_reach(config, cloud.initial_spacing) * survey.largest_stretch;
  double edge_seconds = 0.0, connection_seconds = 0.0;
  long root_evaluations = 0, edge_points = 0;
  DetectedBoundary boundary;
  // The fine nodes and edge roots a pass keeps from the one before (pass_nodes()).
  std::optional<FineNodes> kept_nodes;
  EdgeRoots::Memo memo;
  std::vector<char> changed;
  // The loops' classes of the last pass's contours, when they were taken (for the bridges).
  std::optional<LoopClasses> classes;
  for (int pass = 0;; ++pass) {
    classes.reset();
    lap.restart();
    const int r =
        pass_refinement(config, pass, field.smallest_guard_axis(), h, cloud.initial_spacing);
    timings.refinement = r;
    FineNodes& nodes = pass_nodes(kept_nodes, memo, changed, r, grid, field, config,
                                  cloud.initial_spacing, field_evaluations);
    // Without guards the field is phi, which the screening evaluated at the grid nodes.
    const bool phi_alone = field.n_guarded() == 0 && field.n_bridges() == 0;
    nodes.reuse_grid_nodes(phi_alone ? std::span<const double>(screen.coarse)
                                     : std::span<const double>());
    // 3. The fine cells to contour.
    const std::vector<int> cells =
        trace_band_cells(nodes, grid, field, screen, interior_by_volume, candidate, guard_reach);
    lap(parts.nodes);

    // 4. Edge points and contours.
    const auto contour_start = std::chrono::steady_clock::now();
    EdgeRoots roots(field, nodes, config.level, config.root_tolerance, &memo, &changed);
    boundary = contour_cells(nodes, field, config, cells, roots, field_evaluations);
    timings.processed_cells = static_cast<long>(cells.size());

    // 5. Containment; the particles left outside get their guard and the contours are found
    //    again.
    const std::vector<std::size_t> left_out =
        particles_left_out(boundary, nodes, grid, positions, candidate, config.level);
    edge_seconds += roots.seconds();
    edge_points += roots.count();
    root_evaluations += roots.evaluations();
    connection_seconds += seconds_since(contour_start) - roots.seconds();
    const auto next = next_pass(config, pass, boundary, positions, left_out, cloud.initial_spacing,
                                classes, timings);
    if (!next) break;
    timings.particles_guarded_after_contouring += static_cast<long>(field.add_guards(left_out));
    if (next->bridging) {
      field.add_bridges(left_out, next->pairs, h / r);
      timings.bridges = static_cast<long>(field.n_bridges());
    }
    changed = cells_changed_by(grid, positions, left_out, next->pairs, guard_reach, h / r);
  }
  remove_unresolved_loops(config, boundary, positions, cloud.initial_spacing, classes, timings);
  record_pass_totals(edge_seconds, connection_seconds, edge_points, root_evaluations,
                     field_evaluations, timings);
  if (config.curvature_correction) {
    const auto start = std::chrono::steady_clock::now();
    correct_curvature(boundary, field.curvature_moment(),
                      config.radius_factor * cloud.initial_spacing);
    timings.filters = seconds_since(start);
  }
  return boundary;
}

}  // namespace pfm::detail

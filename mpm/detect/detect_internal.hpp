// Internal interfaces between detector.cpp and the detector implementations.
#pragma once

#include <omp.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cstddef>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "mpm/detect/detector.hpp"
#include "mpm/detect/improved_field.hpp"
#include "mpm/detect/loop_classes.hpp"

namespace pfm {
class ParticleBins;
}

namespace pfm::detail {

/// The improved detector with its narrow band and accelerations (improved_detector.cpp).
DetectedBoundary detect_improved(const ParticleCloud& cloud, const Grid& grid,
                                 const ImprovedConfig& config, DetectionTimings& timings);
/// Its definition, plainly (reference_detector.cpp): bitwise the same contours, the field
/// evaluated at every node of the refined grid. detect() runs it for `narrow_band: false`.
DetectedBoundary detect_improved_reference(const ParticleCloud& cloud, const Grid& grid,
                                           const ImprovedConfig& config, DetectionTimings& timings);

// ---- pieces of the improved detector's definition that both of them call (in definition.cpp;
// the bridges' pairs and the removal of spurious loops in loop_classes.cpp) ----

/// Chebyshev (max-norm) distance from x to the segment a-b (a point: a == b), m.
double chebyshev_distance(const Vec2& x, const Vec2& a, const Vec2& b);
/// The refinement of contour pass `pass` (0, 1 or, joining spurious loops, 2), for a grid of
/// cell h (m), the particles' initial spacing (m) and the smallest semi-axis of an active guard
/// (m; infinity: none). Automatic (config.refinement <= 0): for the first pass and, joining
/// spurious loops, for the bridges' pass, the smallest refinement >= 4 whose fine cell is at most
/// half a spacing (4 up to 2 x 2 points per cell, 2 n at n x n); the last pass takes cells whose
/// diagonal fits in the smallest guard, so that a guarded particle has the four corners of its
/// fine cell inside (capped at max_refinement / sqrt(1 - neighbour_shape)). The fine cell scales
/// with the spacing because the contours' corners and the bridges do: marching squares on cells
/// a spacing wide cut a body's convex corner off past its corner particle, and that particle's
/// bridge (a square of 1.25 fine cells around it) would then stand out of the body by 1.25 cells
/// less half a spacing. The first pass does not refine for the guards: a few guarded corner
/// particles of a long face would refine the whole band, and the containment check sends what it
/// misses to the last pass.
int pass_refinement(const ImprovedConfig& config, int pass, double smallest_guard_axis, double h,
                    double spacing);
/// The bridges of the second pass (ImprovedConfig::join_spurious_loops): from each particle of
/// `left_out` to every particle within kContactSpacings initial spacings of it, and the contacts
/// of the spurious islands of `classes`; pairs in increasing order, each once.
std::vector<std::array<std::size_t, 2>> bridge_pairs(std::span<const Vec2> positions,
                                                     std::span<const std::size_t> left_out,
                                                     const LoopClasses& classes, double spacing);
/// Removes the loops the particle spacing cannot resolve (`classes`, classify_loops() of
/// `boundary`): every spurious hole, with the loops inside it (their region becomes material: it
/// held no free disk of one spacing), and every material loop that holds no particle. Returns the
/// number of loops removed.
long remove_spurious_loops(DetectedBoundary& boundary, const LoopClasses& classes);
/// The fine cell (i, j) of the lattice `nodes` (its geometry) holding x, clamped to the lattice;
/// false when x lies outside it.
bool fine_cell(const NodalField& nodes, const Vec2& x, int& i, int& j);
/// A segment of a contour, a to b, and the fine cell (j (n_x - 1) + i) holding its middle.
struct CellSegment {
  int cell;
  Vec2 a, b;
};
/// Every segment of the contours, sorted by fine cell of `nodes`, in contour order within a cell.
std::vector<CellSegment> segments_by_cell(const DetectedBoundary& boundary,
                                          const NodalField& nodes);
/// The segments of `segments` (segments_by_cell()) in fine cell `cell`.
std::span<const CellSegment> segments_in(const std::vector<CellSegment>& segments, int cell);
/// The containment check for a point x in the fine cell of `segments` (not empty): whether x lies
/// right of (outside) the segment nearest to it; the first of equally near ones decides.
bool outside_nearest_segment(std::span<const CellSegment> segments, const Vec2& x);
/// What the contours of pass `pass` call for (ImprovedConfig: join_spurious_loops, guards): no
/// further pass (nullopt), or one with bridges between `pairs` (pass 0, joining spurious loops,
/// when a particle is outside or an island is in contact) or one at the guards' refinement (a
/// particle is still outside); in both the particles `left_out` get their guard. `positions`:
/// the field's particles, `left_out` indexes them; `classes` takes the loops' classes when they
/// were found. Counts the particles outside the first contours and the guards' passes.
struct NextPass {
  bool bridging = false;
  std::vector<std::array<std::size_t, 2>> pairs;
};
std::optional<NextPass> next_pass(const ImprovedConfig& config, int pass,
                                  const DetectedBoundary& boundary, std::span<const Vec2> positions,
                                  std::span<const std::size_t> left_out, double spacing,
                                  std::optional<LoopClasses>& classes, DetectionTimings& timings);
/// After the last pass, joining spurious loops: removes the loops the spacing cannot resolve
/// (remove_spurious_loops(); `classes`: those of the last pass's contours if found).
void remove_unresolved_loops(const ImprovedConfig& config, DetectedBoundary& boundary,
                             std::span<const Vec2> positions, double spacing,
                             std::optional<LoopClasses>& classes, DetectionTimings& timings);
/// Curvature-bias correction (ImprovedConfig::curvature_correction): each point moves towards
/// the void by kappa moment / 2, kappa from the circle through the neighbours `arc` (m) away
/// along the contour.
void correct_curvature(DetectedBoundary& boundary, double moment, double arc);

DetectedBoundary detect_thesis_pfm(const ParticleCloud& cloud, const Grid& grid,
                                   const ThesisPfmConfig& config, DetectorState& state,
                                   DetectionTimings& timings);

/// Baselines (mpm/detect/baselines/).
DetectedBoundary detect_surface_markers(const ParticleCloud& cloud, const Grid& grid,
                                        const DetectorConfig& config, DetectorState& state,
                                        DetectionTimings& timings);
DetectedBoundary detect_volume_of_fluid(const ParticleCloud& cloud, const Grid& grid,
                                        const VofConfig& config, DetectionTimings& timings);
DetectedBoundary detect_cell_density(const ParticleCloud& cloud, const Grid& grid,
                                     const DensityConfig& config, DetectionTimings& timings);

/// body(k) for every k < n, by chunks of `chunk` on the OpenMP threads (a single chunk runs on the
/// calling thread). Each body(k) may write only its own places: then the result does not depend
/// on the thread count. It must not throw (an exception cannot leave an OpenMP region): input is
/// checked before.
template <class Body>
void for_each_on_threads(std::size_t n, std::size_t chunk, const Body& body) {
  const std::size_t n_chunks = (n + chunk - 1) / chunk;
  if (n_chunks <= 1 || omp_get_max_threads() == 1) {  // no team (a team of one still costs)
    for (std::size_t k = 0; k < n; ++k) body(k);
    return;
  }
#pragma omp parallel for schedule(dynamic, 1)
  for (std::size_t c = 0; c < n_chunks; ++c) {
    const std::size_t end = std::min(n, (c + 1) * chunk);
    for (std::size_t k = c * chunk; k < end; ++k) body(k);
  }
}

/// Seconds since `start`.
inline double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// Largest and smallest singular values of a 2 x 2 matrix (closed form).
inline void singular_values(const Mat2& m, double& largest, double& smallest) {
  const double e = 0.5 * (m(0, 0) + m(1, 1)), f = 0.5 * (m(0, 0) - m(1, 1));
  const double g = 0.5 * (m(1, 0) + m(0, 1)), h = 0.5 * (m(1, 0) - m(0, 1));
  const double q = std::sqrt(e * e + h * h), r = std::sqrt(f * f + g * g);
  largest = q + r;
  smallest = std::abs(q - r);
}

/// Whether some F of a set may lie beyond the stretch cap `cap` (0: no cap), from the set's
/// largest singular value and smallest det F: each F's smallest singular value is det F / its
/// largest >= smallest_det / largest.
inline bool may_exceed_stretch_cap(double largest, double smallest_det, double cap) {
  return cap > 0.0 && (largest > cap || smallest_det * cap < largest);
}

/// The kernels' stretch cap (ImprovedConfig::max_stretch): clamps every singular value of each F
/// to [1 / cap, cap], keeping its axes: F' = F (I + sum_k (s_k' / s_k - 1) v_k v_k^T) over the
/// right singular vectors v_k. A particle's volume is V = V0 det F: each `volume` (one per F, or
/// empty) follows its det F both ways, V' = V det F' / det F.
void cap_stretch(std::vector<Mat2>& deformation, double cap, std::span<double> volume = {});

/// Whether a contour pass at the refinement of the pass before keeps that pass's fine nodes and
/// edge roots outside the cells where the field changed (on by default; tests turn it off to
/// check that the contours are bitwise the same). Returns the previous setting.
bool keep_nodes_between_passes(bool on);

/// The neighbours of the kernel shapes regularised by the neighbours
/// (ImprovedConfig::neighbour_shape): a cloud (its spans; the arrays must outlive the search) and
/// its bins.
class NeighbourSearch {
 public:
  /// window_reach (m): no smaller than a0 times the largest stretch of the particles' F whose
  /// windows are searched (the bins are a third of it).
  NeighbourSearch(const ParticleCloud& cloud, double window_reach);
  ~NeighbourSearch();
  const ParticleCloud& cloud() const { return cloud_; }
  const ParticleBins& bins() const { return *bins_; }

 private:
  ParticleCloud cloud_;  ///< (spans: the arrays must outlive the search)
  std::unique_ptr<ParticleBins> bins_;
};

/// Kernel shapes regularised by the neighbours (ImprovedConfig::neighbour_shape, beta in
/// (0, 0.9]): for each of `particles`, all of them in the search's cloud, the symmetric F' with
/// F' F'^T = F [(1 - beta) I + beta A] F^T, where A has the principal axes e_i of
/// neighbour_window_moment() and eigenvalues min(1, m_i / (m1 / 2)), m1 from
/// neighbour_moment_of_unit_window(): the kernel narrows across a body thinner than about half
/// its window (det F' >= (1 - beta) det F), and is F S0 elsewhere. The clouds must have been
/// checked.
std::vector<Mat2> neighbour_shaped_deformation(const NeighbourSearch& search,
                                               const ParticleCloud& particles,
                                               const ImprovedConfig& config);
/// The same for every particle of `cloud`.
std::vector<Mat2> neighbour_shaped_deformation(const ParticleCloud& cloud,
                                               const ImprovedConfig& config);
/// The second moment, in the reference frame of a particle at x with deformation gradient F, of
/// its neighbours' offsets u = F^-1 (x_j - x) / a0 in the unit window |u| < 1, weighted by
/// V_j (1 - |u|^2)^k (k of the profile): its principal axes (x and y when it is diagonal) and,
/// along each, the larger of the moments of the two sides, each normalised by its own weight
/// (offsets within 1e-9 of the axis, the particle itself, count half on each side). Deep in a
/// body, or on an affinely deformed lattice with its F, these are m1 up to the lattice's
/// discreteness; a free surface leaves them so (its inner side is full); a body thinner than the
/// window makes them small across it.
struct WindowMoment {
  Vec2 axis[2] = {Vec2(1.0, 0.0), Vec2(0.0, 1.0)};
  double moment[2] = {0.0, 0.0};
};
WindowMoment neighbour_window_moment(const NeighbourSearch& search, const ImprovedConfig& config,
                                     const Vec2& x, const Mat2& f);
/// m1 = E[u_x^2] under the weight (1 - |u|^2)^k on the unit disk: 1 / (2 (k + 2)).
double neighbour_moment_of_unit_window(KernelProfile profile);

/// Validates the cloud's spans and spacing and every particle (InputError naming the field).
void check_cloud(const ParticleCloud& cloud);
/// The spans and the spacing only.
void check_cloud_shape(const ParticleCloud& cloud);
/// Particle p: finite position, volume > 0, finite F with det F > 0 (InputError naming it).
void check_particle(const ParticleCloud& cloud, std::size_t p);

}  // namespace pfm::detail

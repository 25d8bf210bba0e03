// Boundary detection from material points: the thesis' Proximity Field Method (4.4, 5) and an
// improved detector, behind one entry point detect().
//
//   particles (+ deformation gradients) -> field on a grid -> edge points -> contours
//
// Units: m for lengths, m^2 for particle volumes. The field grid is the grid given to detect()
// (usually the MPM grid) refined by an integer factor; open contours end on its edge.
#pragma once

#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mpm/core/grid.hpp"
#include "mpm/core/json_input.hpp"
#include "mpm/core/types.hpp"
#include "mpm/detect/contour.hpp"
#include "mpm/detect/marching_squares.hpp"
#include "mpm/detect/particle_bins.hpp"

namespace pfm {

/// The material points seen by a detector. Spans are views; the caller owns the data.
struct ParticleCloud {
  std::span<const Vec2> position;              ///< m
  std::span<const double> volume;              ///< current volume, m^2 (per unit thickness)
  std::span<const Mat2> deformation_gradient;  ///< total F since the initial state; may be empty
  double initial_spacing = 0.0;                ///< particle spacing in the initial state, m
};

enum class DetectorMethod { kPfm, kImproved, kSmm, kVof, kDensity };

/// Radial profile of a unit-mass kernel W(u) = C (1 - u.u)^k on the unit disk of the scaled
/// coordinate u = S^-1 (x - x_p); C = (k + 1) / (pi det S). k = 1 is the thesis' Epanechnikov
/// kernel (eq. 4.9, C from eq. 4.19).
enum class KernelProfile { kEpanechnikov = 1, kBiweight = 2, kTriweight = 3 };

/// Thesis kernel deformation (4.4.3).
enum class KernelDeformation {
  kNone,         ///< fixed kernels (thesis Fig. 5.26)
  kSmallStrain,  ///< total strain on the initial shape, eq. 4.17
  kLargeStrain,  ///< incremental, eq. 4.16, re-decomposed to principal axes every step
};

enum class EdgeLocation {
  kBisection,       ///< bisection on the exact field (4.4.5)
  kShapeFunctions,  ///< quadratic interpolation of the 3 nodes on the cell edge (5.2.2)
};

/// The Proximity Field Method as the thesis defines it. Every switch reproduces a published
/// behaviour; defaults follow the thesis' final configuration (5.5) without smoothing.
struct ThesisPfmConfig {
  /// Initial kernel semi-axis = factor * initial_spacing / 2 (eq. 4.21 as read in the method
  /// map; >= sqrt(2) covers a particle's square, 5.3).
  double kernel_factor = 1.5;
  double contour_level = 0.0;  ///< z of eq. 4.20, in field units (1/m^2: kernels have unit volume)
  int refinement = 1;          ///< field cell = grid cell / refinement; cells have 9 nodes
  bool negative_outside = true;  ///< closest-point negative values outside all kernels (5.2.2)
  KernelDeformation deformation = KernelDeformation::kNone;
  double min_size_factor = 2.0 / 3.0;  ///< s_min / s_0 of eq. 5.11 (0 disables the lower clamp)
  double max_size_factor = 2.0;        ///< s_max / s_0 of eq. 5.11 (0 disables the upper clamp)
  EdgeLocation edge_location = EdgeLocation::kBisection;
  int bisection_steps = 1000;         ///< maximum bisection steps (4.4.5)
  double bisection_tolerance = 1e-4;  ///< stop when |H| < tolerance (4.4.5)
  bool remove_vertex_holes = true;    ///< 5.3.4
  double gaussian_sigma = 0.0;        ///< eq. 5.4-5.9, in field-node spacings; 0 = off
  int gaussian_size = 0;              ///< filter length n (odd); 0 = eq. 5.7
  /// Weighted median filter eq. 5.10: centre, edge and corner weights (a, b, c); all 0 = off.
  int median_weights[3] = {0, 0, 0};
};

/// The improved detector: volume-normalised field phi = sum_p V_p W_p(x) contoured at 0.5.
struct ImprovedConfig {
  KernelProfile profile = KernelProfile::kTriweight;
  /// Kernel radius a = radius_factor * initial_spacing in the reference state; S = F S0.
  double radius_factor = 3.0;
  double level = 0.5;
  /// A particle whose own phi(x_p) <= level + guard_margin keeps an ellipse
  /// F * disk(guard_factor * initial_spacing / 2) in the material (the field is max(phi, guard));
  /// 0 disables. With the automatic refinement this guarantees that such a particle lies inside
  /// the detected region (isolated points, thin filaments, sharp tips); particles with a larger
  /// phi are inside the exact level set with a margin the chords cannot undo in practice.
  double guard_factor = 0.6;
  double guard_margin = 0.02;
  /// Field cell = grid cell / refinement. 0 = automatic: the smallest refinement >= 4 whose cells
  /// fit in every active guard ellipse (cell diagonal <= smallest guard semi-axis), capped at
  /// max_refinement.
  int refinement = 0;
  int max_refinement = 32;
  SaddleRule saddle_rule = SaddleRule::kAsymptoticDecider;
  bool narrow_band = true;
  /// Narrow band: grid cells no kernel reaches are skipped (exact); cells whose corners and centre
  /// all have a field value > level + band_margin (interior) or < level - band_margin with no
  /// guarded particle inside (exterior) are skipped too, and the rest is dilated by one cell.
  /// The screening is a heuristic: sub-cell holes or islands it misses would differ from the
  /// full field (none found in the tests).
  double band_margin = 0.4;
  double root_tolerance = 1e-6;       ///< edge crossings to this fraction of the grid cell size
  bool curvature_correction = false;  ///< shift points outwards by kappa a^2 / (2 (2k + 3))
};

struct DetectorConfig {
  DetectorMethod method = DetectorMethod::kImproved;
  ThesisPfmConfig pfm;
  ImprovedConfig improved;
  /// Settings of the baseline detectors ("smm", "vof", "density"), validated by their owners.
  std::optional<nlohmann::json> baseline;
};

/// Parses {"method": "pfm" | "improved" | "smm" | "vof" | "density", "pfm": {...},
/// "improved": {...}, "smm"/"vof"/"density": {...}}; unknown keys throw InputError with the
/// JSON pointer.
DetectorConfig parse_detector_config(const JsonView& json);

/// Kernel shapes carried from step to step (thesis large-strain and clamped modes).
struct DetectorState {
  std::vector<Mat2> shape;                 ///< S per particle (columns: kernel axes), m
  std::vector<Mat2> previous_deformation;  ///< F at the previous call
  std::size_t n_calls = 0;
};

/// Wall-clock seconds per stage of the last detect() call, and counters.
struct DetectionTimings {
  double field = 0.0;
  double edge_points = 0.0;
  double connection = 0.0;
  double filters = 0.0;
  long field_evaluations = 0;  ///< exact field evaluations (nodes and root finding)
  long edge_point_count = 0;
  long root_evaluations = 0;  ///< field evaluations spent locating edge points
  int refinement = 0;         ///< refinement actually used
  long processed_cells = 0;   ///< field cells visited by the contouring
};

/// Detects the boundary of the body the particles represent on `grid` refined as configured.
/// Throws InputError for inconsistent input (span sizes, non-positive spacing).
DetectedBoundary detect(const ParticleCloud& cloud, const Grid& grid, const DetectorConfig& config,
                        DetectorState& state, DetectionTimings* timings = nullptr);

// ---- building blocks (exposed for tests and studies) ------------------------------------------

/// The improved detector's exact field max(phi, guard) at x (unit: volume fraction).
class ImprovedField {
 public:
  ImprovedField(const ParticleCloud& cloud, const ImprovedConfig& config);
  double operator()(const Vec2& x) const;
  /// phi alone (no guard), for studies.
  double volume_fraction(const Vec2& x) const;
  /// Largest kernel or guard reach, m.
  double reach() const { return reach_; }
  /// Smallest guard semi-axis over the particles, m (infinity without guard).
  double smallest_guard_axis() const { return smallest_guard_axis_; }
  /// E[t^2 | n = 0] = a^2 / (2k + 3) of the reference kernel, m^2: a boundary of curvature kappa
  /// is found kappa * curvature_moment() / 2 inside the true one (= kappa a^2 / 10 for k = 1).
  double curvature_moment() const { return curvature_moment_; }
  std::span<const Vec2> positions() const { return position_; }
  std::span<const double> reaches() const { return particle_reach_; }
  /// Half widths of the axis-aligned box around particle p outside which it adds nothing, m.
  Vec2 reach_box(std::size_t p) const { return reach_box_[p]; }
  bool guarded(std::size_t p) const { return guarded_[p] != 0; }
  /// Number of particles whose guard is active.
  std::size_t n_guarded() const { return n_guarded_; }

 private:
  std::vector<Vec2> position_;
  std::vector<Mat2> kernel_inverse_;   ///< S^-1
  std::vector<double> kernel_weight_;  ///< V_p C_p
  std::vector<Mat2> guard_inverse_;
  std::vector<char> guarded_;
  std::vector<Vec2> reach_box_;
  std::size_t n_guarded_ = 0;
  std::vector<double> particle_reach_;
  int exponent_ = 3;
  bool guard_ = true;
  double reach_ = 0.0;
  double smallest_guard_axis_ = 0.0;
  double curvature_moment_ = 0.0;
  ParticleBins bins_;
};

/// Weights of the thesis' discrete Gaussian filter (eq. 5.6-5.8): the normal density with standard
/// deviation sigma (in node spacings) integrated over each filter cell; size 0 takes n from
/// eq. 5.7.
std::vector<double> thesis_gaussian_weights(double sigma, int size);

/// Brent's method on [a, b] for a sign change of g (g(a) = value_a, g(b) = value_b); returns the
/// root parameter t in [0, 1] of x = a + t (b - a) to |dt| <= tolerance_t. Counts evaluations.
double brent_root(const std::function<double(double)>& g, double value_a, double value_b,
                  double tolerance_t, long* evaluations);

}  // namespace pfm

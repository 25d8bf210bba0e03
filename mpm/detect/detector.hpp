// Boundary detection from material points behind one entry point detect(): the thesis' Proximity
// Field Method (4.4, 5), an improved detector and three baselines (Surface Marker Method, Volume
// of Fluid, cell-density threshold).
//
//   particles (+ deformation gradients) -> field on a grid -> edge points -> contours
//
// Units: m for lengths, m^2 for particle volumes. The field grid is the grid given to detect()
// (usually the MPM grid) refined by an integer factor; open contours end on its edge.
#pragma once

#include <array>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "mpm/core/grid.hpp"
#include "mpm/core/json_input.hpp"
#include "mpm/core/particle_bins.hpp"
#include "mpm/core/types.hpp"
#include "mpm/detect/contour.hpp"
#include "mpm/detect/marching_squares.hpp"
#include "mpm/detect/vector_loops.hpp"

namespace pfm {

namespace detail {
/// The lattice of the grid's cells as the improved detector's sweep takes it.
inline CellLattice cell_lattice(const Grid& grid) {
  return {grid.origin.x(), grid.origin.y(), 1.0 / grid.cell_size, grid.n_cells_x, grid.n_cells_y};
}
}  // namespace detail

/// The material points seen by a detector. Spans are views; the caller owns the data.
struct ParticleCloud {
  std::span<const Vec2> position;              ///< m
  std::span<const double> volume;              ///< current volume, m^2 (per unit thickness)
  std::span<const Mat2> deformation_gradient;  ///< total F since the initial state; may be empty
  double initial_spacing = 0.0;                ///< particle spacing in the initial state, m
};

enum class DetectorMethod { kPfm, kImproved, kSmm, kVof, kDensity };

/// The method's name in configuration files and summaries: "pfm", "improved", "smm", "vof",
/// "density".
const char* detector_method_name(DetectorMethod method);

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
  /// the detected region (isolated points, thin filaments, sharp tips): the contours are checked,
  /// and a particle they leave outside gets a bridge in a second pass at the same refinement
  /// (join_spurious_loops), or, if still outside (or with "keep"), a pass with cells that fit in
  /// the guards. A particle with a larger phi is inside the exact level set, but the contour's
  /// chords can still cut it off where the level set curves within a fine cell, or miss an island
  /// smaller than a fine cell (a few stacked points): such particles are guarded for the second
  /// pass (Invariants.StackedPointsSmallerThanAFineCellAreGuardedInASecondPass).
  double guard_factor = 0.6;
  double guard_margin = 0.02;
  /// Field cell = grid cell / refinement. 0 = automatic: 4 (the bridges' pass too), and if the
  /// contours still leave a particle outside (the containment check tests every particle outside
  /// the interior cells, guarded or not), a last pass at the smallest refinement >= 4 whose cells
  /// fit in every active guard ellipse (cell diagonal <= smallest guard semi-axis), capped at
  /// max_refinement.
  int refinement = 0;
  int max_refinement = 32;
  SaddleRule saddle_rule = SaddleRule::kAsymptoticDecider;
  bool narrow_band = true;
  /// Narrow band: cells full of particle volume (>= 1 - 0.15 a0 / h of their area, or each
  /// 2 x 2 window of cells around their corners that full, and every cell within a kernel reach
  /// too) are interior without evaluating the field, and only the
  /// particles within reach of the other cells enter it (README of mpm/detect). Of those, cells
  /// no kernel reaches are skipped (exact); cells whose corners and centre all have
  /// phi > level + band_margin (interior) or < level - band_margin with no guarded particle
  /// inside (exterior) are skipped too. In the remaining ("active") cells the field is evaluated
  /// on a lattice of at most half a cell, and at every fine node in the cells with a guarded
  /// particle and the ring around them; the contours are traced, fine cell by fine cell, from every
  /// fine edge with a sign change on a lattice segment whose ends differ or on the grid edge, and
  /// from the guarded particles and the particles of islands that may hold no lattice node. Only
  /// particles outside the interior cells are tested for guards. The screenings and the lattice are
  /// heuristics: a hole smaller than the lattice, or an island without a particle, in an active
  /// cell away from the guards would be missed. The invariants test, the tests
  /// Determinism.NarrowBandEqualsFullField* and fuzz_detect check that the narrow band and the
  /// reference detector agree bitwise (random clouds, cracked blocks, windows of the failure
  /// states, the fuzzer's corpus). false: the reference detector (reference_detector.cpp), the
  /// definition written plainly, which evaluates the field at every fine node of the grid (much
  /// slower): the test oracle of the narrow band.
  double band_margin = 0.4;
  double root_tolerance = 1e-6;       ///< edge crossings to this fraction of the grid cell size
  bool curvature_correction = false;  ///< shift points outwards by kappa a^2 / (2 (2k + 3))
  /// The edges of the field grid are walls where the body rests on them: across an edge that no
  /// particle lies beyond, the particles within reach of it are mirrored if the edge is touched
  /// (a particle closer than one initial spacing) within their reach along it; across both
  /// edges at a corner too. A body resting on the grid edge (an MPM body on its fixed base or
  /// between roller sides) then has no boundary along it and its contour ends on the edge. No
  /// effect on a body clear of the edges (by more than a spacing) or cut by them.
  bool mirror_grid_edges = true;
  /// Kernel shape regularised by the neighbours, beta in [0, 0.9] (0 = off, the shape F S0 alone):
  /// S S^T = a0^2 F [(1 - beta) I + beta A] F^T. A has the principal axes of the second moment
  /// of the neighbours' offsets pulled back by F^-1 in the particle's own kernel window and, along
  /// each, min(1, 2 m / m1): m the fuller side's moment, m1 a full window's. Deep in a body and at
  /// a free surface A = I (the shape stays F S0); across a body thinner than about half the
  /// window the kernel narrows, never widens (a filament one particle thick: beta 0.7 joins it
  /// into one loop of its width, beta 0 leaves a guard island per particle). The guards narrow
  /// with their kernels, so the automatic refinement's cap becomes
  /// max_refinement / sqrt(1 - beta). Costs a neighbour search for each particle of the narrow
  /// band (README of mpm/detect).
  double neighbour_shape = 0.0;
  /// Largest stretch of a kernel: the kernels (and guards) take F with its singular values
  /// clamped to [1 / max_stretch, max_stretch] (same axes), so no kernel reaches more than
  /// max_stretch x a0, nor narrows below a0 / max_stretch, however the material deforms (the
  /// reach of the widest kernel sets the cost of every field evaluation). 0 = no cap.
  double max_stretch = 2.0;
  /// What the improved detector does with the loops that the particle spacing cannot resolve
  /// (loop_classes.hpp): true ("join", the default) runs the second contour pass at the first
  /// pass's refinement with bridges (ImprovedField::add_bridges()) from every particle the first
  /// contours left outside to each particle within 1.5 initial spacings of it, and from each
  /// particle of an island in contact with other material (a spurious island) to those particles
  /// of the other material within 1.5 spacings; then removes every hole into which no
  /// particle-free disk of one spacing fits (a spurious hole, with the loops inside it) and every
  /// material loop that holds no particle. If a particle is still outside, a third pass runs at
  /// the guards' refinement. false ("keep"): the contours of max(phi, guards) as they are, the
  /// second pass at the guards' refinement.
  bool join_spurious_loops = true;
};

/// How advect_surface_markers() treats grid nodes without mass, whose velocity (mv)_i / m_i of
/// eq. 4.7 is undefined.
enum class MasslessNodes {
  /// Left out; the weights of the nodes with mass are renormalised to sum to one (a marker in a
  /// cell without any node with mass does not move).
  kRenormalise,
  /// Taken literally as (mv)_i / m_i = 0: they pull the marker's velocity towards zero.
  kZero,
};

/// Surface Marker Method (thesis 3.4.1, 4.2): massless markers on the initial boundary, moved by
/// the grid velocities (eq. 4.6-4.7) and connected to the same neighbours for ever.
struct SmmConfig {
  /// Marker spacing along the initial contour, in grid cells (the thesis' slope: 0.25 m markers
  /// on 0.5 m cells).
  double marker_spacing = 0.5;
  /// Detector giving the initial contour the markers are placed on: kImproved or kPfm (the
  /// "improved" / "pfm" settings of the same configuration apply).
  DetectorMethod initial_contour = DetectorMethod::kImproved;
  MasslessNodes massless_nodes = MasslessNodes::kRenormalise;
};

/// What the volume of material in a cell is computed from (thesis eq. 4.8).
enum class VofFraction {
  kCount,   ///< eq. 4.8: particle count x initial_spacing^2 / cell area (the thesis)
  kVolume,  ///< sum of the current particle volumes in the cell / cell area
};

/// Volume of Fluid (thesis 3.4.2, 4.3): cell volume fractions, Sobel normals (eq. 3.36) and a
/// piecewise-linear interface (PLIC) in every mixed cell.
struct VofConfig {
  int refinement = 1;  ///< VOF cell = grid cell / refinement (4.3.1: the MPM grid or finer)
  /// Counts (the thesis): a full cell stays full while its points are compressed; volumes: a
  /// compressed cell becomes "mixed" and PLIC opens slivers of void inside the body.
  VofFraction fraction = VofFraction::kCount;
  /// Cells with a fraction <= tolerance are empty, >= 1 - tolerance full; the rest are mixed.
  double mixed_tolerance = 1e-9;
};

/// The density field the cell-density detector contours.
enum class DensityField {
  /// Nodal volume fraction sum_p V_p N_i(x_p) / A_i (linear hat functions; A_i the node's
  /// tributary area inside the grid, h^2 inside, h^2 / 2 on an edge, h^2 / 4 at a corner): the
  /// nodal mass of P2G divided by the mass that fills the node's share of the grid.
  kNodal,
  /// Cell volume fraction sum_{p in cell} V_p / h^2 (cb-geo/mpm's compute_cell_vol_fraction),
  /// averaged to the nodes over the (up to four) adjacent cells of the grid.
  kCell,
};

/// Cell-density threshold (the free-surface test of cb-geo/mpm and GeoTaichi): material where
/// the volume fraction exceeds `threshold`, contoured by marching squares.
struct DensityConfig {
  DensityField field = DensityField::kNodal;
  double threshold = 0.5;  ///< volume fraction (cb-geo flags particles below 0.65 - 0.70 of the
                           ///< full density, GeoTaichi below 0.76; 0.5 puts a flat face exactly)
  int refinement = 1;      ///< density cell = grid cell / refinement
};

struct DetectorConfig {
  DetectorMethod method = DetectorMethod::kImproved;
  ThesisPfmConfig pfm;
  ImprovedConfig improved;
  SmmConfig smm;
  VofConfig vof;
  DensityConfig density;
};

/// Parses {"method": "pfm" | "improved" | "smm" | "vof" | "density", "pfm": {...},
/// "improved": {...}, "smm": {...}, "vof": {...}, "density": {...}}; unknown keys throw
/// InputError with the JSON pointer.
DetectorConfig parse_detector_config(const JsonView& json);

/// State carried from call to call: kernel shapes (thesis large-strain and clamped modes) and the
/// Surface Marker Method's markers.
struct DetectorState {
  std::vector<Mat2> shape;                 ///< S per particle (columns: kernel axes), m
  std::vector<Mat2> previous_deformation;  ///< F at the previous call
  std::size_t n_calls = 0;
  /// Surface markers (kSmm), m: one polyline per initial contour, material on the left, fixed
  /// connectivity; markers_closed[k] tells whether polyline k closes on itself.
  std::vector<std::vector<Vec2>> markers;
  std::vector<bool> markers_closed;
  bool markers_placed = false;  ///< set by the first detect() with kSmm
  MasslessNodes massless_nodes = MasslessNodes::kRenormalise;  ///< copied from SmmConfig
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
  /// Improved detector: particles in its field (the narrow band leaves out the particles that
  /// cannot reach a cell next to the boundary), mirror images not counted.
  long field_particles = 0;
  /// Improved detector: particles its first contours left outside, guarded for a second pass.
  long particles_guarded_after_contouring = 0;
  /// Improved detector: particles (guarded or not) its first contours left outside; any makes
  /// a second pass (ImprovedConfig::join_spurious_loops).
  long particles_outside_first_contours = 0;
  /// Improved detector: bridges of its second pass (points and segments, ImprovedField).
  long bridges = 0;
  /// Improved detector: passes at the guards' refinement (0 or 1).
  long guard_refinement_passes = 0;
  /// Improved detector: spurious holes (with the loops inside them) and empty material loops
  /// removed (ImprovedConfig::join_spurious_loops).
  long spurious_loops_removed = 0;
  /// Improved detector: the parts of `field`, s. survey: the one sweep over every particle;
  /// band: the cells interior by volume and the copy of the particles within reach of the
  /// others; setup: the field's slots, bins and mirror images; screening: the coarse
  /// deep/far/active cells; guards: phi at the candidate particles; nodes: the fine nodes of the
  /// active cells and of the traced cells; shape: the kernel shapes of the field's particles from
  /// their neighbours (ImprovedConfig::neighbour_shape > 0).
  struct FieldParts {
    double survey = 0.0, band = 0.0, setup = 0.0, screening = 0.0, guards = 0.0, nodes = 0.0;
    double shape = 0.0;
  } field_parts;
};

/// Detects the boundary of the body the particles represent on `grid` refined as configured.
/// Throws InputError for inconsistent input (span sizes, non-positive spacing).
///
/// kSmm: the first call places markers on the contour of the initial particles (the detector of
/// SmmConfig::initial_contour) resampled at SmmConfig::marker_spacing and stores them in
/// `state`; every call returns the current markers as contours (the particles are not used
/// again). Without advect_surface_markers() between the calls they stay where they were placed.
DetectedBoundary detect(const ParticleCloud& cloud, const Grid& grid, const DetectorConfig& config,
                        DetectorState& state, DetectionTimings* timings = nullptr);

/// Surface Marker Method, thesis eq. 4.6-4.7: moves every marker of `state` by
/// x += v(x) dt, v(x) = sum_i N_i(x) v_i with the bilinear shape functions N_i of `grid`, the
/// nodal velocities v_i = (mv)_i / m_i after the grid update (node_velocity, m/s) and the nodal
/// masses (node_mass, t; > 0 marks a node with mass). Nodes without mass follow
/// state.massless_nodes. Markers outside the grid do not move. Call it after every grid update
/// with that step's dt (s); it does nothing before detect() with kSmm has placed markers.
/// Throws InputError unless both spans have grid.n_nodes() entries.
///
/// Known failure (thesis 4.2.2), measured by studies/detectors: the markers keep their initial
/// neighbours, so they cannot follow a change of topology (tearing, new surfaces, soil folding
/// onto itself: loops may cross), and they drift apart where the surface stretches, leaving
/// long chords; nothing re-seeds them.
void advect_surface_markers(DetectorState& state, const Grid& grid,
                            std::span<const Vec2> node_velocity, std::span<const double> node_mass,
                            double dt);

/// Resamples a polyline at (nearly) uniform arc length: ceil(length / spacing) points for a
/// closed polyline (at least 3), ceil(length / spacing) + 1 for an open one (ends kept); the
/// first point is kept. Used to place the surface markers.
std::vector<Vec2> resample_polyline(std::span<const Vec2> points, bool closed, double spacing);

// ---- building blocks (exposed for tests and studies) ------------------------------------------

/// The improved detector's exact field max(phi, guard) at x (unit: volume fraction).
class ImprovedField {
 public:
  /// Tag of the constructor that leaves the guards undecided (see decide_guards()).
  struct DeferGuards {};
  /// A point's sum visits the bins kBinRings rings around its own; bins are the largest reach /
  /// kBinRings.
  static constexpr int kBinRings = 2;
  /// The fixed-point unit of a field that holds part of a cloud (the narrow band) comes from the
  /// whole cloud, so that its sums are bitwise those of a field holding every particle (the sums
  /// do not depend on the order of their terms, vector_loops.hpp).
  struct CloudBounds {
    /// Bound of the largest kernel weight V_p C_p of the whole cloud (weight_bound()).
    double weight_bound;
    /// Bound of the number of slots of the whole cloud (4 per particle: itself and up to three
    /// mirror images): the unit keeps the sum of all weights below 2^63.
    std::size_t slot_bound;
  };
  /// Kernel data by slot, one array per quantity, each padded with detail::kKernelPadding zeros
  /// (the sums read four slots at a time).
  struct KernelArrays {
    std::vector<double> x, y;                ///< centre, m
    std::vector<double> k00, k01, k10, k11;  ///< S^-1, 1/m
    std::vector<double> weight;              ///< V_p C_p x 2^fixed_point_bits()
    std::vector<double> half_x, half_y;      ///< half widths of the box around kernel and guard, m
    /// The slots whose guard is active, increasing: the guards are few, and a field evaluation
    /// visits only those among its slots instead of testing every slot.
    std::vector<int> guarded_slots;
    std::size_t size() const { return n_; }
    /// n slots (zeros, no guard), padding included.
    void assign_zeros(std::size_t n);
    /// The slots `slots` of `from`, in that order: the columns the sums read (x to weight) and
    /// the guarded ones among them, not the half widths, which are left empty.
    void gather(const KernelArrays& from, std::span<const int> slots);

   private:
    static constexpr std::size_t kSummedColumns = 7;  ///< x .. weight, first in columns()
    std::array<std::vector<double>*, 9> columns() {
      return {&x, &y, &k00, &k01, &k10, &k11, &weight, &half_x, &half_y};
    }
    std::array<const std::vector<double>*, 9> columns() const {
      return {&x, &y, &k00, &k01, &k10, &k11, &weight, &half_x, &half_y};
    }
    std::size_t n_ = 0;
  };

  /// `walls`: the field grid whose edges mirror the particles (ImprovedConfig::mirror_grid_edges);
  /// nullptr: none.
  ImprovedField(const ParticleCloud& cloud, const ImprovedConfig& config,
                const Grid* walls = nullptr);
  /// Which grid edges are walls (no particle beyond) and, in bins of one initial spacing along
  /// each, where a particle touches it (closer than a spacing): see mirror_grid_edges.
  struct WallContacts {
    bool wall[4] = {false, false, false, false};  ///< left, right, bottom, top
    std::vector<char> touched[4];
  };
  /// Reach of an undeformed particle, m: its kernel's (radius_factor x spacing) or its guard's
  /// support (sqrt 2 guard radius), whichever is larger; a particle with largest stretch s
  /// reaches s times as far.
  static double reference_reach(const ImprovedConfig& config, double initial_spacing);
  /// Reach of an undeformed particle's guard, m: sqrt 2 guard radius (0 without guards).
  static double reference_guard_reach(const ImprovedConfig& config, double initial_spacing);
  /// The contacts of the particles at `positions` (bounding box lo, hi) with the edges of `walls`:
  /// the bins of one `spacing` along each edge holding a particle closer to it than `distance`
  /// (m; 0: one spacing, the field's mirrors).
  static WallContacts find_wall_contacts(std::span<const Vec2> positions, const Vec2& lo,
                                         const Vec2& hi, const Grid& walls, double spacing,
                                         double distance = 0.0);
  /// Across which edges of `walls` a particle at x whose kernel and guard reach half_x, half_y
  /// (m) is mirrored: {0 left, 1 right or -1 none; 0 bottom, 1 top or -1 none}. Across a wall
  /// that the particle reaches, where the body touches it within half_along along it.
  static std::array<int, 2> mirror_sides(const WallContacts& contacts, const Grid& walls,
                                         const Vec2& x, double half_x, double half_y,
                                         double spacing);
  /// Trusts the cloud (detect() has checked it). `bounds`: nullptr = those of the cloud itself.
  /// `contacts`: nullptr = those of the cloud's own particles; the narrow band passes those of
  /// the whole cloud, of which it holds a part.
  ImprovedField(const ParticleCloud& cloud, const ImprovedConfig& config, DeferGuards,
                const Grid* walls = nullptr, const CloudBounds* bounds = nullptr,
                const WallContacts* contacts = nullptr);
  /// Guards the particles p with candidate[p] != 0 (all when empty) whose phi(x_p) is
  /// <= level + guard_margin; the narrow band passes the particles outside the interior cells.
  /// Call once, before evaluating the field.
  void decide_guards(std::span<const char> candidate);
  /// Switches the guard on for `particles` whatever their phi (the detector's second pass, for
  /// particles its first contours left outside).
  /// Returns how many were not guarded before.
  std::size_t add_guards(std::span<const std::size_t> particles);

  /// Bridges, for the detector's second pass: keeps the square of half side `cell` (m, the fine
  /// cell) around each particle of `points` in the material, and a strip of that half width along
  /// the segment between the two particles of each of `pairs`. The field is max(phi, guards,
  /// level (2 - d / (1.25 cell))), d the Chebyshev distance to the particle or segment: every
  /// fine node within `cell` of it is inside, so the four corners of the fine cell that holds the
  /// particle, or any point of the segment, are. Adds to the bridges already there.
  void add_bridges(std::span<const std::size_t> points,
                   std::span<const std::array<std::size_t, 2>> pairs, double cell);
  /// Number of bridges (points and segments).
  std::size_t n_bridges() const { return bridges_.a.size(); }

  double operator()(const Vec2& x) const;
  /// The slots (kernels and guards) whose support box meets the box lo..hi, copied into `out`:
  /// the terms of operator() at any point of the box that are not exact zeros.
  void slots_reaching(const Vec2& lo, const Vec2& hi, KernelArrays& out) const;
  /// operator() at x summed over `slots` only (from slots_reaching() for a box holding x):
  /// bitwise equal to operator(), without visiting the bins' other candidates.
  double operator()(const Vec2& x, const KernelArrays& slots) const;
  /// A bound of the largest kernel weight V_p C_p of particles with volume <= largest_volume
  /// and det F >= smallest_det (1 without F), as the constructor computes the weights.
  static double weight_bound(const ImprovedConfig& config, double initial_spacing,
                             double largest_volume, double smallest_det);
  /// s of the fixed-point unit 2^-s of the kernel sums (detail::kernel_sum()).
  int fixed_point_bits() const { return fixed_point_bits_; }
  /// max(guards, bridges) at x (0 without them): operator() is max(phi, this), so a value of
  /// operator() taken before guards or bridges were added becomes its value now by a maximum
  /// with it.
  double guards_and_bridges(const Vec2& x) const;
  /// phi alone (no guard), for studies.
  double volume_fraction(const Vec2& x) const;
  /// Whether volume_fraction(x) > threshold: the same answer, found from the bin rows nearest x
  /// first, stopping as soon as their partial sum exceeds the threshold (the terms are >= 0).
  bool volume_fraction_above(const Vec2& x, double threshold) const;
  /// Largest kernel or guard reach, m.
  double reach() const { return reach_; }
  /// Smallest guard semi-axis over the particles, m (infinity without guard).
  double smallest_guard_axis() const { return smallest_guard_axis_; }
  /// E[t^2 | n = 0] = a^2 / (2k + 3) of the reference kernel, m^2: a boundary of curvature kappa
  /// is found kappa * curvature_moment() / 2 inside the true one (= kappa a^2 / 10 for k = 1).
  double curvature_moment() const { return curvature_moment_; }
  std::span<const Vec2> positions() const { return position_; }
  std::span<const double> reaches() const { return particle_reach_; }
  /// Half widths of the axis-aligned box around particle p outside which it adds nothing (its
  /// guard included, whether active or not), m.
  Vec2 reach_box(std::size_t p) const { return reach_box_[p]; }
  bool guarded(std::size_t p) const { return guarded_[p] != 0; }
  /// Number of particles whose guard is active.
  std::size_t n_guarded() const { return n_guarded_; }
  /// Number of mirror images across the grid edges (see ImprovedConfig::mirror_grid_edges).
  std::size_t n_mirrored() const { return slot_.size() - position_.size(); }

 private:
  void switch_guard_on(std::size_t p);
  // Rebuilds slot_.guarded_slots from guarded_ (after guards were switched on).
  void list_guarded_slots();
  // The sum over the slot ranges [begin[r], end[r]) of `kernels` at x: phi (fixed point
  // converted back) and, with `guard`, max(phi, guard).
  double sum_ranges(const KernelArrays& kernels, const int* begin, const int* end, int n_ranges,
                    const Vec2& x, bool guard) const;
  // max(bridges, guards) at x (0 without them), the guards among the slots of those ranges.
  double raised_by(const KernelArrays& kernels, const int* begin, const int* end, int n_ranges,
                   const Vec2& x) const;
  double sum_at(const Vec2& x, bool guard) const;

  // The bridges of add_bridges(): segments a-b (a point: a == b), binned in squares of side bin
  // (each segment listed in every bin its support box meets).
  struct Bridges {
    std::vector<Vec2> a, b;
    double half = 0.0;  ///< Chebyshev half width of the part inside (1.25 fine cells), m
    Vec2 origin = Vec2::Zero();
    double bin = 0.0;
    int n_x = 0, n_y = 0;
    std::vector<int> start, item;  ///< bin k lists item[start[k] .. start[k + 1] - 1]
    /// The largest bridge value at x (0 outside every support), for contour level `level`.
    double value(const Vec2& x, double level) const;
  };
  Bridges bridges_;

  // Per particle, by particle index.
  std::vector<Vec2> position_;
  std::vector<char> guarded_;
  std::vector<Vec2> reach_box_;
  std::vector<double> particle_reach_;
  std::vector<double> kernel_reach_;      ///< largest kernel semi-axis, m
  std::vector<double> smallest_stretch_;  ///< smallest singular value of F
  // Per particle and mirror image in bin order (slot k holds bins_.particle_at(k); indices past
  // the particles are mirror images): what the evaluations read.
  KernelArrays slot_;
  int fixed_point_bits_ = 0;
  double fixed_point_unit_ = 1.0;  ///< 2^-fixed_point_bits_
  std::size_t n_guarded_ = 0;
  int exponent_ = 3;
  bool guard_ = true;
  double level_ = 0.5;
  double guard_margin_ = 0.02;
  double guard_radius_ = 0.0;  ///< rho0 = guard_factor * initial_spacing / 2, m
  double guard_scale_ = 0.0;   ///< a0 / rho0: the guard ellipse is the kernel's scaled by it
  double reach_ = 0.0;
  double smallest_guard_axis_ = 0.0;
  double curvature_moment_ = 0.0;
  int rings_ = kBinRings;  ///< bins searched around a point (bin size = reach / rings)
  ParticleBins bins_;
};

/// Weights of the thesis' discrete Gaussian filter (eq. 5.6-5.8): the normal density with standard
/// deviation sigma (in node spacings) integrated over each filter cell; size 0 takes n from
/// eq. 5.7.
std::vector<double> thesis_gaussian_weights(double sigma, int size);

/// Brent's method on [a, b] for a sign change of g (g(a) = value_a, g(b) = value_b); returns the
/// root parameter t in [0, 1] of x = a + t (b - a) to |dt| <= tolerance_t (an end where g is 0:
/// tolerance_t from it). Counts evaluations.
double brent_root(const std::function<double(double)>& g, double value_a, double value_b,
                  double tolerance_t, long* evaluations);

}  // namespace pfm

// The detectors' configuration: which method, and each method's settings, as a case file or a
// detector configuration file gives them (mpm/detect/README.md lists every key, unit and default).
// What reads configurations includes this header only; the detectors' entry point is detector.hpp.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "mpm/core/json_input.hpp"
#include "mpm/core/types.hpp"
#include "mpm/detect/marching_squares.hpp"  // SaddleRule

namespace pfm {

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
  /// Field cell = grid cell / refinement. 0 = automatic: 4, or finer where half a spacing is
  /// less than h / 4 (2 n at n x n points per cell; the bridges' pass too), and if the contours
  /// still leave a particle outside (the containment check tests every particle outside the
  /// interior cells, guarded or not), a last pass at the smallest refinement at least that whose
  /// cells fit in every active guard ellipse (cell diagonal <= smallest guard semi-axis), capped
  /// at max_refinement (detail::pass_refinement).
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

}  // namespace pfm

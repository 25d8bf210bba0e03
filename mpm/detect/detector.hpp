// Boundary detection from material points behind one entry point detect(): the thesis' Proximity
// Field Method (4.4, 5), an improved detector and three baselines (Surface Marker Method, Volume
// of Fluid, cell-density threshold).
//
//   particles (+ deformation gradients) -> field on a grid -> edge points -> contours
//
// Units: m for lengths, m^2 for particle volumes. The field grid is the grid given to detect()
// (usually the MPM grid) refined by an integer factor; open contours end on its edge.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "mpm/core/grid.hpp"
#include "mpm/core/types.hpp"
#include "mpm/detect/contour.hpp"
#include "mpm/detect/detector_config.hpp"

namespace pfm {

/// The material points seen by a detector. Spans are views; the caller owns the data.
struct ParticleCloud {
  std::span<const Vec2> position;              ///< m
  std::span<const double> volume;              ///< current volume, m^2 (per unit thickness)
  std::span<const Mat2> deformation_gradient;  ///< total F since the initial state; may be empty
  double initial_spacing = 0.0;                ///< particle spacing in the initial state, m
};

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

}  // namespace pfm

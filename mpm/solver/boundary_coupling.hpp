// The MPM step coupled with boundary detection and loads on the detected boundary (thesis 6.2).
//
// In the external-force stage of step n (particles at time t_n, nodal masses known):
//   1. detect    every `detection.every_steps` steps, when some point has moved more than
//                `detection.max_motion` x h since the last detection (and whenever an output
//                needs a fresh boundary), the detector of the case runs on the particles
//                (positions, current volumes, deformation gradients); between detections the
//                last boundary is used;
//   2. bezier    each surface load builds its composite curves from the contours (its "curve");
//   3. traction  the load at the time function's factor is integrated into nodal forces,
//                f_I = int N_I t dGamma (mpm/boundary/surface_load.hpp), and added to the grid.
// After the grid update the Surface Marker Method's markers (if that detector runs) ride on the
// updated grid velocities.
//
// Load intervals carried by the material (interval "material"): at the start, each end x_e of
// x_range is tied to the particle of the body's top layer whose x is closest to x_e (ties: the
// lower id); the end then moves with that particle's horizontal displacement.
//
// Lost load (without the ties of nearly empty nodes, mpm/core/basis_extension.hpp: with them
// every load goes to its nodes and the solver passes the tied nodes' loads on through the ties,
// so nothing is lost or redistributed). A node is too light to carry a load when its mass is
// <= min_node_mass_fraction x a full cell's (the densest particle's density x h^2). With
// redistribute_lost_load (the default), such a node that receives a load carries no force of its
// own at all: the load and its internal force are both moved to the nearest heavier nodes,
// conserving the sum and the moment (surface_load.hpp); only its own gravity stays. Moving the load
// alone would leave the internal force, which the load balances where the stress is what the load
// demands, to accelerate a node of tiny mass, and the points next to it would be off the stress
// the load demands (test_boundary_coupling's free square under a follower pressure).
//
// Diagnostics per step and load (kN/m): target = the exact resultant of the load on the loaded
// parts of the curves; applied = the sum of the nodal forces on the grid; lost = the part on
// nodes too light to carry it (reported before moving), with its moment about (0, 0).
// applied + off-grid = target to round-off.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include "mpm/boundary/bezier.hpp"
#include "mpm/boundary/surface_load.hpp"
#include "mpm/core/stress_recovery.hpp"
#include "mpm/detect/detector.hpp"
#include "mpm/solver/boundary_constraint.hpp"
#include "mpm/solver/checkpoint.hpp"
#include "mpm/solver/mpm_solver.hpp"
#include "mpm/step/case.hpp"

namespace pfm {

/// Summed over the detected-boundary loads, at the last step that applied them (kN/m).
struct SurfaceLoadDiagnostics {
  Vec2 target = Vec2::Zero();
  Vec2 applied = Vec2::Zero();
  Vec2 lost = Vec2::Zero();
  double lost_moment = 0.0;  ///< kN m/m about (0, 0) of `lost`
  Vec2 off_grid = Vec2::Zero();
  int loaded_nodes = 0;
  int lost_nodes = 0;
};

/// Wall-clock seconds of the coupling's stages, accumulated over the run.
struct CouplingTimes {
  double detect = 0.0;
  double bezier = 0.0;
  double traction = 0.0;
  double constraint = 0.0;  ///< the constraints on the detected boundary
  long detections = 0;
  /// Due detections skipped because no point had moved more than max_motion x h.
  long kept = 0;
  /// Improved detector, over the run (DetectionTimings): detections whose second pass bridged
  /// particles left outside or islands in contact, the bridges, the spurious loops removed, the
  /// passes at the guards' refinement, and the most loops of one boundary.
  long bridged_detections = 0;
  long bridges = 0;
  long spurious_loops_removed = 0;
  long guard_refinement_passes = 0;
  long most_loops = 0;
};

class BoundaryCoupling {
 public:
  /// Does nothing unless the case has a detection block, detected-boundary loads or
  /// constraints.
  explicit BoundaryCoupling(const Case& c);
  BoundaryCoupling(const BoundaryCoupling&) = delete;
  BoundaryCoupling& operator=(const BoundaryCoupling&) = delete;

  bool detection_enabled() const { return case_.detection.has_value(); }
  bool has_surface_loads() const { return !loads_.empty(); }
  /// The constraints on the detected boundary (boundary_constraint.hpp) and their last reports.
  const BoundaryConstraints& constraints() const { return constraints_; }

  /// Installs the solver hooks, which see the step through a StepView only (no pointer to the
  /// solver is kept). Ties material-carried load intervals to their particles (call after
  /// initialise_stress: the particles' reference positions are then final).
  void attach(MpmSolver& solver);

  /// The boundary of the particles as `now` has them (detects unless the last detection was
  /// at its step).
  const DetectedBoundary& current_boundary(const StepView& now);
  const SurfaceLoadDiagnostics& diagnostics() const { return diagnostics_; }
  /// The particles' spacing in the initial state, m (the loops' classes take it).
  double initial_spacing() const { return initial_spacing_; }
  const CouplingTimes& times() const { return times_; }
  const DetectionTimings& last_detection_timings() const { return detection_timings_; }
  /// The nodal forces of the surface loads at the last step (kept when the case asks for
  /// output.nodal_loads), summed over the loads, sorted by node.
  const std::vector<boundary::NodalForce>& nodal_forces() const { return nodal_forces_; }
  /// The x_range of surface load k at the last step (moved with the material for interval
  /// "material"); none for a load without x_range.
  std::optional<Vec2> current_x_range(std::size_t k) const { return current_range_[k]; }
  /// Checkpoints: the detector's state (kernel shapes, markers), the last boundary and when it
  /// was found, and the particles that carry material intervals.
  void save(CheckpointFile& file) const;
  /// Restores what save() wrote for the state `now` (its particles and step); call after
  /// attach().
  void restore(const CheckpointFile& file, const StepView& now);
  /// The points of the boundary of `now` (current_boundary) where the traction is known, for
  /// the stress recovery (mpm/core/stress_recovery.hpp): the points of each detected-boundary
  /// load's parts with its traction at `now`; the parts that a grid-top load covers (upward
  /// faces seen from above, over its x_range) with its vertical pressure; every other point of
  /// the boundary with zero traction (a free surface), except the points of a constraint's part
  /// and the points within 3/4 of a cell of a node with a fixed component (a support), where the
  /// traction is the unknown reaction. The exact rule's quadrature points
  /// (BoundaryLoadIntegrator::quadrature_points), each standing for its weight's length.
  std::vector<TractionSample> traction_samples(const StepView& now,
                                               std::span<const unsigned> fixed);
  /// Ids of the particles that carry the ends of material load intervals (-1: fixed interval).
  std::vector<std::array<long, 2>> interval_particles() const;

 private:
  struct SurfaceLoad {
    std::size_t case_index = 0;
    boundary::BoundaryLoadSpec spec;
    TimeFunction time_function;
    std::array<long, 2> end_particle = {-1, -1};
    std::array<double, 2> end_x0 = {0.0, 0.0};  ///< the ends' particles' initial x, m
  };

  /// A boundary the detector found: the step it was found at, and the particles' positions
  /// then.
  struct Detection {
    long step = 0;
    DetectedBoundary boundary;
    std::vector<Vec2> positions;  ///< m
    /// Its composite curves of the kind last asked for (curves()).
    std::optional<boundary::CurveKind> curve_kind;
    std::vector<boundary::CompositeBezier> curves;
  };

  /// The detection the step's loads and constraints act on: a new one when due (header
  /// comment), else the last.
  Detection& detection_for(const StepView& step);
  void detect_now(const StepView& step);
  /// Whether a point has moved more than detection.max_motion x h since the last detection
  /// (true before the first one, and always with max_motion 0).
  bool moved_since_detection(const Particles& particles) const;
  void apply_loads(const StepView& step, Detection& detection, GridState& grid_state,
                   std::vector<Vec2>& force);
  /// The composite curves of kind `kind` through a detection's boundary (built once per
  /// detection and kind).
  const std::vector<boundary::CompositeBezier>& curves(Detection& detection,
                                                       boundary::CurveKind kind);
  void tie_material_intervals(const Particles& particles);

  const Case& case_;
  double initial_spacing_ = 0.0;
  std::vector<SurfaceLoad> loads_;
  DetectorState detector_state_;
  DetectionTimings detection_timings_;
  std::optional<Detection> detection_;  ///< the last (none before the first)
  boundary::BoundaryLoadIntegrator integrator_;
  BoundaryConstraints constraints_;
  SurfaceLoadDiagnostics diagnostics_;
  CouplingTimes times_;
  std::vector<boundary::NodalForce> nodal_forces_;
  std::vector<std::optional<Vec2>> current_range_;
};

}  // namespace pfm

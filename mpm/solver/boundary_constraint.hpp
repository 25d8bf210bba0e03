// Essential conditions on the detected boundary (case-file "constraints"): the displacement of
// the material on a part of the boundary the detector finds is held at a prescribed value,
// while that part moves through the grid. The thesis leaves this open (7.2); no explicit MPM
// code does it on a detected boundary (cb-geo and Anura3D constrain grid nodes, NairnMPM moves
// rigid particles).
//
// The gap. At a point x of the boundary the material's displacement is taken from the grid:
//   u_I = sum_p m_p N_I(x_p) (u_p + G_p (x_I - x_p)) / sum_p m_p N_I(x_p),
//   u_h(x) = sum_I N_I(x) u_I / sum_I N_I(x)   (both sums over the nodes the particles reach),
// with u_p = x_p - X_p the particle's displacement since time 0 and G_p = I - F_p^-1 its
// displacement gradient: each particle extrapolates its own affine field to the node, so u_h
// is exact wherever the displacement is affine (a homogeneous strain, a rigid translation),
// also on nodes that the body only partly covers. N_I are the grid functions of the loads
// (bilinear for linear and uGIMP, the B-splines otherwise; surface_load.hpp). The gap is
// g(x) = P (u_h(x) - u_bar), P = n n^T (normal_only, n the outward normal of the detected
// curve at x, u_bar = value n) or the identity, and u_bar the prescribed displacement: value x
// the time function, or for a velocity the integral of value x the time function over the
// steps taken (midpoint rule, kept in the checkpoint).
//
// The penalty method. A traction t = -beta g acts on the part: the nodal forces are
// P_I = -beta int N_I g dGamma, integrated with the loads' rule (exact on the pieces of the
// curve between cell edges; BoundaryLoadIntegrator::quadrature_points). A penalty stiff enough
// to be accurate (beta ~ 100 M / h, M = lambda + 2 mu) makes k_I / m_I of a boundary node, and
// of a node the body barely reaches above all, far beyond what the explicit step can take.
// So the stiffness is taken implicitly on each node's diagonal: with the lumped stiffness
// K_I = beta int N_I P dGamma (2 x 2) and b_I = beta int N_I P v_bar dGamma (v_bar the
// prescribed velocity over the step), the node's velocity after the step solves
//   (m_I + dt^2 K_I) v_I' = p_I + dt (f_I + P_I) + dt^2 b_I,
// and the force the constraint exerts is F_I = P_I - dt (K_I v_I' - b_I), which goes to the
// grid's external force (f_I: the internal force and the other external forces before it;
// the local damping then acts on the sum as on any force). For one node this is backward
// Euler on the spring; with the off-diagonal stiffness explicit, a mode of the lumped
// stiffness K_L and the consistent K has (m + dt^2 k_L) z^2 - (2 m + dt^2 (k_L - k)) z + m = 0,
// whose roots lie in the unit disk for every beta because k_L >= k >= 0: no time step limit
// beyond the soil's, and the error falls as 1 / beta (the penalty's compliance, h / (factor L)
// for a bar of length L) down to the rounding of the gap.
//
// The force on the body from each constraint (the sum of its F_I, kN/m) is the reaction that
// the time series reports (constraint_<k>_fx, _fy) with the root-mean-square gap along the
// part (constraint_<k>_gap, m); the work of F_I with the nodes' mid-step velocities is the
// ledger's constraint_work (the solver books it, LoadWorkRecorder). Components fixed by a
// support take no constraint force (the support holds them). Nodes of mass <= tiny (the
// solver's threshold) take none either: nothing there to push.
// Units: kN, m, s, t, kPa.
#pragma once

#include <vector>

#include "mpm/boundary/surface_load.hpp"
#include "mpm/solver/case.hpp"
#include "mpm/solver/mpm_solver.hpp"

namespace pfm {

class BoundaryConstraints {
 public:
  /// The constraints of the case; `first_recorder_index`: where their work goes in the solver's
  /// LoadWorkRecorder (after the loads).
  explicit BoundaryConstraints(const Case& c);

  bool empty() const { return specs_.empty(); }
  std::size_t size() const { return specs_.size(); }

  /// Adds the constraints' forces of step `step` to `force`, for the boundary `curves` of each
  /// constraint's curve kind (built by `curves_for`); records them for the work.
  template <class CurvesFor>
  void apply(const StepView& step, GridState& grid_state, std::vector<Vec2>& force,
             CurvesFor&& curves_for) {
    if (specs_.empty()) return;
    project_displacement(step.particles, grid_state.mass.size());
    for (std::size_t k = 0; k < specs_.size(); ++k)
      apply_one(k, step, grid_state, force, curves_for(specs_[k].part.curve));
  }

  const std::vector<ConstraintReport>& reports() const { return reports_; }
  /// The prescribed displacement of each constraint now (its u_bar at full vector; for
  /// normal_only (value, 0)), m: the state a checkpoint keeps.
  const std::vector<Vec2>& target() const { return target_; }
  void set_target(const std::vector<Vec2>& target) { target_ = target; }

 private:
  void project_displacement(const Particles& particles, std::size_t n_nodes);
  void apply_one(std::size_t k, const StepView& step, GridState& grid_state,
                 std::vector<Vec2>& force, const std::vector<boundary::CompositeBezier>& curves);
  /// The grid functions at x (stencil of the loads' functions), into stencil_.
  void functions_at(const Vec2& x);

  Grid grid_;
  int degree_ = 1;
  std::size_t n_loads_ = 0;
  std::vector<ConstraintSpec> specs_;
  boundary::BoundaryLoadIntegrator integrator_;
  std::vector<Vec2> target_;  // u_bar per constraint
  std::vector<ConstraintReport> reports_;
  // Scratch.
  ShapeStencil stencil_;
  std::vector<double> node_weight_;       // sum_p m_p N_I(x_p)
  std::vector<Vec2> node_displacement_;   // u_I (after the division)
  std::vector<boundary::CurvePoint> points_;
  std::vector<Vec2> penalty_force_;       // P_I
  std::vector<Mat2> stiffness_;           // K_I
  std::vector<Vec2> target_rate_;         // b_I
  std::vector<char> touched_flag_;
  std::vector<int> touched_;
};

}  // namespace pfm

// Essential conditions on the detected boundary (case-file "constraints"): the displacement of
// the material on a part of the boundary the detector finds is held at a prescribed value,
// while that part moves through the grid. The thesis leaves this open (7.2); cb-geo and
// Anura3D constrain grid nodes, NairnMPM moves rigid particles.
//
// The gap. At a point x of the part, the material's displacement is the value at x of the
// weighted least-squares linear fit u(x_p) ~ a + B (x_p - x) to the particles' displacements
// u_p = x_p - X_p, with weights w_p = m_p sum_J N_J(x) N_J(x_p) (the particles that share a node
// with x; on a part with an x_range, only those over it: the material beside a part is not
// the part's, and under a footing's edge it heaves while the material under the footing
// follows the footing, so a fit across the edge reads a gap neither side has). A particle's
// weight fades to zero over the last half cell inside the x_range's ends (smoothstep of its
// distance from the end over h / 2): material crossing the end leaves the fit, and the nodes'
// shares below, gradually, not in one step that the penalty would turn into a jump of its
// force. The fit is exact wherever the displacement is affine (a homogeneous strain, a
// translation), also on a face whose particles all lie on one side of x, and it uses positions
// only, not the particles' F.
// Its sums are per-node moments (the mass and the moments of x_p - x_J, u_p, the motion since
// the detection and the stress, for Nitsche's method), taken once a step over the particles
// near the parts, and shifted to x; where the points within reach lie on a line, the weighted
// mean is taken. N_J are the loads' grid functions (bilinear for linear and uGIMP, the B-splines
// otherwise). The gap is g = P (u - u_bar): P = n n^T with n the part's normal-window direction
// (a face: the corners of two constrained faces then hold both) or the curve's normal, for
// normal_only; else the identity. u_bar is the prescribed displacement (value x time function),
// or for a velocity its integral over the steps taken (midpoint rule; kept in the checkpoint).
// Between two detections the part moves with the material: each of its points x_0 (on the
// curves last detected) is taken at x_0 + n (n . d(x_0)), with n the curve's normal and d the
// same fit to the particles' motion since that detection (x_p now less x_p then); sliding along
// itself leaves the curve unchanged to first order. The gap under a stiff constraint is a small
// fraction of a cell; read at the detected points it would lag by the strain times the motion
// since the detection (up to max_motion x h), then jump back at the next detection.
//
// The penalty method. A traction t = -beta g acts on the part, integrated with the loads' rule
// (BoundaryLoadIntegrator::quadrature_points, exact on the pieces between cell edges); each
// point's force goes to the nodes with mass in the shares s_I(x) = N_I(x) r_I / sum_J N_J(x) r_J
// (over the nodes with mass): P_I = -beta int s_I g dGamma. r_I is the part's share of node I's
// mass, sum_p a_p m_p N_I(x_p) / sum_p m_p N_I(x_p) over the particles near the part, a_p the
// particle's share in the part (1 over its x_range, fading at the ends as above; 1 for every
// particle of a part without an x_range, where s_I = N_I(x) / sum_J N_J(x)). A node that
// carries mostly the material beside a part moves what the fit does not see: a force on it
// would not relax the gap it acts on (under a footing's edge, with B-splines, whose functions
// reach one and a half cells past the edge, it drove the heave down and the reaction into
// spikes). A penalty stiff enough to be accurate (beta ~ 100 M / h, M = lambda + 2 mu) makes
// k_I / m_I of a boundary node far larger than the explicit step can take, so the stiffness is
// implicit on each node's diagonal: with K_I = beta int s_I P and b_I = beta int s_I P v_bar
// (v_bar the prescribed velocity over the step), summed over the constraints, the node's
// velocity after the step solves
//   (m_I + dt^2 K_I) v_I' = p_I + dt (f_I + P_I) + dt^2 b_I,
// and the constraint's force is F_I = P_I - dt (K_I v_I' - b_I), added to the grid's external
// force (f_I: the internal force and the other external forces; the local damping then acts on
// the sum as on any force). A static state has v' = 0 and F = P: the penalty's answer, whose
// error h / (factor L) for a bar of length L falls as beta grows; a mode of the lumped
// stiffness k_L and the consistent k has (m + dt^2 k_L) z^2 - (2 m + dt^2 (k_L - k)) z + m = 0,
// with its roots in the unit disk for every beta since k_L >= k >= 0 (no time step limit
// beyond the soil's). test_boundary_constraint holds a block turned 30 degrees to the grid in
// uniaxial strain and checks its interior stress and reactions at several factors;
// tests/python/test_boundary_holds.py pushes the benchmarks' footing on the default B-splines
// and checks that its reaction stays near Prandtl's and free of jumps.
//
// Nitsche's method (method "nitsche"). The penalty's traction gains the material's own traction
// on the constrained directions, t = P sigma n - beta g, with n the curve's outward normal and
// sigma the same weighted least-squares linear fit as the displacement, to the particles' stresses
// (the in-plane components), on the nodes in the same shares s_I. The internal force of the
// particles next to the part already holds -int N_I sigma n along their edge (the divergence
// theorem), which this term cancels: what is left drives the gap to zero whatever beta, so the
// method is consistent and beta is only its stabilisation (the non-symmetric, "incomplete" form: no
// term in the test functions' stress). The term is explicit; the penalty's stiffness stays implicit
// as above, and beta must dominate the explicit term (a factor of 4 or more: below it the block
// does not come to rest).
//
// FLIP. The particles next to a constraint pick up velocities the grid does not see (FLIP keeps
// them), which the constraint's stiff nodes feed back: a few per cent of PIC
// (solver.pic_fraction 0.05) removes them, and constraint cases should take it.
//
// The benchmarks study pushes a rigid footing into weightless Tresca soil through a constraint
// on the detected top (studies/benchmarks/footing.py, footing_case) beside the UL-FEM and dolfinx;
// its figures are in that study's tables.
//
// Outputs: the force on the body of each constraint (the sum of its F_I, kN/m) and the
// root-mean-square gap along its part (m) (ConstraintReport, the time series' constraint_<k>_*);
// the work of F_I with the nodes' mid-step velocities is the ledger's constraint_work (the
// solver books it, LoadWorkRecorder). Components fixed by a support take no constraint force.
// Units: kN, m, s, t, kPa.
#pragma once

#include <optional>
#include <span>
#include <vector>

#include "mpm/boundary/surface_load.hpp"
#include "mpm/solver/mpm_solver.hpp"
#include "mpm/step/case.hpp"

namespace pfm {

class BoundaryConstraints {
 public:
  explicit BoundaryConstraints(const Case& c);

  bool empty() const { return specs_.empty(); }
  std::size_t size() const { return specs_.size(); }

  /// Adds the constraints' forces of step `step` to `force` (the grid's external force, with
  /// the loads in it), each on the curves `curves_for(kind)` of its curve kind; records them
  /// for the work (LoadWorkRecorder index: the number of loads + the constraint's index).
  /// detected_positions: the particles' positions at the detection the curves come from (empty:
  /// the curves are the boundary now).
  template <class CurvesFor>
  void apply(const StepView& step, GridState& grid_state, std::vector<Vec2>& force,
             CurvesFor&& curves_for, std::span<const Vec2> detected_positions = {}) {
    if (specs_.empty()) return;
    for (std::size_t k = 0; k < specs_.size(); ++k)
      integrator_.quadrature_points(curves_for(specs_[k].part.curve), specs_[k].part, points_[k]);
    apply_all(step, grid_state, force, detected_positions);
  }

  const std::vector<ConstraintReport>& reports() const { return reports_; }
  /// The prescribed displacement of each constraint now (u_bar; (value, 0) for normal_only),
  /// m: the state a checkpoint keeps.
  const std::vector<Vec2>& target() const { return target_; }
  void set_target(const std::vector<Vec2>& target) { target_ = target; }

 private:
  /// What the fit carries per particle: the displacement (x, y), the motion since the
  /// detection (x, y) and the in-plane stress (xx, yy, xy), at these offsets.
  using Fitted = Eigen::Matrix<double, 7, 1>;
  static constexpr int kDisplacement = 0, kMotion = 2, kStress = 4;
  /// Per node J, over the particles with weights m_p N_J(x_p): the mass, the moments of
  /// d_p = x_p - x_J (first, second) and of the fitted values f_p (value, d_p f_p^T).
  struct NodeMoments {
    double mass = 0.0;
    double beside = 0.0;  ///< sum of m_p N_J(x_p) of the material beside the part (x_range)
    Vec2 first = Vec2::Zero();
    Mat2 second = Mat2::Zero();
    Fitted value = Fitted::Zero();
    Eigen::Matrix<double, 2, 7> cross = Eigen::Matrix<double, 2, 7>::Zero();
  };
  /// A force (or a force per unit mass), its stiffness and the stiffness times the
  /// prescribed velocity.
  struct NodeTerm {
    Vec2 force = Vec2::Zero();
    Mat2 stiffness = Mat2::Zero();
    Vec2 rate = Vec2::Zero();
  };

  void apply_all(const StepView& step, GridState& grid_state, std::vector<Vec2>& force,
                 std::span<const Vec2> detected_positions);
  /// The material's displacement and stress at x (header comment); `mass`: the weights' sum
  /// (0: no material within reach).
  Fitted material_state(const Vec2& x, double& mass) const;
  /// r_I of the header comment: the part's share of node I's mass near the part.
  double part_share(std::size_t node) const;
  /// The moments of the particles within reach of the box [lo, hi] (and over x_range, if given).
  void project(const Particles& particles, std::span<const Vec2> detected_positions, const Vec2& lo,
               const Vec2& hi, const std::optional<Vec2>& x_range);
  /// Constraint k's nodal terms (terms_dense_) and its report's gap; `rate`: the prescribed
  /// displacement's rate over the step.
  void gather(std::size_t k, const Vec2& rate);
  /// Moves them to terms_[k], by node, and adds them to total_.
  void collect(std::size_t k);
  /// The grid functions at x (the loads' functions), into stencil_.
  void functions_at(const Vec2& x);
  /// visit(node, value, i, j) for the nonzero functions of stencil_.
  template <class Visit>
  void for_each_node(Visit&& visit) const;

  Grid grid_;
  int degree_ = 1;
  std::size_t n_loads_ = 0;
  std::vector<ConstraintSpec> specs_;
  boundary::BoundaryLoadIntegrator integrator_;
  std::vector<Vec2> target_;  // u_bar per constraint
  std::vector<ConstraintReport> reports_;
  std::vector<std::vector<boundary::CurvePoint>> points_;     // per constraint
  std::vector<std::vector<std::pair<int, NodeTerm>>> terms_;  // per constraint, by node
  // Scratch, per node, each with its flags and list of the nodes set (cleared sparsely).
  ShapeStencil stencil_;
  std::vector<NodeMoments> moments_;
  std::vector<char> moments_flag_;
  std::vector<int> moments_list_;
  std::vector<NodeTerm> terms_dense_, total_;
  std::vector<char> terms_flag_, total_flag_;
  std::vector<int> terms_list_, total_list_;
  std::vector<Vec2> velocity_;         // v' of the implicit update
  const double* node_mass_ = nullptr;  // the grid's, in this step
  double tiny_mass_ = 0.0;             // t: the solver's "no mass" (1e-12 of a particle's)
};

}  // namespace pfm

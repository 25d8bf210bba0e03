// Implicit quasi-static MPM (issue 47): load steps, each a Newton-Raphson iteration on the
// grid's displacement increment, then the particles updated and the grid reset (updated
// Lagrangian; Coombs & Augarde's AMPLE, Comput. Part. Mech. 2020, does the same with its own
// kinematics).
//
// A load step from t_n to t_n+1 = t_n + dt (the case's time is a pseudo-time: the loads and
// gravity follow their time functions, nothing is inertial):
//   1. at the particles' positions of t_n: the shape functions (the case's kind), the material
//      under each node (sum_p N_I V_p, which also a weightless material has), the ties of the
//      nodes with little of it (mpm/core/basis_extension.hpp, the explicit step's rule) and
//      the ghost penalty of the light nodes next to them (below), the supports, and the
//      external force at t_n+1: gravity sum_p N_I m_p g, the loads on the
//      boundary detected at t_n and those on the grid-top nodes (mpm/step/grid_top_loads.hpp,
//      the explicit step's), dead within the step (a manufactured solution's body force
//      instead of gravity); the constraints on the detected boundary
//      (penalty, Nitsche's method or the Implicit Boundary Method, implicit_constraints.cpp),
//      their forces and stiffness in the residual and the tangent;
//   2. the unknowns: the displacement increment of every node component that is neither fixed
//      nor tied; a fixed component takes its prescribed increment (the integral of its
//      velocity over the step), a tied node the extrapolation of its array, a node behind a wall
//      inside the grid w times the node in front of it (B-splines, mpm/core/wall_mirror.hpp);
//   3. Newton: from the displacement increments, each particle's increment gradient
//      G = sum_I du_I (x) grad N_I (B-bar: its in-plane trace replaced by the cell's
//      volume-weighted mean, mpm/core/kinematics.hpp), the stress from t_n's by the Jaumann
//      rotation and the material's update with its consistent tangent D (materials.hpp, the same
//      arithmetic as the explicit step with L dt = G; at a zero increment, a point that yielded
//      in the last step takes the tangent of 1e-6 of that step's increment, its plastic one), the
//      residual R = f_ext - sum_p V_p B^T sigma_p and its tangent K = sum_p V_p B^T (D B + D D_e^-1
//      (d rotation / d du)) (the geometry of t_n, on which the stress update takes the increment;
//      the second term is the Jaumann rotation's, which makes K unsymmetric); K du = R solved by
//      UMFPACK (SuiteSparse, through Eigen), with a backtracking line search on |R|; converged when
//      |R| <= tolerance x the internal force's norm over all components (the reactions' included)
//      and the last correction is below tolerance^(1/2) of the increment (or below tolerance x h
//      per unknown, for a step that asks for no motion); once |R| is within its tolerance, the
//      correction it would still ask for, K_prev^-1 R by the last factorisation (the tangent of
//      the iterate before), stands for the last correction: a linear step ends after one;
//   4. the particles moved by sum_I N_I du_I, F = (I + G) F, V = det F V_0, the stress and
//      plastic strain of the converged iteration kept.
// The ghost penalty (solver.ghost_penalty, gamma). A node with material of between the tie
// fraction f and 2 f of a full support keeps its unknown, but what holds it is a sliver of
// material, and where that sliver is all at yield (perfectly plastic soil beside a footing) the
// tangent is near singular there and Newton's corrections grow without bound. Each such node j
// and component takes the energy k g^2 / 2 of its deviation from the extrapolation of its array
// (the tie's rule, degree p or at least 1), g = du_j - sum_i e_ij du_i, with
// k = gamma M (1 - f_j / (2 f)), M = lambda + 2 mu of the stiffest material and f_j the node's
// share of a full support: the stiffness fades to none at 2 f, so no node's operator jumps as
// its material crosses it. For B-splines of degree p along a node column, g is the (p + 1)-th
// difference of the coefficients, h^p times the jump of the p-th derivative across the knot:
// the face ghost penalty of Burman (C. R. Math. 2010) for splines, as the unfitted finite
// element methods and the implicit MPM (Coombs, AMPLE's ghost stabilisation) use it. g
// vanishes on polynomials of the array's degree, so the penalty is consistent: it does not act
// on a linear field (degree 1, uGIMP), nor on a quadratic one along a column (quadratic
// B-splines).
// Within a step the geometry is the step's start (B, V and the loads' boundary), so an elastic
// step is linear in its increment and a large-deformation answer converges in the step size at
// first order: such a run needs the steps its strains ask for.
// On a mesh (ImplicitMesh: the UL-FEM's Q4 mesh, fem_reference/ulfem/ulfem_implicit.hpp) the
// step is the same with the grid replaced by the mesh, which moves with the material and is
// never reset: the functions of step 1 are the mesh's at the points' fixed natural coordinates
// on its current geometry, B-bar's mean is over an element, the supports and the loads are the
// mesh's (its nodes and its exact boundary edges, nothing detected, no ties, no mirrors), and
// step 4 moves the mesh's nodes by their increments, the points with them.
// The case's "implicit" block (ImplicitSpec, case.hpp) sets the first step's size (end_time /
// load_steps), the tolerance and the iterations. A step that does not converge in
// max_iterations is cut in half (at most max_cuts times in a row); a step that converges in at
// most 4 iterations lets the next one grow by 1.5 (never beyond the first step's size).
#pragma once

#include <Eigen/Core>
#include <Eigen/SparseCore>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "mpm/core/basis_extension.hpp"
#include "mpm/core/materials.hpp"
#include "mpm/core/shape_functions.hpp"
#include "mpm/core/wall_mirror.hpp"
#include "mpm/detect/detector.hpp"
#include "mpm/step/case.hpp"
#include "mpm/step/energy_ledger.hpp"
#include "mpm/step/grid_top_loads.hpp"
#include "mpm/step/particles.hpp"
#include "mpm/step/prescribed_velocity.hpp"
#include "mpm/step/step_view.hpp"

namespace pfm {

/// One attempt at a load step: its end time, its size, the relative residual before each
/// correction and after the last, and whether it converged.
struct LoadStepLog {
  double time = 0.0;
  double dt = 0.0;
  std::vector<double> residuals;
  bool converged = false;
};

/// A step that could not be completed after max_cuts halvings: the simulation stops (exit 3 in a
/// run, the outputs so far kept).
class ImplicitDivergence : public SimulationError {
 public:
  using SimulationError::SimulationError;
};

/// A node a material point's functions reach, with the function's value and gradient at the
/// point.
struct NodeWeight {
  int node = 0;
  double value = 0.0;
  Vec2 gradient = Vec2::Zero();
};

/// The nodes of an implicit step when they are not the MPM's grid: a mesh that moves with the
/// material (see the header comment). The solver assembles, iterates and updates the points;
/// the mesh gives its points, its functions, its supports, its loads and its motion.
class ImplicitMesh {
 public:
  virtual ~ImplicitMesh() = default;
  /// The material points at the start: positions, volumes, masses, materials and bodies.
  virtual Particles material_points() const = 0;
  virtual std::size_t n_nodes() const = 0;
  virtual std::size_t n_elements() const = 0;
  /// Whether boundary condition `bc` holds node n.
  virtual bool holds(const BoundaryCondition& bc, std::size_t n) const = 0;
  /// Point p's nodes, with their functions' values and gradients on the current mesh.
  virtual std::vector<NodeWeight> functions(std::size_t p) const = 0;
  /// The element holding point p (B-bar's mean dilatation is an element's).
  virtual std::size_t element_of(std::size_t p) const = 0;
  /// The case's loads' nodal forces at time t on the current mesh, added to `force` (one per
  /// node); not called while the body settles under gravity.
  virtual void add_loads(double t, std::vector<Vec2>& force) = 0;
  /// The nodes moved by `increment` (one per node); the points' positions and volumes (det J) on
  /// the moved mesh into `points`. SimulationError when an element inverts.
  virtual void move(const std::vector<Vec2>& increment, Particles& points) = 0;
  /// The current geometry becomes the reference the displacements are measured from (after the
  /// gravity-loading initial stress).
  virtual void reset_reference() = 0;
};

class ImplicitSolver {
 public:
  /// Builds the particles of the case's bodies (and K0 stresses when asked); refuses
  /// (InputError naming the JSON path) what this solver does not do: the explicit step's keys
  /// (solver.scheme, damping, damping_form, pic_fraction; time.cfl, time.dt) and the
  /// manufactured uniform dilatation (a free body; the standing wave is taken, held by its static
  /// body force, mpm/core/manufactured.hpp).
  /// With a mesh the step's nodes are the mesh's (see the header comment), and it refuses
  /// constraints on a detected boundary (a mesh prescribes motion on its nodes).
  explicit ImplicitSolver(const Case& c, std::unique_ptr<ImplicitMesh> mesh = nullptr);

  /// The initial stress procedure's part that takes load steps: with initial_stress "gravity"
  /// the body settled under its weight alone (gravity ramped over a pseudo-second, no loads,
  /// constraints or strength reduction, moving supports held), then at rest with its
  /// displacements measured from there, time 0 (the explicit procedure's outcome, reached
  /// statically). Once; the first advance() calls it if the caller has not. Throws
  /// ImplicitDivergence (its message starting "gravity loading") when a step of it does not
  /// converge.
  void initialise_stress();
  /// Takes load steps until `end_time` (s of pseudo-time) is reached or collapsed().
  void run_to(double end_time);
  /// One converged load step towards `end_time` (its size cut back or grown as the header
  /// says). Throws ImplicitDivergence when max_cuts halvings in a row did not converge, naming
  /// the step, what it asked for (gravity's and each load's factor, each constraint's
  /// displacement, the strength reduction factor) and the last attempt's residuals; with
  /// strength_reduction, after its start_time, returns collapsed() instead.
  void advance(double end_time);

  double time() const { return time_; }
  const Particles& particles() const { return particles_; }
  const Grid& grid() const { return case_.grid; }
  /// The mesh the solver was given (null on the MPM's grid).
  const ImplicitMesh* mesh() const { return mesh_.get(); }
  /// Every attempt of every load step, in order.
  const std::vector<LoadStepLog>& log() const { return log_; }
  /// Per constraint, at the last converged step: the force on the body (kN/m), the
  /// root-mean-square gap (m) and the part's length (m).
  const std::vector<ConstraintReport>& constraint_reports() const { return constraint_reports_; }
  /// With initial_stress "gravity": every attempt of the load steps that settled the body under
  /// its weight before time 0 (empty otherwise).
  const std::vector<LoadStepLog>& initial_stress_log() const { return initial_log_; }
  /// Per moving support (boundary_conditions[].velocity, in the case's order), at the last
  /// converged step: the force it exerts on the body on the components it fixes, summed over
  /// its nodes (kN/m), as the explicit run's reaction_<k>_fx, _fy.
  const std::vector<Vec2>& support_reactions() const { return support_reactions_; }
  /// The strength reduction factor of the last converged step, F(time()) (1 without
  /// strength_reduction).
  double strength_factor() const;
  /// With strength_reduction: a step after its start_time could not be completed (after
  /// max_cuts halvings in a row, or with no halving left above the first step / 2^max_cuts),
  /// so no equilibrium was found at the factor of the last attempt
  /// (failed_factor()): the run's answer. The particles stay those of the last converged step,
  /// and advance() takes no more steps.
  bool collapsed() const { return failed_factor_ > 0.0; }
  double failed_factor() const { return failed_factor_; }

 private:
  struct Prepared;
  struct Iterate;
  /// One attempt at a load step from time_ to time_ + dt: logged; true when it converged (then
  /// the particles are updated).
  bool try_step(double dt);
  // The parts of a step, in order.
  /// 1. Shape functions at the particles and the material under each node.
  void locate(Prepared& s) const;
  /// 2. The supports' increments over the step and the ties of the nodes with little material.
  void hold_and_tie(Prepared& s);
  /// 3. Gravity and the loads (on the boundary detected now and on the grid-top nodes), at the
  /// step's end.
  void apply_external_force(Prepared& s);
  /// Gravity's factor at time t: its ramp's (gravity.ramp_time), or 1 after a K0 or a
  /// gravity-loading initial stress (the weight's stress is in place), as the explicit step.
  double gravity_factor(double t) const;
  /// initialise_stress's settling under gravity.
  void settle_under_gravity();
  /// The materials with their strength divided by the strength reduction factor at time t.
  void reduce_strength(double t);
  /// The message of a step that did not converge after `cut` halvings, the last of size dt.
  std::string divergence_message(double dt, int cut) const;
  /// Constraint k's prescribed displacement at time_ + dt (u_bar: a displacement's value times
  /// its time function, or a velocity's integral, the value at mid-step times dt per step).
  Vec2 constraint_target(std::size_t k, double dt) const;
  /// The boundary detected at t_n, once per step.
  const DetectedBoundary& detected(Prepared& s);
  /// 4. Each node component as an affine function of the unknowns (supports, ties, mirrors).
  void number_unknowns(Prepared& s);
  /// 5. Each particle's B (B-bar with the mean dilatation).
  void build_strain_operators(Prepared& s) const;
  /// 6. The constraints' quadrature points on the boundary detected at t_n: their nodes, the
  /// gap at a zero increment, the fit (implicit_constraints.cpp).
  void place_constraints(Prepared& s);
  /// The elastic parameters of the Implicit Boundary Method's band at a point: those of the
  /// material of the fit's (particle, coefficient) with the largest coefficient.
  const ElasticParameters& band_material(const std::vector<std::pair<int, double>>& fit) const;
  /// Constraint k's gap of the last converged step at x, interpolated along its points moved
  /// with the material (implicit_constraints.cpp); none when no such point lies within a cell.
  std::optional<Vec2> carried_gap(std::size_t k, const Vec2& x) const;
  /// 7. The tangent's sparsity, and where each particle's pairs of unknowns go in it.
  void build_pattern(Prepared& s) const;
  /// The constraint points' pairs of unknowns (rows, columns), and then their places.
  static void add_constraint_pairs(Prepared& s, std::vector<Eigen::Triplet<double>>& pairs);
  static void place_constraint_pairs(Prepared& s);
  /// The ghost penalty's pairs of unknowns, and then their places.
  static void add_ghost_pairs(Prepared& s, std::vector<Eigen::Triplet<double>>& pairs);
  static void place_ghost_pairs(Prepared& s);
  /// The ghost penalty's forces added to it.internal (and its stiffness to it.tangent).
  static void add_ghost_penalty(const Prepared& s, bool tangent, Iterate& it);
  /// The constraints' forces added to `residual` (and their stiffness to it.tangent), their
  /// reports into it.reports.
  void add_constraints(const Prepared& s, bool tangent, Iterate& it,
                       Eigen::VectorXd& residual) const;
  /// The residual T^T (f_ext - f_int) at the unknowns `x`, the particles' stresses and states
  /// in `it`; with `tangent`, T^T K T in it.tangent.
  Eigen::VectorXd evaluate(const Prepared& s, const Eigen::VectorXd& x, bool tangent,
                           Iterate& it) const;
  /// Particle p's stress, state and increment gradient at it.increment into `it`, its internal
  /// force into `internal` and, with `tangent`, its T^T K T into `values` (the tangent's) and
  /// its d sigma / d du when a constraint point (Nitsche's, the IBM's) fits it.
  void evaluate_particle(const Prepared& s, std::size_t p, bool tangent, Iterate& it,
                         double* values, Vec2* internal, std::vector<double>& local) const;
  /// |residual| over the larger of the internal force's and the external force's norms.
  static double relative(const Prepared& s, const Iterate& it, const Eigen::VectorXd& residual);
  /// 8. Newton with a line search; the relative residuals in entry; true when converged.
  bool newton(const Prepared& s, Iterate& it, LoadStepLog& entry) const;
  /// 9. The particles moved, their stresses, states, F and volumes those of `it`.
  void commit(const Prepared& s, const Iterate& it);

  const Case& case_;
  std::unique_ptr<ImplicitMesh> mesh_;  ///< null: the MPM's grid
  std::size_t n_nodes_ = 0;             ///< the grid's or the mesh's
  ImplicitSpec settings_;
  Particles particles_;
  /// Per material: the case's model with its strength divided by strength_factor_ and that
  /// model's constants.
  std::vector<Material> models_;
  std::vector<MaterialConstants> constants_;
  double strength_factor_ = 1.0;        ///< of models_
  double failed_factor_ = 0.0;          ///< collapsed(): the factor of the last attempt
  std::vector<Tangent> hooke_inverse_;  ///< per material: d sigma / d trial = D_alg D^-1
  double ghost_modulus_ = 0.0;          ///< M = lambda + 2 mu of the stiffest material, kPa
  /// Per particle, the strain increment of the last converged step if the point yielded in it
  /// (zero otherwise): a zero increment's tangent is probed along it (evaluate_particle).
  std::vector<Strain> yielding_;
  std::vector<unsigned> fixed_;    ///< FixMask per node
  PrescribedVelocity prescribed_;  ///< the moving supports' velocities over a step
  BasisExtension extension_;
  WallMirror mirror_;
  GridTopLoads top_loads_;  ///< the case's grid_top_nodes loads (on the grid)
  DetectorState detector_state_;
  double initial_spacing_ = 0.0;
  double time_ = 0.0;
  double step_size_ = 0.0;
  double first_step_ = 0.0;
  std::vector<LoadStepLog> log_;
  std::vector<LoadStepLog> initial_log_;  ///< settle_under_gravity's
  bool initialised_ = false;              ///< initialise_stress() done
  std::vector<Vec2> constraint_target_;   ///< u_bar per constraint at time_, m
  std::vector<ConstraintReport> constraint_reports_;
  /// A constraint point of the last converged step: moved with the material (by the step's
  /// increment there), with its gap at the step's end.
  struct CarriedGap {
    Vec2 position = Vec2::Zero();  ///< m
    Vec2 gap = Vec2::Zero();       ///< m
  };
  std::vector<std::vector<CarriedGap>> carried_gaps_;  ///< per constraint, along its part
  std::vector<Vec2> support_reactions_;                ///< per moving support, kN/m
};

}  // namespace pfm

// Updated-Lagrangian FEM extracted from the MPM by removing the Eulerian phase
// (thesis 5.5.2, 6.2.5; method-map section 2).
//
// The step is MpmSolver's step (mpm/solver/mpm_solver.hpp) with the grid replaced by a mesh
// that moves with the material and is never reset:
//   compute_geometry     Q4 gradients and det J at the material points on the current mesh
//                        (also after every move: an inverted element stops the run)
//   particles_to_nodes   lumped nodal mass, momentum, internal force  f_I = -sum_p V_p sigma_p
//                        grad N_I(x_p) on the current geometry
//   external_forces      gravity m_I g, pressure loads on the current top boundary edges
//   update_nodes         local (Cundall) damping, acceleration, velocity, constraints
//                        (the same arithmetic as MpmSolver::update_grid)
//   nodes_to_particles   particle velocity (FLIP)
//   remap_momentum       MUSL only: nodal velocity from the updated particle momentum
//   update_stress        velocity gradient, Jaumann rotation, constitutive update, F
//   move_mesh            x_I += dt v_I; material points stay at their natural coordinates,
//                        their positions are interpolated: x_p = sum_I N_I(xi_p) x_I
//
// Material points: 2 x 2 per element at the Gauss points (+-1/sqrt 3), volume det J x weight
// (weight 1), mass = density x volume, density = unit weight / g. Point 4e + k of element e
// sits at natural coordinates ((-,-), (+,-), (-,+), (+,+))[k] (row by row, like the MPM's
// fill_bodies), so on a grid-aligned mesh the points and their ids are the MPM's "gauss" ones.
//
// Constraints: "left" / "right" / "bottom" / "top" act on the mesh nodes whose reference
// position lies on the grid edge line x = x0, x = x0 + nx h, y = y0, y = y0 + ny h (within
// 1e-9 h): the grid nodes the MPM constrains there are exactly these nodes where the body
// touches the grid edge, and a body that does not touch a grid edge gets no constraint from it,
// as in the MPM. A node set constrains the mesh nodes in its closed box (reference position).
//
// Loads: a vertical_pressure of the case (apply_on "grid_top_nodes" or "detected_boundary":
// the FE boundary is exact, so both act on it) is a normal follower pressure q on the boundary
// edges that face upwards in the reference configuration (outward normal n_y > 0), over the
// part of each edge whose current x lies in x_range. Per edge A -> B (material on the left,
// outward normal n = (dy, -dx) / L) the consistent nodal forces are exact:
//   f_A = -q (dy, -dx) int (1 - s) ds,  f_B = -q (dy, -dx) int s ds  over the loaded s-range.
// On a flat top this is the MPM's grid_top_nodes hat integral.
#pragma once

#include <array>
#include <string>
#include <vector>

#include "fem_reference/ulfem/quad_mesh.hpp"
#include "mpm/solver/mpm_solver.hpp"

namespace pfm::ulfem {

/// A boundary edge that can carry a pressure: nodes in element order (material on the left).
struct LoadedEdge {
  int from = 0;
  int to = 0;
};

class UlFemSolver {
 public:
  /// Mesh from mesh_case(c).
  explicit UlFemSolver(const Case& c);
  UlFemSolver(const Case& c, QuadMesh mesh);

  /// One explicit step of size dt().
  void step();
  /// The initial stress procedure of the case (zero, K0, gravity loading), as MpmSolver's:
  /// afterwards time and step are 0, velocities 0, displacements measured from the state
  /// reached (the mesh keeps its deformed shape, its reference positions are reset).
  void initialise_stress();

  /// Prescribed motion of the mesh nodes by the given displacements (one per node), then the
  /// geometry update with its inversion check. For tests and coupling.
  void displace_nodes(const std::vector<Vec2>& displacement);

  /// Stress update from given nodal velocities (one per mesh node) on the current mesh over
  /// one dt(): the kinematics + constitutive stage of a step alone (patch tests), as
  /// MpmSolver::update_stress_from_grid_velocity. The mesh does not move.
  void update_stress_from_node_velocity(const std::vector<Vec2>& node_velocity);

  double time() const { return time_; }
  long step_count() const { return step_; }
  /// Time step of the last step taken (of the next one before the first): the base step
  /// (time.dt, or cfl x critical_dt()), reduced to cfl x (smallest current element length) /
  /// (c_p + |v|max) when elements have been crushed below that.
  double dt() const { return dt_; }
  /// Critical time step: smallest (element area / longest edge) of the initial mesh / c_p.
  double critical_dt() const { return critical_dt_; }
  long initial_stress_steps() const { return initial_stress_steps_; }
  const QuadMesh& mesh() const { return mesh_; }
  /// Current node positions, m (mesh().node_position is the initial mesh).
  const std::vector<Vec2>& node_position() const { return node_position_; }
  /// Node displacement = current - reference position (reference reset by initialise_stress).
  std::vector<Vec2> node_displacement() const;
  const Particles& particles() const { return particles_; }
  /// Nodal arrays, indexed by mesh node.
  const GridState& node_state() const { return nodes_; }
  const Case& case_spec() const { return case_; }
  const StageTimes& stage_times() const { return times_; }
  const std::vector<LoadedEdge>& top_edges() const { return top_edges_; }
  EnergyBalance energy() const;

  void set_damping(double coefficient) { damping_ = coefficient; }
  /// Replace the base time step (must not exceed critical_dt(); checked).
  void set_dt(double dt);
  void set_external_force_hook(ExternalForceHook hook) { hook_ = std::move(hook); }

 private:
  void build_particles();
  void build_constraints();
  void build_top_edges();
  void compute_geometry();
  void particles_to_nodes(bool momentum_only);
  void external_forces();
  void update_nodes();
  void nodes_to_particles();
  void update_stress(const std::vector<Vec2>& node_velocity);
  void move_mesh();
  void check_particles();
  void apply_k0_stress();
  double gravity_factor(double t) const;
  std::string describe_element(std::size_t element, const Vec2& x) const;

  Case case_;
  QuadMesh mesh_;
  std::vector<Vec2> node_position_;
  std::vector<Vec2> node_reference_;
  Particles particles_;
  GridState nodes_;
  std::array<Eigen::Vector4d, 4> shape_value_;  ///< N_I at the 4 point slots
  std::array<Eigen::Matrix<double, 4, 2>, 4> shape_natural_gradient_;
  std::vector<Eigen::Matrix<double, 4, 2>> gradient_;  ///< per point: row I = grad N_I, 1/m
  std::vector<double> det_jacobian_;                   ///< per point, m^2
  std::vector<LoadedEdge> top_edges_;

  double time_ = 0.0;
  long step_ = 0;
  double dt_ = 0.0;
  double base_dt_ = 0.0;
  double max_particle_speed_ = 0.0;
  double critical_dt_ = 0.0;
  double max_wave_speed_ = 0.0;
  double min_element_length_ = 0.0;  ///< current smallest area / longest edge, m
  double damping_ = 0.0;
  StageTimes times_;  ///< locate = geometry, particles_to_grid = particles_to_nodes, ...
  ExternalForceHook hook_;
  bool loads_active_ = true;
  bool gravity_full_ = false;
  long initial_stress_steps_ = 0;
  double external_work_ = 0.0;
  double internal_work_ = 0.0;
  double damping_work_ = 0.0;
  std::vector<double> internal_work_increment_;
  std::vector<Vec2> velocity_before_update_;
  std::vector<Vec2> remapped_velocity_;
};

}  // namespace pfm::ulfem

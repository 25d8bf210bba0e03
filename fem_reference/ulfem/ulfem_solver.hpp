// Updated-Lagrangian FEM extracted from the MPM by removing the Eulerian phase
// (thesis 5.5.2, 6.2.5; method-map section 2).
//
// The step is MpmSolver's step (mpm/solver/mpm_solver.hpp) with the grid replaced by a mesh
// that moves with the material and is never reset:
//   compute_geometry     Q4 gradients and det J at the material points on the current mesh
//                        (also after every move: an inverted element stops the run)
//   particles_to_nodes   lumped nodal mass, momentum, internal force  f_I = -sum_p V_p sigma_p
//                        grad N_I(x_p) on the current geometry
//   external_forces      gravity m_I g, the case's loads on the current boundary edges
//   update_nodes         local (Cundall) damping, acceleration, velocity, constraints
//                        (update_node() of mpm/step/energy_ledger.hpp, as the MPM's grid)
//   nodes_to_particles   particle velocity (FLIP, blended with PIC by solver.pic_fraction,
//                        XPIC of solver.xpic_order)
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
// Constraints and loads act on the mesh's nodes and exact boundary edges
// (fem_reference/ulfem/edge_loads.hpp).
#pragma once

#include <array>
#include <string>
#include <vector>

#include "fem_reference/ulfem/edge_loads.hpp"
#include "fem_reference/ulfem/quad_mesh.hpp"
#include "mpm/step/initial_stress.hpp"
#include "mpm/step/prescribed_velocity.hpp"
#include "mpm/step/step_scheme.hpp"
#include "mpm/step/step_view.hpp"

namespace pfm::ulfem {

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

  double time() const { return counters_.time; }
  long step_count() const { return counters_.step; }
  /// Time step of the last step taken (of the next one before the first): the base step
  /// (time.dt, or cfl x critical_dt()), reduced to cfl x (smallest current element length) /
  /// (c_p + |v|max) when elements have been crushed below that.
  double dt() const { return counters_.dt; }
  /// Critical time step: smallest (element area / longest edge) of the initial mesh / c_p.
  double critical_dt() const { return critical_dt_; }
  long initial_stress_steps() const { return counters_.initial_stress_steps; }
  const QuadMesh& mesh() const { return mesh_; }
  /// Current node positions, m (mesh().node_position is the initial mesh).
  const std::vector<Vec2>& node_position() const { return node_position_; }
  /// Node displacement = current - reference position (reference reset by initialise_stress).
  std::vector<Vec2> node_displacement() const;
  const Particles& particles() const { return particles_; }
  /// The points, to be changed between steps (tests: initial velocity fields).
  Particles& mutable_particles() { return particles_; }
  /// Nodal arrays, indexed by mesh node.
  const GridState& node_state() const { return nodes_; }
  const Case& case_spec() const { return case_; }
  const StageTimes& stage_times() const { return times_; }
  /// The stages' names in run.json's stage_seconds, in the order of StageTimes' fields.
  static constexpr std::array<const char*, 7> kStageNames = {
      "geometry",     "particles_to_nodes", "external_forces",
      "update_nodes", "nodes_to_particles", "remap",
      "stress"};
  /// Every boundary edge of the mesh (the candidates for loads), in boundary_edges() order.
  const std::vector<LoadedEdge>& boundary_edges() const { return edge_loading_.edges(); }
  const std::vector<EdgeLoad>& loads() const { return edge_loading_.loads(); }
  /// Load forces of the last step that applied loads (zero before the first, and during the
  /// gravity loading of the initial stress, which applies none).
  const EdgeLoadDiagnostics& load_diagnostics() const { return load_diagnostics_; }
  EnergyBalance energy() const;

  /// Replace the base time step (must not exceed critical_dt(); checked).
  void set_dt(double dt);
  void set_external_force_hook(ExternalForceHook hook) { hook_ = std::move(hook); }

 private:
  void build_constraints();
  void apply_loads();
  /// Gradients, det J, volumes and the smallest element length on the current mesh; with
  /// account_energy the volume change goes into the energy ledger.
  void compute_geometry(bool account_energy = false);
  void particles_to_nodes(bool momentum_only);
  void external_forces();
  void update_nodes();
  void nodes_to_particles();
  /// XPIC(m) (solver.xpic_order m > 1): xpic_term_ by xpic_grid_term (grid_stages.hpp).
  void xpic_extrapolation();
  /// MUSL: the updated points' momentum to the nodes, and the nodes' velocity from it.
  void remap();
  void update_stress(const std::vector<Vec2>& node_velocity);
  void move_mesh();
  void check_particles();
  double gravity_factor(double t) const;
  double particle_kinetic_energy() const;

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
  EdgeLoading edge_loading_;
  EdgeLoadDiagnostics load_diagnostics_;

  SolverCounters counters_;  ///< time, step, dt, damping, load switches, works
  double base_dt_ = 0.0;
  double max_particle_speed_ = 0.0;
  double critical_dt_ = 0.0;
  double max_wave_speed_ = 0.0;
  double min_element_length_ = 0.0;  ///< current smallest area / longest edge, m
  StageTimes times_;  ///< locate = geometry, particles_to_grid = particles_to_nodes, ...
  ExternalForceHook hook_;
  LoadWorkRecorder load_work_recorder_;  ///< each load's nodal forces of the step
  PrescribedVelocity prescribed_;        ///< moving supports (boundary_conditions[].velocity)
  std::vector<MaterialConstants> material_constants_;  ///< per case material
  std::vector<PointEnergy> point_energy_;              ///< per point, scratch of update_stress
  double grid_kinetic_after_ = 0.0;                    ///< nodal kinetic energy after update_nodes
  std::vector<Vec2> remapped_velocity_;
  std::vector<Vec2> xpic_term_;     ///< XPIC(m): the PIC part's nodal term (m > 1 only)
  std::vector<Vec2> xpic_iterate_;  ///< XPIC(m): g_r
  std::vector<Vec2> xpic_sum_;      ///< XPIC(m): sum_p N m_p (S g_(r-1))_p
};

}  // namespace pfm::ulfem

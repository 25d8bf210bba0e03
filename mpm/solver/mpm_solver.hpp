// Explicit 2D plane-strain MPM (thesis 3.2, eq. 3.24), MUSL by default, USL as an option.
//
// One step reads as its stages, in order (the hook points of Karamelo / cb-geo):
//   locate_particles      shape functions at the particles, particles binned by cell
//   particles_to_grid     nodal mass, momentum and internal force  (+ body force)
//   external_forces       surface loads on the grid (grid-aligned, or on the detected boundary)
//   update_grid           local damping, acceleration, velocity, velocity constraints
//   grid_to_particles     particle velocity (FLIP) and position
//   remap_momentum        MUSL only: nodal velocity from the updated particle momentum
//   update_stress         velocity gradient, Jaumann rotation, constitutive update, F, volume
//
// Determinism: particles are binned by cell; the scatter to the grid visits the cells in s x s
// colour classes (s = 2 linear, 4 GIMP) so that no two cells of one class share a node; every
// node therefore receives its contributions in the same order whatever the thread count, and
// results are bitwise identical for any number of threads.
#pragma once

#include <array>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "mpm/solver/case.hpp"
#include "mpm/solver/particles.hpp"

namespace pfm {

/// A run that cannot go on (NaN, CFL violation, particle leaving the grid, element inversion).
class SimulationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Nodal arrays of the background grid, indexed by Grid::node_index.
struct GridState {
  std::vector<double> mass;          ///< t
  std::vector<Vec2> momentum;        ///< t m/s
  std::vector<Vec2> internal_force;  ///< kN
  std::vector<Vec2> external_force;  ///< kN (surface loads and body forces)
  std::vector<Vec2> velocity;        ///< m/s, after the grid update
  std::vector<Vec2> acceleration;    ///< m/s^2
  std::vector<unsigned> fixed;       ///< FixMask per node
};

/// Wall-clock seconds spent per stage, accumulated over the run.
struct StageTimes {
  double locate = 0, particles_to_grid = 0, external_forces = 0, update_grid = 0,
         grid_to_particles = 0, remap = 0, stress = 0;
  double total() const {
    return locate + particles_to_grid + external_forces + update_grid + grid_to_particles + remap +
           stress;
  }
};

/// Energies and momentum for timeseries.csv.
struct EnergyBalance {
  double kinetic_energy = 0.0;   ///< kJ (per m thickness)
  double external_work = 0.0;    ///< kJ, accumulated work of gravity and surface loads
  double internal_work = 0.0;    ///< kJ, accumulated stress power (strain energy + dissipation)
  double damping_work = 0.0;     ///< kJ, accumulated work of the damping forces (<= 0)
  Vec2 momentum = Vec2::Zero();  ///< t m/s
};

/// Extra external forces added to the grid each step (the boundary-traction stage hooks in
/// here). Called after particles_to_grid with the nodal masses known; adds into `force`.
using ExternalForceHook =
    std::function<void(double time, const GridState& grid_state, std::vector<Vec2>& force)>;

/// Observer of the updated grid velocities (after the grid update, before grid-to-particles):
/// surface markers ride on them (thesis eq. 4.6-4.7). `dt` is the step being taken.
using GridVelocityHook = std::function<void(double time, double dt, const GridState& grid_state)>;

class MpmSolver {
 public:
  /// Builds particles from the case bodies, the constraints and the grid-aligned loads.
  explicit MpmSolver(const Case& c);

  /// One explicit step of size dt().
  void step();

  /// Stress update from given nodal velocities (one node per grid node) at the current
  /// particle positions, over one dt(): the kinematics + constitutive stage of a step alone.
  /// Used by the patch test and by solvers that prescribe the grid motion.
  void update_stress_from_grid_velocity(const std::vector<Vec2>& node_velocity);

  /// Apply the initial stress procedure of the case (zero, K0, gravity loading); afterwards
  /// time and step are 0 and displacements are measured from the state reached.
  void initialise_stress();

  /// Steps taken by the gravity-loading procedure (0 for zero and K0).
  long initial_stress_steps() const { return initial_stress_steps_; }
  double time() const { return time_; }
  long step_count() const { return step_; }
  double dt() const { return dt_; }
  /// Critical time step h / c_p of the stiffest material at its initial density, s.
  double critical_dt() const { return critical_dt_; }
  const Particles& particles() const { return particles_; }
  Particles& particles() { return particles_; }
  const Grid& grid() const { return case_.grid; }
  const GridState& grid_state() const { return grid_; }
  const Case& case_spec() const { return case_; }
  const StageTimes& stage_times() const { return times_; }
  EnergyBalance energy() const;

  void set_external_force_hook(ExternalForceHook hook) { hook_ = std::move(hook); }
  void set_grid_velocity_hook(GridVelocityHook hook) { velocity_hook_ = std::move(hook); }
  /// Override the local damping coefficient (used by gravity loading).
  void set_damping(double coefficient) { damping_ = coefficient; }
  /// Replace the time step (must not exceed critical_dt(); checked).
  void set_dt(double dt);

  /// The scalars that carry from step to step besides the particles (checkpoints: with the
  /// particles they are the complete state; the grid is rebuilt every step).
  struct Counters {
    double time = 0.0;
    long step = 0;
    double dt = 0.0;
    double damping = 0.0;
    bool loads_active = true;
    bool gravity_full = false;
    long initial_stress_steps = 0;
    double external_work = 0.0, internal_work = 0.0, damping_work = 0.0;
  };
  Counters counters() const {
    return {time_,         step_,         dt_,           damping_,
            loads_active_, gravity_full_, initial_stress_steps_, external_work_,
            internal_work_, damping_work_};
  }
  /// Restores counters() of a checkpoint (after the particles have been restored).
  void restore(const Counters& n) {
    time_ = n.time;
    step_ = n.step;
    dt_ = n.dt;
    damping_ = n.damping;
    loads_active_ = n.loads_active;
    gravity_full_ = n.gravity_full;
    initial_stress_steps_ = n.initial_stress_steps;
    external_work_ = n.external_work;
    internal_work_ = n.internal_work;
    damping_work_ = n.damping_work;
  }

  /// Nodes on the initial top surface and their consistent nodal force per unit pressure for
  /// a grid_top_nodes load (exposed for tests).
  struct TopNodeLoad {
    std::vector<int> node;
    std::vector<double> vertical_force_per_kpa;  ///< kN per kPa (downwards positive)
  };
  const std::vector<TopNodeLoad>& top_node_loads() const { return top_loads_; }

 private:
  template <int W>
  void run_step();
  template <int W>
  void locate_particles();
  template <int W>
  void particles_to_grid(bool momentum_only);
  void external_forces();
  void update_grid();
  template <int W>
  void grid_to_particles();
  template <int W>
  void update_stress(const std::vector<Vec2>& node_velocity);
  void check_particles();
  void build_constraints();
  void build_top_node_loads();
  void apply_k0_stress();
  double gravity_factor(double t) const;

  Case case_;
  Particles particles_;
  GridState grid_;
  double time_ = 0.0;
  long step_ = 0;
  double dt_ = 0.0;
  double critical_dt_ = 0.0;
  double max_wave_speed_ = 0.0;
  double damping_ = 0.0;
  StageTimes times_;
  ExternalForceHook hook_;
  GridVelocityHook velocity_hook_;
  std::vector<TopNodeLoad> top_loads_;

  // Per-step work arrays.
  std::vector<int> particle_cell_;   ///< cell index of each particle
  std::vector<int> cell_start_;      ///< n_cells + 1 offsets into sorted_
  std::vector<int> sorted_;          ///< particle ids binned by cell, ascending within a cell
  std::vector<int> occupied_cells_;  ///< cells holding particles, ascending
  std::vector<std::array<double, 12>> stencil_;  ///< 1D factors per particle (see .cpp)
  std::vector<std::array<int, 2>> stencil_base_;
  std::vector<double> internal_work_increment_;
  std::vector<Vec2> velocity_before_update_;       ///< nodal velocity before the grid update
  std::vector<Vec2> remapped_velocity_;            ///< MUSL: nodal velocity from updated particles
  std::array<std::vector<int>, 16> colour_cells_;  ///< occupied cells per colour class
  bool loads_active_ = true;
  bool gravity_full_ = false;

  long initial_stress_steps_ = 0;
  long bad_particle_ = -1;  ///< a particle with a non-finite value in this step, or -1
  double max_speed_ = 0.0;  ///< largest particle speed after this step, m/s
  double external_work_ = 0.0;
  double internal_work_ = 0.0;
  double damping_work_ = 0.0;
};

}  // namespace pfm

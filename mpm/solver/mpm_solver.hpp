// Explicit 2D plane-strain MPM (thesis 3.2, eq. 3.24), MUSL by default, USL as an option.
//
// One step reads as its stages, in order (the hook points of Karamelo / cb-geo; after
// locate_particles, run_stages of step_scheme.hpp calls them in the scheme's order, as the
// UL-FEM's):
//   locate_particles      shape functions at the particles, particles binned by band
//   particles_to_grid     nodal mass, momentum and internal force  (+ body force); then the
//                         nodes with nearly no material are tied to inner nodes and what they
//                         hold is gathered there (solver.outer_node_fraction,
//                         mpm/core/basis_extension.hpp; the loads on them follow after
//                         external_forces, their velocities after update_grid and remap)
//   external_forces       surface loads on the grid (grid-aligned, or on the detected boundary)
//   update_grid           local damping, acceleration, velocity, velocity constraints
//   grid_to_particles     particle velocity (FLIP, blended with PIC by solver.pic_fraction,
//                         XPIC of solver.xpic_order) and position
//   remap                 MUSL only: nodal velocity from the updated particle momentum
//   update_stress         velocity gradient, Jaumann rotation, constitutive update, F, volume
//
// With solver.anti_locking "bbar" (mean dilatation, mpm/core/kinematics.hpp) each particle
// belongs to the cell holding it at locate_particles: update_stress gives every particle its
// cell's volume-weighted mean tr L, and particles_to_grid its cell's mean in-plane stress trace
// (B-bar's internal force, the work conjugate). Each band sums the cells of its rows.
//
// Determinism: particles are binned by horizontal bands of cell rows (the band height depends
// on the grid only, >= 1 row linear, >= 3 GIMP), in ascending id order within a band. The
// scatters to the grid (particles_to_grid and the MUSL momentum remap) run over the even bands,
// then over the odd bands: two bands of one parity share no node, so every node receives its
// contributions in the same order (its bands in parity order, particles by id) whatever the
// thread count, and results are bitwise identical for any number of threads. Sums over all
// particles or nodes (energies) are taken over fixed blocks of indices, each in index order,
// then over the blocks in order.
//
// Performance notes: particles are visited band by band, close to their storage order; a
// linear particle's stencil is stored as its cell and local coordinates (24 bytes) and expanded
// where it is used; the MUSL grid-to-particle update and the momentum scatter of the remap are
// one pass; the constitutive constants of each material are computed once (MaterialConstants);
// a step has about a dozen thread synchronisations, and tiny problems (< 1024 particles +
// nodes) run on one thread; per-step arrays are allocated once.
#pragma once

#include <array>
#include <functional>
#include <stdexcept>
#include <string>
#include <vector>

#include "mpm/step/case.hpp"
#include "mpm/step/energy_ledger.hpp"
#include "mpm/step/grid_stages.hpp"
#include "mpm/step/grid_top_loads.hpp"
#include "mpm/step/initial_stress.hpp"
#include "mpm/step/particles.hpp"
#include "mpm/step/prescribed_velocity.hpp"
#include "mpm/step/step_scheme.hpp"
#include "mpm/step/step_view.hpp"

namespace pfm {

class MpmSolver {
 public:
  /// Builds particles from the case bodies, the constraints and the grid-aligned loads.
  explicit MpmSolver(const Case& c);

  /// One explicit step of size dt().
  void step();

  /// Stress update from given nodal velocities (one node per grid node) at the current
  /// particle positions, over one dt(): the kinematics + constitutive stage of a step alone.
  /// Used by the patch test and by solvers that prescribe the grid motion. Stops like step()
  /// (SimulationError) on a non-finite value or an inverted particle (det F <= 0).
  void update_stress_from_grid_velocity(const std::vector<Vec2>& node_velocity);

  /// Apply the initial stress procedure of the case (zero, K0, gravity loading); afterwards
  /// time and step are 0 and displacements are measured from the state reached.
  void initialise_stress();

  /// Steps taken by the gravity-loading procedure (0 for zero and K0).
  long initial_stress_steps() const { return counters_.initial_stress_steps; }
  double time() const { return counters_.time; }
  long step_count() const { return counters_.step; }
  double dt() const { return counters_.dt; }
  /// Critical time step h / c_p of the stiffest material at its initial density, s.
  double critical_dt() const { return critical_dt_; }
  const Particles& particles() const { return particles_; }
  /// The particles, to change them between steps (checkpoint restart, tests): the ledger's
  /// particle kinetic energy is then taken anew.
  Particles& mutable_particles() {
    kinetic_stale_ = true;
    return particles_;
  }
  const Grid& grid() const { return case_.grid; }
  const GridState& grid_state() const { return grid_; }
  const Case& case_spec() const { return case_; }
  const StageTimes& stage_times() const { return times_; }
  /// The stages' names in run.json's stage_seconds, in the order of StageTimes' fields.
  static constexpr std::array<const char*, 7> kStageNames = {
      "locate", "particles_to_grid", "external_forces", "update_grid", "grid_to_particles", "remap",
      "stress"};
  /// Kinetic and elastic energy of the particles now and the energy ledger since time 0
  /// (mpm/step/energy_ledger.hpp).
  EnergyBalance energy() const;

  void set_external_force_hook(ExternalForceHook hook) { hook_ = std::move(hook); }
  void set_grid_velocity_hook(GridVelocityHook hook) { velocity_hook_ = std::move(hook); }
  /// The step as the hooks see it, now (outside a step: the next one's start).
  StepView step_view() {
    return {counters_.time, counters_.dt, counters_.step, particles_, load_work_recorder_};
  }
  /// Replace the time step (must not exceed critical_dt(); checked).
  void set_dt(double dt);

  /// The scalars that carry from step to step besides the particles (checkpoints: with the
  /// particles they are the complete state; the grid is rebuilt every step).
  const SolverCounters& counters() const { return counters_; }
  /// Restores counters() of a checkpoint (after the particles have been restored).
  void restore(const SolverCounters& n) { counters_ = n; }

  /// The grid_top_nodes loads' nodal forces per unit pressure on the initial top surface
  /// (mpm/step/grid_top_loads.hpp, exposed for tests).
  using TopNodeLoad = GridTopLoads::TopNodeLoad;
  const std::vector<TopNodeLoad>& top_node_loads() const { return top_loads_.top_node_loads(); }

 private:
  template <int W>
  void run_step();
  template <int W>
  void locate_particles(bool clear_grid);
  template <int W>
  void particles_to_grid();
  void external_forces();
  void update_grid();
  template <int W, bool kScatterMomentum>
  void grid_to_particles();
  // XPIC(m) (solver.xpic_order m > 1): xpic_term_ by xpic_grid_term (grid_stages.hpp), S+ S
  // gathered and extrapolated through the mirrors and ties as the momentum is. The update's
  // PIC part is then S (v' + xpic_term_).
  template <int W>
  void xpic_extrapolation();
  // MUSL: the nodes' momentum and velocity from the updated particles' momentum, which
  // grid_to_particles<W, true> scattered.
  void remap();
  template <int W>
  void update_stress(const std::vector<Vec2>& node_velocity);
  template <int W>
  struct Shape;
  template <int W>
  struct StencilReader;
  template <int W>
  StencilReader<W> stencil_reader() const;
  void check_particles();
  /// Zeroes cell_volume_ and cell_trace_ over the cell rows of a band.
  void clear_band_cells(int band);
  void build_constraints();
  double gravity_factor(double t) const;
  double particle_kinetic_energy() const;

  Case case_;
  Particles particles_;
  GridState grid_;
  SolverCounters counters_;  ///< time, step, dt, damping, load switches, works
  double critical_dt_ = 0.0;
  double max_wave_speed_ = 0.0;
  StageTimes times_;
  ExternalForceHook hook_;
  GridVelocityHook velocity_hook_;
  GridTopLoads top_loads_;
  LoadWorkRecorder load_work_recorder_;
  std::vector<double> step_work_;     ///< the work of each load and constraint in this step
  PrescribedVelocity prescribed_;     ///< moving supports (boundary_conditions[].velocity)
  BasisExtension extension_;          ///< the outer nodes' ties (solver.outer_node_fraction)
  WallMirror mirror_;                 ///< the nodes behind walls inside the grid (B-splines)
  double extension_density_ = 0.0;    ///< t/m^3, the densest particle's at the start
  std::vector<int> loaded_massless_;  ///< nodes without mass or tie that took a load
  /// Ties the outer nodes of this step (basis_extension.hpp) and gathers what the particles
  /// gave them.
  void tie_outer_nodes();

  // Per-step work arrays (sized once).
  /// Linear stencil of a particle: its cell (i, j) and local coordinates in [0, 1).
  struct LinearStencil {
    double xi;
    double eta;
    int i;
    int j;
  };
  std::vector<LinearStencil> linear_stencil_;
  /// GIMP and B-splines: the 1D factors of each particle's W x W stencil, 4 W per particle
  /// (StencilReader in the .cpp), and the stencil's base node.
  std::vector<double> stencil_factors_;
  std::vector<std::array<int, 2>> stencil_base_;
  int band_rows_ = 1;  ///< cell rows per band
  int n_bands_ = 1;
  int n_chunks_ = 1;                ///< fixed particle chunks of the parallel binning
  std::vector<int> particle_band_;  ///< band of each particle
  std::vector<int> chunk_offsets_;  ///< n_chunks x n_bands counts, then cursors
  std::vector<int> band_start_;     ///< n_bands + 1 offsets into sorted_
  std::vector<int> sorted_;         ///< particle ids binned by band, ascending within a band
  // Mean dilatation (solver.anti_locking "bbar"; empty otherwise): each particle's cell (of its
  // position at locate), its velocity gradient, and per cell the sums of V and V tr over the
  // particles in it (each band sums the cells of its rows, particles in id order).
  std::vector<int> particle_cell_;
  std::vector<Mat2> velocity_gradient_;
  std::vector<double> cell_volume_;
  std::vector<double> cell_trace_;
  std::vector<MaterialConstants> material_constants_;  ///< per case material
  std::vector<PointEnergy> point_energy_blocks_;  ///< stress-update ledger terms per particle block
  std::vector<double> kinetic_blocks_;            ///< particle kinetic energy per particle block
  std::vector<NodeEnergy> node_energy_;           ///< grid-update ledger terms per node block
  double grid_kinetic_after_ = 0.0;               ///< nodal kinetic energy after the grid update
  bool kinetic_stale_ = true;            ///< the ledger's particle_kinetic is to be taken anew
  std::vector<Vec2> remapped_velocity_;  ///< MUSL: nodal velocity from updated particles
  std::vector<Vec2> remapped_momentum_;  ///< MUSL: nodal momentum of updated particles
  std::vector<Vec2> xpic_term_;          ///< XPIC(m): the PIC part's grid term (m > 1 only)
  std::vector<Vec2> xpic_iterate_;       ///< XPIC(m): g_r
  std::vector<Vec2> xpic_sum_;           ///< XPIC(m): sum_p N m_p (S g_(r-1))_p
  bool parallel_ = true;         ///< run the stages on all threads (false for tiny problems)
  long bad_particle_ = -1;       ///< a particle with a non-finite value in this step, or -1
  long inverted_particle_ = -1;  ///< a particle whose det F <= 0 after this step, or -1
  double max_speed_ = 0.0;       ///< largest particle speed after this step, m/s
};

}  // namespace pfm

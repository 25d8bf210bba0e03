// The initial stress procedures (zero, K0, gravity loading) with the step counters that the MPM
// and the UL-FEM share.
#pragma once

#include <functional>

#include "mpm/step/case.hpp"
#include "mpm/step/energy_ledger.hpp"
#include "mpm/step/particles.hpp"

namespace pfm {

/// The scalars an explicit solver (the MPM or the UL-FEM) carries from step to step besides
/// its particles; checkpoints save them.
struct SolverCounters {
  double time = 0.0;              ///< s
  long step = 0;                  ///< steps taken since time 0
  double dt = 0.0;                ///< s
  double damping = 0.0;           ///< local damping coefficient in force
  bool loads_active = true;       ///< surface loads applied (off during gravity loading)
  bool gravity_full = false;      ///< gravity at its full value from the start (no ramp)
  long initial_stress_steps = 0;  ///< steps of the gravity loading (0 for zero and K0)
  EnergyLedger energy;            ///< the energy ledger since time 0 (energy_ledger.hpp)
};

/// The initial stress procedure of the case (shared by the MPM and the UL-FEM). Zero: nothing.
/// K0: apply_k0_stress(), full gravity from the start. Gravity loading: full gravity, the
/// procedure's damping and no surface loads; `step()` until the kinetic energy
/// (`kinetic_energy()`) falls below spec.kinetic_energy_ratio x its peak (after at least 10
/// steps; SimulationError when spec.max_time passes first); then the damping and the loads are
/// restored, the velocities zeroed, the reference positions set to the current ones, and time,
/// step and the energy ledger reset (initial_stress_steps keeps the count). Returns true after
/// gravity loading: the caller resets what else measures displacement.
bool initialise_stress(const Case& c, Particles& particles, SolverCounters& counters,
                       const std::function<void()>& step,
                       const std::function<double()>& kinetic_energy);

}  // namespace pfm

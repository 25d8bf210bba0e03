// What every solver on the background grid or mesh shares with the code around its step: the
// error that stops a run, the view of a step that the hooks get, and the hooks' types.
#pragma once

#include <functional>
#include <stdexcept>
#include <vector>

#include "mpm/core/types.hpp"
#include "mpm/step/energy_ledger.hpp"
#include "mpm/step/grid_stages.hpp"
#include "mpm/step/particles.hpp"

namespace pfm {

/// A run that cannot go on (NaN, CFL violation, particle leaving the grid, particle or element
/// inversion).
class SimulationError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// What a hook sees of the step it is called in: the time at the step's start, its size and
/// count, the material points as the step found them, and where the external-force hook records
/// each load's nodal forces (for the work of each load, EnergyLedger::load_work_by_load). The
/// hooks see nothing else of the solver.
struct StepView {
  double time = 0.0;  ///< s
  double dt = 0.0;    ///< s
  long step = 0;
  const Particles& particles;
  LoadWorkRecorder& load_work;
};

/// Extra external forces added to the grid each step (the boundary-traction stage hooks in
/// here). Called after particles_to_grid with the nodal masses and internal forces known (after
/// the ties: a tied node shows no mass, and a force added to it goes through its tie); adds
/// into `force` (grid_state.external_force). It may move internal forces between nodes,
/// conserving their sum and moment (the lost-load rule of boundary_coupling.hpp).
using ExternalForceHook =
    std::function<void(const StepView& step, GridState& grid_state, std::vector<Vec2>& force)>;

/// Observer of the updated grid velocities (after the grid update, before grid-to-particles):
/// surface markers ride on them (thesis eq. 4.6-4.7).
using GridVelocityHook = std::function<void(const StepView& step, const GridState& grid_state)>;

}  // namespace pfm

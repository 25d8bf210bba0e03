// The order of an explicit step's stages (case solver.scheme; thesis 3.3), for the MPM and the
// UL-FEM alike, with the wall-clock time of each.
#pragma once

#include "mpm/step/case.hpp"
#include "mpm/step/stage_timer.hpp"

namespace pfm {

/// Wall-clock seconds spent per stage, accumulated over the run. With MUSL, the MPM's
/// grid_to_particles includes the scatter of the updated particle momentum (done in the same
/// pass), and remap the nodal velocities computed from it.
struct StageTimes {
  double locate = 0, particles_to_grid = 0, external_forces = 0, update_grid = 0,
         grid_to_particles = 0, remap = 0, stress = 0;
  double total() const {
    return locate + particles_to_grid + external_forces + update_grid + grid_to_particles + remap +
           stress;
  }
};

/// Runs the stages of one step in the order of `scheme`, each under its timer in `times`:
///   particles_to_grid, external_forces, update_grid, grid_to_particles(musl),
///   remap (MUSL only), update_stress(musl).
/// USL updates the stress with the velocities of the grid update; MUSL (modified update stress
/// last, Sulsky, Zhou & Schreyer 1995) first maps the updated points' momentum back to the nodes
/// (the MPM scatters it in grid_to_particles; remap turns it into velocities with the prescribed
/// components) and takes the velocities from it. `stages` gives them as members: MpmSolver's and
/// UlFemSolver's step adapters. What comes before (the MPM locates its particles) and after
/// (the clock, the UL-FEM's mesh) is the solver's.
template <class Stages>
void run_stages(Scheme scheme, Stages&& stages, StageTimes& times) {
  const bool musl = scheme == Scheme::kMUSL;
  {
    StageTimer timer(times.particles_to_grid);
    stages.particles_to_grid();
  }
  {
    StageTimer timer(times.external_forces);
    stages.external_forces();
  }
  {
    StageTimer timer(times.update_grid);
    stages.update_grid();
  }
  {
    StageTimer timer(times.grid_to_particles);
    stages.grid_to_particles(musl);
  }
  if (musl) {
    StageTimer timer(times.remap);
    stages.remap();
  }
  {
    StageTimer timer(times.stress);
    stages.update_stress(musl);
  }
}

}  // namespace pfm

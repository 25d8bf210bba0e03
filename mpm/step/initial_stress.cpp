#include "mpm/step/initial_stress.hpp"

#include <algorithm>
#include <string>

#include "mpm/step/body_fill.hpp"
#include "mpm/step/step_view.hpp"

namespace pfm {

bool initialise_stress(const Case& c, Particles& particles, SolverCounters& counters,
                       const std::function<void()>& step,
                       const std::function<double()>& kinetic_energy) {
  switch (c.initial_stress.method) {
    case InitialStressMethod::kZero:
      return false;
    case InitialStressMethod::kK0:
      apply_k0_stress(c, particles);
      counters.gravity_full = true;
      return false;
    case InitialStressMethod::kGravity:
      break;
  }
  const InitialStressSpec& spec = c.initial_stress;
  const double saved_damping = counters.damping;
  counters.damping = spec.damping;
  counters.gravity_full = true;
  counters.loads_active = false;
  double peak = 0.0;
  while (true) {
    step();
    const double ke = kinetic_energy();
    peak = std::max(peak, ke);
    if (counters.step > 10 && peak > 0.0 && ke < spec.kinetic_energy_ratio * peak) break;
    if (counters.time > spec.max_time) {
      throw SimulationError("gravity loading did not reach kinetic energy ratio " +
                            std::to_string(spec.kinetic_energy_ratio) + " within " +
                            std::to_string(spec.max_time) + " s (ratio now " +
                            std::to_string(ke / peak) + ")");
    }
  }
  counters.damping = saved_damping;
  counters.loads_active = true;
  for (std::size_t p = 0; p < particles.size(); ++p) {
    particles.velocity[p].setZero();
    particles.reference_position[p] = particles.position[p];
  }
  counters.initial_stress_steps = counters.step;
  counters.time = 0.0;
  counters.step = 0;
  counters.energy = EnergyLedger{};
  return true;
}

}  // namespace pfm

// Helpers for the UL-FEM tests: cases as JSON documents, running to rest.
#pragma once

#include <algorithm>
#include <nlohmann/json.hpp>
#include <string>

#include "fem_reference/ulfem/ulfem_solver.hpp"

namespace pfm::ulfem::testing {

/// Elastic block [0, width] x [0, height] on a grid of cell h with `margin` empty cells above
/// and beside it, rollers on left and right, fixed base; E = 1e4 kPa, nu = 0.15, gamma = 20.
inline nlohmann::json block_case(double width, double height, double h, int margin_x,
                                 int margin_top) {
  nlohmann::json j = nlohmann::json::parse(R"({
    "grid": {"origin": [0, 0]},
    "materials": [{"name": "soil", "model": "linear_elastic", "youngs_modulus": 10000.0,
                   "poisson_ratio": 0.15, "unit_weight": 20.0}],
    "bodies": [{"name": "block", "material": "soil", "points_per_cell": 2,
                "placement": "gauss"}],
    "gravity": {"g": 9.81},
    "boundary_conditions": [{"where": "bottom", "fix": "xy"}, {"where": "left", "fix": "x"},
                            {"where": "right", "fix": "x"}],
    "solver": {"scheme": "musl", "shape_function": "linear", "damping": 0.7},
    "time": {"end_time": 1.0, "cfl": 0.5}
  })");
  const int nx = static_cast<int>(std::lround(width / h)) + margin_x;
  const int ny = static_cast<int>(std::lround(height / h)) + margin_top;
  j["grid"]["cell_size"] = h;
  j["grid"]["n_cells"] = {nx, ny};
  j["bodies"][0]["rectangle"] = {{0.0, 0.0}, {width, height}};
  return j;
}

/// Step until the kinetic energy is below ratio x its peak (after at least 20 steps); returns
/// the simulated time used, or -1 if max_time passed first.
inline double run_to_rest(UlFemSolver& solver, double ratio, double max_time) {
  double peak = 0.0;
  const double start = solver.time();
  while (solver.time() - start < max_time) {
    solver.step();
    const double ke = solver.energy().kinetic_energy;
    peak = std::max(peak, ke);
    if (solver.step_count() > 20 && peak > 0.0 && ke < ratio * peak) return solver.time() - start;
  }
  return -1.0;
}

}  // namespace pfm::ulfem::testing

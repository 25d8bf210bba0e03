// Helpers for solver tests: cases built as JSON documents.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace pfm::testing {

/// Oedometric column: width 2 cells, height `height`, rollers on the sides, fixed base,
/// E = 1e4 kPa, nu = 0.15, unit weight 20 kN/m^3, gravity ramped over 0.5 s, damped.
inline nlohmann::json column_case(double height, double cell, int points_per_cell,
                                  const std::string& placement) {
  nlohmann::json j = nlohmann::json::parse(R"({
    "grid": {"origin": [0, 0]},
    "materials": [{"name": "soil", "model": "linear_elastic", "youngs_modulus": 10000.0,
                   "poisson_ratio": 0.15, "unit_weight": 20.0}],
    "bodies": [{"name": "column", "material": "soil"}],
    "gravity": {"g": 9.81, "ramp_time": 0.5},
    "boundary_conditions": [{"where": "bottom", "fix": "xy"}, {"where": "left", "fix": "x"},
                            {"where": "right", "fix": "x"}],
    "solver": {"scheme": "musl", "shape_function": "linear", "damping": 0.2},
    "time": {"end_time": 4.0, "cfl": 0.5}
  })");
  j["grid"]["cell_size"] = cell;
  j["grid"]["n_cells"] = {2, static_cast<int>(height / cell + 0.5) + 2};
  j["bodies"][0]["rectangle"] = {{0.0, 0.0}, {2 * cell, height}};
  j["bodies"][0]["points_per_cell"] = points_per_cell;
  j["bodies"][0]["placement"] = placement;
  return j;
}

}  // namespace pfm::testing

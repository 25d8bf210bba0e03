// What the implicit tests assert of a linear problem's load steps.
#pragma once

#include <gtest/gtest.h>

#include <cstddef>
#include <nlohmann/json.hpp>

#include "mpm/implicit/implicit_solver.hpp"

namespace pfm {

/// The boundary conditions of a block on the grid's bottom: fixed base, rollers on both sides.
inline nlohmann::json base_and_rollers() {
  return {{{"where", "bottom"}, {"fix", "xy"}},
          {{"where", "left"}, {"fix", "x"}},
          {{"where", "right"}, {"fix", "x"}}};
}

/// A vertical pressure on the detected top (or on the grid-top nodes) over x in [0, 1] m, by
/// default ramped over the first second.
inline nlohmann::json pressure_on_top(double pressure,
                                      const nlohmann::json& time_function = {{"type", "ramp"},
                                                                             {"ramp_time", 1.0}},
                                      const char* apply_on = "detected_boundary") {
  return {{{"type", "vertical_pressure"},
           {"pressure", pressure},
           {"x_range", {0.0, 1.0}},
           {"apply_on", apply_on},
           {"time_function", time_function}}};
}

/// The mean pressure the points carry, -sum V sigma_yy / sum V (kPa).
inline double carried_pressure(const Particles& points) {
  double force = 0.0, area = 0.0;
  for (std::size_t p = 0; p < points.size(); ++p) {
    force -= points.volume[p] * points.stress[p][kYY];
    area += points.volume[p];
  }
  return force / area;
}

/// A linear problem (elastic, small rotations): `steps` load steps, each converged, each one's
/// first correction leaving round-off (relative residual below 1e-10) and ending it (the next
/// correction it would ask for is round-off too).
inline void expect_one_correction_per_step(const ImplicitSolver& solver, std::size_t steps) {
  ASSERT_EQ(solver.log().size(), steps);
  for (const LoadStepLog& e : solver.log()) {
    EXPECT_TRUE(e.converged);
    ASSERT_EQ(e.residuals.size(), 2u);
    EXPECT_LE(e.residuals[1], 1e-10);
  }
}

}  // namespace pfm

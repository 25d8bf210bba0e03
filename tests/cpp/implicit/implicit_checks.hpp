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

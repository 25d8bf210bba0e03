// Essential conditions on the detected boundary in the implicit step
// (mpm/implicit/implicit_constraints.cpp): a weightless elastic column pressed down by its
// detected top, by penalty, Nitsche's method and the Implicit Boundary Method, with every shape
// function, and the shipped block turned 30 degrees to the grid, against the closed form of
// uniaxial strain.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <numbers>
#include <string>

#include "mpm/core/json_input.hpp"
#include "mpm/implicit/implicit_solver.hpp"
#include "tests/cpp/implicit/implicit_checks.hpp"
#include "tests/cpp/inclined_block.hpp"

namespace pfm {
namespace {

constexpr double kHeight = 4.0, kPush = 0.004;  // m: the top's prescribed settlement
constexpr double kYoungs = 5e5, kPoisson = 0.25;

// A weightless elastic column 1 m wide and 4 m high on a fixed base between rollers (the
// grid's edges), its detected top pushed down by kPush over the run (a ramp), in 4 load steps.
nlohmann::json pressed_column(const std::string& shape, const std::string& method) {
  return {{"title", "implicit pressed column"},
          {"grid", {{"origin", {0.0, 0.0}}, {"cell_size", 0.25}, {"n_cells", {4, 20}}}},
          {"materials",
           {{{"name", "soil"},
             {"model", "linear_elastic"},
             {"youngs_modulus", kYoungs},
             {"poisson_ratio", kPoisson},
             {"unit_weight", 0.0}}}},
          {"bodies",
           {{{"name", "column"},
             {"material", "soil"},
             {"rectangle", {{0.0, 0.0}, {1.0, kHeight}}},
             {"points_per_cell", 2}}}},
          {"boundary_conditions", base_and_rollers()},
          {"constraints",
           {{{"apply_on", "detected_boundary"},
             {"faces", "top"},
             {"normal_displacement", -kPush},
             {"time_function", {{"type", "ramp"}, {"ramp_time", 1.0}}},
             {"method", method}}}},
          {"solver", {{"type", "implicit"}, {"shape_function", shape}}},
          {"implicit", {{"load_steps", 4}}},
          {"time", {{"end_time", 1.0}}}};
}

TEST(ImplicitConstraints, PressedColumnMatchesUniaxialStrainByEachMethod) {
  // Uniaxial strain under a hypoelastic law whose increments are taken on the current height:
  // sigma_yy = -M ln(H / (H - kPush)) throughout (M = E (1 - nu) / ((1 + nu)(1 - 2 nu))), the
  // force on the body that times 1 m. Nitsche's method is consistent: its gap is a round-off
  // of the penalty's; the IBM's band leaves 3 delta / 8 of the strain, 1e-7 of the push. The
  // penalty's gap is its traction over beta (100 M / h), and its settlement kPush less that gap.
  const double m = kYoungs * (1.0 - kPoisson) / ((1.0 + kPoisson) * (1.0 - 2.0 * kPoisson));
  const double beta = 100.0 * m / 0.25;
  for (const char* method : {"penalty", "nitsche", "ibm"}) {
    for (const char* shape : {"linear", "gimp", "quadratic_bspline", "cubic_bspline"}) {
      SCOPED_TRACE(std::string(method) + ", " + shape);
      const Case c = parse_case(pressed_column(shape, method), "pressed.json");
      ImplicitSolver solver(c);
      solver.run_to(1.0);
      ASSERT_EQ(solver.constraint_reports().size(), 1u);
      const ConstraintReport& r = solver.constraint_reports()[0];
      EXPECT_NEAR(r.length, 1.0, 1e-4);  // the detected top's length
      const bool penalty = std::string(method) == "penalty";
      const double gap = penalty ? m * kPush / kHeight / beta : 0.0;
      if (!penalty) {
        EXPECT_LE(r.rms_gap, 1e-4 * kPush);
      } else {
        EXPECT_NEAR(r.rms_gap / gap, 1.0, 1e-2);
      }
      const double exact = -m * std::log(kHeight / (kHeight - kPush + gap));
      // Cubic B-splines: the rows next to the top oscillate (up to 12 % at 2 x 2 points per cell,
      // the boundary issue), and the fit that reads the top's displacement from them is off by
      // 0.2 %; the bar for them is 5e-3, 1e-3 for the others.
      const double bar = std::string(shape) == "cubic_bspline" ? 5e-3 : 1e-3;
      EXPECT_NEAR(r.force.y() / exact, 1.0, bar);
      EXPECT_NEAR(r.force.x(), 0.0, 1e-9 * m * kPush);
      // The stress of the lower half: its mean within the bar, each point within 5e-3. (The rows
      // next to the top are the boundary issue's: the top moves into the cell under its node row
      // and shares the force with it, 1.3 % with linear functions.)
      const Particles& p = solver.particles();
      double worst = 0.0, sum = 0.0, count = 0.0;
      for (std::size_t k = 0; k < p.size(); ++k) {
        if (p.reference_position[k].y() > 0.5 * kHeight) continue;
        worst = std::max(worst, std::abs(p.stress[k][kYY] / exact - 1.0));
        sum += p.stress[k][kYY];
        count += 1.0;
      }
      EXPECT_NEAR(sum / count / exact, 1.0, bar);
      EXPECT_LE(worst, 5e-3);
      // Linear: each step's first correction leaves round-off.
      expect_one_correction_per_step(solver, 4);
    }
  }
}

// A rigid smooth footing of half-width b = 1 m pushed into weightless, perfectly plastic Tresca
// soil (c = 10 kPa, nu = 0.49, B-bar by default) by Nitsche's method on its detected top, half of
// it by symmetry: a 3 m block, 4 cells under b, uGIMP, 10 load steps of 0.00375 b to 0.0375 b.
nlohmann::json pushed_footing(const nlohmann::json& solver) {
  return {{"title", "implicit rigid footing"},
          {"grid", {{"origin", {0.0, 0.0}}, {"cell_size", 0.25}, {"n_cells", {12, 14}}}},
          {"materials",
           {{{"name", "clay"},
             {"model", "tresca"},
             {"youngs_modulus", 1e4},
             {"poisson_ratio", 0.49},
             {"unit_weight", 20.0},
             {"cohesion", 10.0}}}},
          {"bodies",
           {{{"name", "layer"},
             {"material", "clay"},
             {"rectangle", {{0.0, 0.0}, {3.0, 3.0}}},
             {"points_per_cell", 2}}}},
          {"gravity", {{"g", 0.0}}},
          {"boundary_conditions", base_and_rollers()},
          {"constraints",
           {{{"apply_on", "detected_boundary"},
             {"x_range", {-1.0, 1.0}},
             {"faces", "top"},
             {"normal", {{"direction", {0.0, 1.0}}, {"max_angle", 45.0}}},
             {"normal_velocity", -0.0375},
             {"method", "nitsche"},
             {"penalty_factor", 16.0}}}},
          {"solver", solver},
          {"implicit", {{"load_steps", 10}}},
          {"time", {{"end_time", 1.0}}}};
}

TEST(ImplicitConstraints, RigidFootingConvergesIntoPerfectlyPlasticSoil) {
  // With the ties of the nearly empty nodes (the default), every load step converges at its
  // first attempt, on uGIMP (the benchmarks' functions) and on the default quadratic B-splines;
  // without them (outer_node_fraction 0) the steps past the yield of the soil under the
  // footing's edge are cut back, or the run stops (Newton stalls where a node's support is a
  // sliver of plastic points).
  struct Run {
    const char* shape;  // nullptr: the default
    bool tied;
    double max_reaction;  // over (2 + pi) c
  };
  // The reaction at 0.0375 b, on the plateau: above Prandtl's (2 + pi) c, which a grid of 4 cells
  // under b exceeds by an error of first order in h / b (the benchmarks' footing in
  // study-implicit has it at 8 and 16 cells), the same bar whichever the functions. The
  // B-splines reach one and a half cells past the footing's edge: a constraint that pushed on
  // the nodes there (not sharing its force by each node's share of the part's material) would
  // act as a footing wider by about that much, 1.30 here.
  for (const Run run : {Run{"gimp", true, 1.12}, Run{nullptr, true, 1.12}, Run{"gimp", false, 0}}) {
    SCOPED_TRACE(std::string(run.shape ? run.shape : "default") + (run.tied ? "" : ", no ties"));
    nlohmann::json solver = {{"type", "implicit"}};
    if (run.shape) solver["shape_function"] = run.shape;
    if (!run.tied) solver["outer_node_fraction"] = 0.0;
    const Case c = parse_case(pushed_footing(solver), "footing.json");
    ImplicitSolver solver_run(c);
    try {
      solver_run.run_to(1.0);
    } catch (const ImplicitDivergence&) {
      EXPECT_FALSE(run.tied);  // without the ties it may stop altogether
    }
    const auto& log = solver_run.log();
    const auto cut =
        std::count_if(log.begin(), log.end(), [](const LoadStepLog& e) { return !e.converged; });
    if (!run.tied) {
      EXPECT_GT(cut, 0);
      continue;
    }
    EXPECT_EQ(cut, 0);
    ASSERT_EQ(log.size(), 10u);
    // At most 6 Newton iterations per step on average (must-show 1): the points that yielded in
    // the last step start from their plastic tangent (8 per step from the elastic one).
    std::size_t iterations = 0;
    for (const LoadStepLog& e : log) iterations += e.residuals.size() - 1;
    EXPECT_LE(iterations, 6u * log.size());
    const double prandtl = (2.0 + std::numbers::pi) * 10.0;
    const double q = -solver_run.constraint_reports()[0].force.y() / prandtl;
    EXPECT_GT(q, 1.0);
    EXPECT_LT(q, run.max_reaction);
  }
}

TEST(ImplicitConstraints, AHeldFootingStartsEachStepFromTheBalanceItReached) {
  // The footing above pushed to 0.0375 b by a displacement ramped over 10 load steps, then held
  // for two: a held step asks for no motion, so it starts from the balance the last one
  // reached, less what moving the points to their new positions changes (the last push's
  // strain). The second held step follows one that moved little (the stresses settling): its
  // first relative residual is that of the geometry's change. Were the gap measured afresh from
  // the particles at each step (not carried with the boundary), the grid's and the particles'
  // motion at the footing's edge would differ by a fraction of a cell that the penalty turns
  // into a relative residual above 1 at every step, held or not: the bar, 1e-2, is two orders
  // below that.
  for (const char* shape : {"gimp", "quadratic_bspline"}) {
    for (const char* method : {"nitsche", "penalty"}) {
      SCOPED_TRACE(std::string(shape) + ", " + method);
      nlohmann::json document = pushed_footing({{"type", "implicit"}, {"shape_function", shape}});
      nlohmann::json& constraint = document["constraints"][0];
      constraint.erase("normal_velocity");
      constraint["normal_displacement"] = -0.0375;
      constraint["time_function"] = {{"type", "ramp"}, {"ramp_time", 1.0}};
      constraint["method"] = method;
      document["implicit"]["load_steps"] = 12;
      document["time"]["end_time"] = 1.2;
      const Case c = parse_case(document, "held_footing.json");
      ImplicitSolver solver(c);
      solver.run_to(1.2);
      const auto& log = solver.log();
      ASSERT_EQ(log.size(), 12u);  // each step at its first attempt
      EXPECT_LE(log.back().residuals.front(), 1e-2);
      EXPECT_LE(log.back().residuals.size(), 6u);
    }
  }
}

// The shipped inclined block (tests/cpp/inclined_block.hpp, quadratic B-splines) run implicitly
// in 4 load steps over the push's smooth ramp, by penalty, Nitsche's method and the IBM.
TEST(ImplicitConstraints, InclinedBlockReachesUniaxialStrain) {
  std::ifstream in("cases/constraint_inclined_block.json");
  nlohmann::json document = nlohmann::json::parse(in);
  document["solver"] = {{"type", "implicit"}};
  document["time"] = {{"end_time", 0.1}};
  document["implicit"] = {{"load_steps", 4}};
  for (const char* method : {"penalty", "nitsche", "ibm"}) {
    SCOPED_TRACE(method);
    for (auto& constraint : document["constraints"]) constraint["method"] = method;
    const Case c = parse_case(document, "cases/constraint_inclined_block.json");
    ImplicitSolver solver(c);
    solver.run_to(0.1);
    const inclined_block::Errors r = inclined_block::measure(
        solver.particles(), elastic_parameters(c.materials[0].model), solver.constraint_reports());
    ASSERT_GT(r.interior_points, 100);
    // Issue 47's bars for an essential condition on an inclined face: the interior's stress and
    // the reactions within 1 %; every interior point within the explicit test's 4 %.
    EXPECT_LE(std::abs(r.interior_nn), 0.01);
    EXPECT_LE(std::abs(r.interior_tt), 0.01);
    EXPECT_LE(r.worst_point, 0.04);
    EXPECT_LE(std::abs(r.reaction), 0.01);
    EXPECT_LE(std::abs(r.opposite), 0.01);
    // Linear elastic, small rotations: each step's first correction leaves round-off.
    expect_one_correction_per_step(solver, 4);
  }
}

}  // namespace
}  // namespace pfm

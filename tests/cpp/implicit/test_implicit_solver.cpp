// The implicit quasi-static MPM (mpm/implicit/implicit_solver.hpp): the elastic column against its
// closed form with every shape function, Newton's quadratic convergence on a plastic footing,
// the cut-backs and the stop of a step that cannot converge, the strength reduction's factor of
// safety against a closed form, and the cases it refuses.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include "mpm/core/json_input.hpp"
#include "mpm/implicit/implicit_solver.hpp"
#include "mpm/step/body_fill.hpp"
#include "tests/cpp/implicit/implicit_checks.hpp"

namespace pfm {
namespace {

constexpr double kHeight = 4.0, kUnitWeight = 18.0, kSurcharge = 30.0;

// An elastic column, 1 m wide and 4 m high, on a fixed base between rollers (the grid's edges),
// under its weight and a pressure on its detected top, both ramped over the run (nu = 0.25).
nlohmann::json column_case(const std::string& shape, double youngs_modulus) {
  return {{"title", "implicit column"},
          {"grid", {{"origin", {0.0, 0.0}}, {"cell_size", 0.25}, {"n_cells", {4, 20}}}},
          {"materials",
           {{{"name", "soil"},
             {"model", "linear_elastic"},
             {"youngs_modulus", youngs_modulus},
             {"poisson_ratio", 0.25},
             {"unit_weight", kUnitWeight}}}},
          {"bodies",
           {{{"name", "column"},
             {"material", "soil"},
             {"rectangle", {{0.0, 0.0}, {1.0, kHeight}}},
             {"points_per_cell", 2}}}},
          {"gravity", {{"g", 9.81}, {"ramp_time", 1.0}}},
          {"boundary_conditions", base_and_rollers()},
          {"loads", pressure_on_top(kSurcharge)},
          {"solver", {{"type", "implicit"}, {"shape_function", shape}}},
          {"implicit", {{"load_steps", 5}}},
          {"time", {{"end_time", 1.0}}}};
}

TEST(ImplicitSolver, ElasticColumnMatchesTheClosedFormWithEveryShapeFunctionAndLoadPath) {
  // E = 5e5 kPa: strains of 1e-4, so the small-strain closed form holds to about 1e-4.
  //   u(y) = -[q y + gamma (H y - y^2 / 2)] / M,  sigma_yy(y) = -q - gamma (H - y),
  // M = E (1 - nu) / ((1 + nu)(1 - 2 nu)).
  // The surcharge on the detected top, and on the grid-top nodes (the explicit step's load).
  const double e_modulus = 5e5, m = e_modulus * 0.75 / (1.25 * 0.5);
  for (const char* apply_on : {"detected_boundary", "grid_top_nodes"})
    for (const char* shape : {"linear", "gimp", "quadratic_bspline", "cubic_bspline"}) {
      SCOPED_TRACE(std::string(shape) + " " + apply_on);
      nlohmann::json document = column_case(shape, e_modulus);
      document["loads"] =
          pressure_on_top(kSurcharge, {{"type", "ramp"}, {"ramp_time", 1.0}}, apply_on);
      const Case c = parse_case(document, "column.json");
      ImplicitSolver solver(c);
      solver.run_to(1.0);
      EXPECT_DOUBLE_EQ(solver.time(), 1.0);
      const Particles& p = solver.particles();
      double top = 0.0;
      for (const Vec2& x : p.reference_position) top = std::max(top, x.y());
      // The top row's settlement, and the mean stress of the two rows next to mid-depth (one cell
      // row: the linear functions' strain is constant in a cell); each of their points with
      // B-splines.
      double settlement = 0.0, top_row = 0.0, rows = 0.0, stress = 0.0, exact_stress = 0.0;
      double worst_point = 0.0;
      for (std::size_t k = 0; k < p.size(); ++k) {
        const double y = p.reference_position[k].y();
        if (y == top) {
          settlement += p.reference_position[k].y() - p.position[k].y();
          top_row += 1.0;
        }
        if (std::abs(y - 0.5 * kHeight) < 0.125) {
          const double exact = -kSurcharge - kUnitWeight * (kHeight - y);
          stress += p.stress[k][kYY];
          exact_stress += exact;
          rows += 1.0;
          worst_point = std::max(worst_point, std::abs(p.stress[k][kYY] / exact - 1.0));
        }
      }
      ASSERT_EQ(top_row, 8.0);
      ASSERT_EQ(rows, 16.0);
      settlement /= top_row;
      const double exact_settlement =
          (kSurcharge * top + kUnitWeight * (kHeight * top - 0.5 * top * top)) / m;
      EXPECT_NEAR(settlement / exact_settlement, 1.0, 1e-3);
      EXPECT_NEAR(stress / exact_stress, 1.0, 1e-3);
      if (std::string(shape).find("bspline") != std::string::npos) {
        EXPECT_LE(worst_point, 1e-3);
      }
      // A linear problem: the first correction of every step leaves round-off.
      expect_one_correction_per_step(solver, 5);
    }
}

TEST(ImplicitSolver, GravityLoadingSettlesTheColumnThenMeasuresFromThere) {
  // initial_stress "gravity": the column settles under its weight alone before t = 0, in load
  // steps: sigma_yy = -gamma (H - y), sigma_xx = K0 sigma_yy (K0 = nu / (1 - nu), the
  // oedometric state), at rest with its displacements measured from there. Then the surcharge
  // alone moves it: the top by q H / M; gravity stays full (its ramp is the settling's).
  const double e_modulus = 5e5, m = e_modulus * 0.75 / (1.25 * 0.5);
  for (const char* shape : {"linear", "quadratic_bspline"}) {
    SCOPED_TRACE(shape);
    nlohmann::json document = column_case(shape, e_modulus);
    document["initial_stress"] = {{"method", "gravity"}};
    const Case c = parse_case(document, "column.json");
    ImplicitSolver solver(c);
    solver.initialise_stress();
    EXPECT_EQ(solver.time(), 0.0);
    EXPECT_TRUE(solver.log().empty());
    ASSERT_FALSE(solver.initial_stress_log().empty());
    for (const LoadStepLog& e : solver.initial_stress_log()) EXPECT_TRUE(e.converged);
    const Particles& p = solver.particles();
    // Equilibrium tested with v = y e_y, which every shape function reproduces: sum_p V_p
    // sigma_yy = -sum_p m_p g y_p (the base's reaction does no work on it), on the geometry the
    // last load step started from: on the settled one, to that step's strain (1e-4). Each
    // point within 2 % of gamma H of the weight above it (linear functions: the cell's stress is
    // constant, so a point a quarter cell from the centre is off by h / (4 H) of gamma H),
    // sigma_xx = K0 sigma_yy within 1e-3.
    const Particles filled_at_start = fill_bodies(c);
    double worst = 0.0, worst_k0 = 0.0, stress = 0.0, weight_moment = 0.0;
    for (std::size_t k = 0; k < p.size(); ++k) {
      EXPECT_EQ(p.position[k], p.reference_position[k]);
      stress += p.volume[k] * p.stress[k][kYY];
      weight_moment -= p.mass[k] * 9.81 * p.position[k].y();
      const double y = filled_at_start.position[k].y();
      const double exact = -kUnitWeight * (kHeight - y);
      worst = std::max(worst, std::abs(p.stress[k][kYY] - exact) / (kUnitWeight * kHeight));
      worst_k0 = std::max(
          worst_k0, std::abs(p.stress[k][kXX] - p.stress[k][kYY] / 3.0) / (kUnitWeight * kHeight));
    }
    EXPECT_NEAR(stress / weight_moment, 1.0, 1e-4);
    EXPECT_LE(worst, 2e-2);
    EXPECT_LE(worst_k0, 1e-3);
    solver.run_to(1.0);
    // The top row (by its original height, which the settling moved by 1e-4 of the column's):
    // the surcharge's closed form at that height.
    const Particles filled = fill_bodies(c);
    double top = 0.0;
    for (const Vec2& x : filled.position) top = std::max(top, x.y());
    double settlement = 0.0, n = 0.0;
    for (std::size_t k = 0; k < p.size(); ++k) {
      if (filled.position[k].y() != top) continue;
      settlement += p.reference_position[k].y() - p.position[k].y();
      n += 1.0;
    }
    ASSERT_EQ(n, 8.0);
    EXPECT_NEAR(settlement / n / (kSurcharge * top / m), 1.0, 1e-3);
  }
}

TEST(ImplicitSolver, ThreadsSumTheSameTangentAndForces) {
  // The column at h = 1/16 m (4,096 points, above the 2,000 from which a step's particles are
  // shared among threads): on 2 threads each thread adds into its own copy of the tangent and
  // the internal forces, summed after. A copy lost or added twice would move the settlement by
  // its share; the sums' order alone moves it by round-off.
  nlohmann::json document = column_case("quadratic_bspline", 5e5);
  document["grid"]["cell_size"] = 0.0625;
  document["grid"]["n_cells"] = {16, 80};
  const Case c = parse_case(document, "column.json");
  const int before = omp_get_max_threads();
  std::vector<double> settlement;
  for (const int threads : {1, 2, 2}) {
    omp_set_num_threads(threads);
    ImplicitSolver solver(c);
    solver.run_to(1.0);
    expect_one_correction_per_step(solver, 5);
    const Particles& p = solver.particles();
    ASSERT_EQ(p.size(), 4096u);
    double sum = 0.0;
    for (std::size_t k = 0; k < p.size(); ++k)
      sum += p.position[k].y() - p.reference_position[k].y();
    settlement.push_back(sum);
  }
  omp_set_num_threads(before);
  EXPECT_NEAR(settlement[1] / settlement[0], 1.0, 1e-12);
  EXPECT_EQ(settlement[1], settlement[2]);  // the same thread count: the same bytes
}

TEST(ImplicitSolver, ElasticColumnOnWallsInsideTheGridMatchesTheClosedForm) {
  // The base and the side walls as node sets with the nodes behind them (a margin of two
  // cells): with B-splines the nodes behind mirror the nodes in front (wall_mirror.hpp), so the
  // walls hold as the grid's edges do. Its weight alone (the detected top's corners are round
  // here, which the walls are not about).
  nlohmann::json document = column_case("quadratic_bspline", 5e5);
  document["grid"] = {{"origin", {-0.5, -0.5}}, {"cell_size", 0.25}, {"n_cells", {8, 24}}};
  document["node_sets"] = {{{"name", "base"}, {"box", {{-10.0, -10.0}, {10.0, 1e-9}}}},
                           {{"name", "left_wall"}, {"box", {{-10.0, 0.0}, {1e-9, 10.0}}}},
                           {{"name", "right_wall"}, {"box", {{1.0 - 1e-9, 0.0}, {10.0, 10.0}}}}};
  document["boundary_conditions"] = {{{"where", "base"}, {"fix", "xy"}},
                                     {{"where", "left_wall"}, {"fix", "x"}},
                                     {{"where", "right_wall"}, {"fix", "x"}}};
  document.erase("loads");
  const Case c = parse_case(document, "column.json");
  ImplicitSolver solver(c);
  solver.run_to(1.0);
  const Particles& p = solver.particles();
  double top = 0.0;
  for (const Vec2& x : p.reference_position) top = std::max(top, x.y());
  const double m = 5e5 * 0.75 / (1.25 * 0.5);
  const double exact = kUnitWeight * (kHeight * top - 0.5 * top * top) / m;
  int row = 0;
  for (std::size_t k = 0; k < p.size(); ++k) {
    if (p.reference_position[k].y() != top) continue;
    ++row;
    EXPECT_NEAR((top - p.position[k].y()) / exact, 1.0, 1e-3) << "x = " << p.position[k].x();
  }
  EXPECT_EQ(row, 8);
}

// A Tresca layer (c = 40 kPa, nu = 0.49, B-bar by default; weightless: g = 0) under a strip
// pressure on its detected top, half of it by symmetry, ramped to `pressure` over the run (or at
// once with `ramped` false).
nlohmann::json footing_case(double pressure, int load_steps, int max_cuts, bool ramped = true) {
  const nlohmann::json time_function = ramped ? nlohmann::json{{"type", "ramp"}, {"ramp_time", 1.0}}
                                              : nlohmann::json{{"type", "constant"}};
  return {
      {"title", "implicit strip footing"},
      {"grid", {{"origin", {0.0, 0.0}}, {"cell_size", 0.25}, {"n_cells", {24, 14}}}},
      {"materials",
       {{{"name", "clay"},
         {"model", "tresca"},
         {"youngs_modulus", 10000.0},
         {"poisson_ratio", 0.49},
         {"unit_weight", 20.0},
         {"cohesion", 40.0}}}},
      {"bodies",
       {{{"name", "layer"},
         {"material", "clay"},
         {"rectangle", {{0.0, 0.0}, {6.0, 3.0}}},
         {"points_per_cell", 2}}}},
      {"gravity", {{"g", 0.0}}},
      {"boundary_conditions", base_and_rollers()},
      {"loads", pressure_on_top(pressure, time_function)},
      {"solver", {{"type", "implicit"}}},
      {"implicit", {{"load_steps", load_steps}, {"max_cuts", max_cuts}, {"max_iterations", 10}}},
      {"time", {{"end_time", 1.0}}}};
}

constexpr double kPrandtl = (2.0 + std::numbers::pi) * 40.0;  // kPa

TEST(ImplicitSolver, TheGhostPenaltyIsConsistentAndInTheTangent) {
  // An elastic body 2 m wide whose top falls from 4 m to 3.3 m across it, under its weight in 2
  // load steps: along the sloping top some nodes hold between the tie fraction and twice it, so
  // the ghost penalty acts (implicit_solver.hpp). With the default (the key left out) and a
  // hundred times it:
  //  - every step, linear, still ends after one correction at round-off: the penalty's stiffness
  //    in the tangent is the derivative of its forces;
  //  - the settlement of the highest point moves (the penalty acts) by less than 1e-3 (1e-5 at
  //    the default): it acts only on what the nodes' arrays do not reproduce, the smooth field's
  //    higher differences (a penalty on the nodes' own increments would hold the top back by
  //    percents).
  nlohmann::json document = column_case("gimp", 5e4);
  document["bodies"][0].erase("rectangle");
  document["bodies"][0]["polygon"] = {{0.0, 0.0}, {2.0, 0.0}, {2.0, 3.3}, {0.0, 4.0}};
  document["grid"]["n_cells"] = {8, 20};
  document.erase("loads");
  document["implicit"]["load_steps"] = 2;
  for (const char* shape : {"gimp", "quadratic_bspline"}) {
    SCOPED_TRACE(shape);
    std::vector<double> settlement;
    for (const double gamma : {0.0, -1.0, 0.1}) {  // -1: the default
      document["solver"]["shape_function"] = shape;
      document["solver"].erase("ghost_penalty");
      if (gamma >= 0.0) document["solver"]["ghost_penalty"] = gamma;
      const Case c = parse_case(document, "ghost.json");
      ImplicitSolver solver(c);  // keeps a reference to the case
      solver.run_to(1.0);
      for (const LoadStepLog& e : solver.log()) {
        ASSERT_EQ(e.residuals.size(), 2u) << "t = " << e.time;
        EXPECT_LT(e.residuals.back(), 1e-12) << "t = " << e.time;
      }
      const auto& x = solver.particles().position;
      const auto top = std::max_element(x.begin(), x.end(),
                                        [](const Vec2& a, const Vec2& b) { return a.y() < b.y(); });
      const auto p = static_cast<std::size_t>(top - x.begin());
      settlement.push_back(solver.particles().reference_position[p].y() - x[p].y());
    }
    // The change scales with gamma: bars a hundred times apart.
    const double at_default = std::abs(settlement[1] / settlement[0] - 1.0);
    EXPECT_GT(at_default, 1e-9);
    EXPECT_LT(at_default, 1e-5);
    const double strong = std::abs(settlement[2] / settlement[0] - 1.0);
    EXPECT_GT(strong, 1e-7);
    EXPECT_LT(strong, 1e-3);
  }
}

TEST(ImplicitSolver, NewtonConvergesQuadraticallyOnAPlasticFooting) {
  const Case c = parse_case(footing_case(0.9 * kPrandtl, 10, 8), "footing.json");
  ImplicitSolver solver(c);
  solver.run_to(1.0);
  int iterations = 0, steps = 0, quadratic = 0;
  for (const LoadStepLog& e : solver.log()) {
    ASSERT_TRUE(e.converged) << "t = " << e.time;
    iterations += static_cast<int>(e.residuals.size()) - 1;
    ++steps;
    // Inside Newton's basin (a residual of 1e-3 and less) every correction cuts the relative
    // residual by two orders at least, unless it ends at round-off.
    for (std::size_t k = 1; k < e.residuals.size(); ++k) {
      const double before = e.residuals[k - 1], after = e.residuals[k];
      if (before > 1e-3 || before < 1e-11 || after < 1e-12) continue;
      EXPECT_LE(after, 1e-2 * before) << "t = " << e.time << ", correction " << k;
      ++quadratic;
    }
  }
  EXPECT_EQ(steps, 10);
  EXPECT_LE(iterations, 6 * steps);
  EXPECT_GE(quadratic, 4);  // the plastic steps reach the basin
  // Plastic points under the footing.
  int plastic = 0;
  for (const PointState& s : solver.particles().state) plastic += s.plastic_strain > 0.0;
  EXPECT_GT(plastic, 20);
}

TEST(ImplicitSolver, AStepBeyondCollapseIsCutBackThenStops) {
  // 1.5 x Prandtl's pressure at once has no equilibrium: every attempt fails, the step is
  // halved twice, then the solver stops naming the step, its load factor and the residuals.
  const Case c = parse_case(footing_case(1.5 * kPrandtl, 1, 2, false), "footing.json");
  ImplicitSolver solver(c);
  try {
    solver.run_to(1.0);
    FAIL() << "no stop";
  } catch (const ImplicitDivergence& e) {
    const std::string what = e.what();
    EXPECT_NE(what.find("did not converge"), std::string::npos) << what;
    EXPECT_NE(what.find("relative residuals"), std::string::npos) << what;
    // The step, the load factor it asked for at its end (the first step halved twice; the
    // pressure at once).
    EXPECT_NE(what.find("load step 1 from t = 0 s to 0.25 s"), std::string::npos) << what;
    EXPECT_NE(what.find("load 0 factor 1"), std::string::npos) << what;
  }
  ASSERT_EQ(solver.log().size(), 3u);
  for (const LoadStepLog& e : solver.log()) EXPECT_FALSE(e.converged);
  EXPECT_DOUBLE_EQ(solver.log()[2].dt, 0.25);
  EXPECT_EQ(solver.time(), 0.0);
}

// A weightless Tresca block (c = 20 kPa), 1 m high and (by symmetry about x = 0) 2 m wide, on a
// smooth base, free on its right, under `pressure` on its detected top ramped over the first
// second; then its strength reduced from t = 1 s (implicit.strength_reduction) to
// `final_factor` at t = 2 s. The stress is uniform, sigma_yy = -q, sigma_xx = 0: the block
// yields throughout, and collapses, when q / 2 = c / F, so its factor of safety is 2 c / q.
nlohmann::json reduced_block_case(const std::string& shape, double pressure, double final_factor) {
  return {{"title", "strength reduction of a pressed block"},
          {"grid", {{"origin", {0.0, 0.0}}, {"cell_size", 0.125}, {"n_cells", {16, 12}}}},
          {"materials",
           {{{"name", "clay"},
             {"model", "tresca"},
             {"youngs_modulus", 10000.0},
             {"poisson_ratio", 0.3},
             {"unit_weight", 18.0},
             {"cohesion", 20.0}}}},
          {"bodies",
           {{{"name", "block"},
             {"material", "clay"},
             {"rectangle", {{0.0, 0.0}, {1.0, 1.0}}},
             {"points_per_cell", 2}}}},
          {"gravity", {{"g", 0.0}}},
          {"boundary_conditions",
           {{{"where", "bottom"}, {"fix", "y"}}, {{"where", "left"}, {"fix", "x"}}}},
          {"loads", pressure_on_top(pressure)},
          {"solver", {{"type", "implicit"}, {"shape_function", shape}}},
          {"implicit",
           {{"load_steps", 40},
            {"max_cuts", 6},
            {"strength_reduction", {{"start_time", 1.0}, {"final_factor", final_factor}}}}},
          {"time", {{"end_time", 2.0}}}};
}

TEST(ImplicitSolver, StrengthReductionFindsTheFactorOfSafetyOfAPressedBlock) {
  // q = 30 kPa: F = 2 c / q = 4/3, with q the pressure the block carries: its mean sigma_yy
  // under the full load (the load on the detected top leaves out a little at the top's rounded
  // corner). The reduction runs in steps of 0.03 (40 steps over 2 s, the last 20 from 1 to
  // 1.6), halved up to 6 times: the bracket [last converged, failed] is at most 0.03 / 64 wide,
  // and it must hold 2 c / q within 1 % (the load is not quite uniform next to the rounded
  // corner, where the points yield a little early). B-bar is on by default in a strength
  // reduction (isochoric plastic flow); without it the block on uGIMP locks (below).
  for (const char* shape : {"quadratic_bspline", "gimp", "linear"}) {
    SCOPED_TRACE(shape);
    const Case c = parse_case(reduced_block_case(shape, 30.0, 1.6), "block.json");
    ImplicitSolver solver(c);
    solver.run_to(1.0);
    const double q = carried_pressure(solver.particles());
    const double safety = 2.0 * 20.0 / q;
    solver.run_to(2.0);
    ASSERT_TRUE(solver.collapsed());
    std::printf("%s: factor of safety in [%.5f, %.5f], closed form %.5f (q = %.4f kPa)\n", shape,
                solver.strength_factor(), solver.failed_factor(), safety, q);
    EXPECT_GT(solver.failed_factor(), solver.strength_factor());
    EXPECT_LE(solver.failed_factor() - solver.strength_factor(), 0.03 / 64.0 + 1e-12);
    EXPECT_LE(solver.strength_factor(), safety * 1.01);
    EXPECT_GE(solver.failed_factor(), safety * 0.99);
    EXPECT_GT(solver.time(), 1.0);
    EXPECT_LT(solver.time(), 2.0);
  }
  // Below its factor of safety the block stands to the end.
  const Case c = parse_case(reduced_block_case("quadratic_bspline", 30.0, 1.25), "block.json");
  ImplicitSolver solver(c);
  solver.run_to(2.0);
  EXPECT_FALSE(solver.collapsed());
  EXPECT_DOUBLE_EQ(solver.strength_factor(), 1.25);
  EXPECT_DOUBLE_EQ(solver.time(), 2.0);
  // Without the mean dilatation (nu = 0.3) the uGIMP block locks: it stands 10 % past 4/3.
  nlohmann::json locking = reduced_block_case("gimp", 30.0, 1.6);
  locking["solver"]["anti_locking"] = "none";
  const Case locking_case = parse_case(locking, "block.json");
  ImplicitSolver locked(locking_case);
  locked.run_to(2.0);
  EXPECT_GT(locked.strength_factor(), 1.1 * 4.0 / 3.0);
}

TEST(ImplicitSolver, StrengthReductionDividesTanPhiOfAMohrCoulombBlock) {
  // The pressed block in Mohr-Coulomb soil (c = 15 kPa, phi = 20 degrees, no dilation), default
  // shape functions: sigma_xx = 0 and sigma_yy = -q, so it collapses where
  // q (1 - sin phi') = 2 c' cos phi' with c' = c / F and tan phi' = tan phi / F (about 1.3145
  // at q = 30 kPa), q again the mean pressure the block carries. Bracket and tolerance as for
  // the Tresca block.
  nlohmann::json document = reduced_block_case("quadratic_bspline", 30.0, 1.6);
  document["materials"][0] = {{"name", "clay"},         {"model", "mohr_coulomb"},
                              {"youngs_modulus", 1e4},  {"poisson_ratio", 0.3},
                              {"unit_weight", 18.0},    {"cohesion", 15.0},
                              {"friction_angle", 20.0}, {"dilation_angle", 0.0}};
  const Case c = parse_case(document, "block.json");
  ImplicitSolver solver(c);
  solver.run_to(1.0);
  const double q = carried_pressure(solver.particles()),
               tan_phi = std::tan(20.0 * std::numbers::pi / 180.0);
  const auto excess = [&](double factor) {  // > 0 while the block holds q
    const double phi = std::atan(tan_phi / factor);
    return 2.0 * 15.0 / factor * std::cos(phi) / (1.0 - std::sin(phi)) - q;
  };
  double low = 1.0, high = 1.6;  // bisection: excess(low) > 0 > excess(high)
  ASSERT_GT(excess(low), 0.0);
  ASSERT_LT(excess(high), 0.0);
  for (int k = 0; k < 60; ++k) (excess(0.5 * (low + high)) > 0.0 ? low : high) = 0.5 * (low + high);
  const double safety = 0.5 * (low + high);
  solver.run_to(2.0);
  ASSERT_TRUE(solver.collapsed());
  std::printf("Mohr-Coulomb: factor of safety in [%.5f, %.5f], closed form %.5f (q = %.4f kPa)\n",
              solver.strength_factor(), solver.failed_factor(), safety, q);
  EXPECT_LE(solver.failed_factor() - solver.strength_factor(), 0.03 / 64.0 + 1e-12);
  EXPECT_LE(solver.strength_factor(), safety * 1.01);
  EXPECT_GE(solver.failed_factor(), safety * 0.99);
}

TEST(ImplicitSolver, RefusesWhatItCannotHonour) {
  const auto refused = [](nlohmann::json document, const std::string& path) {
    try {
      const Case c = parse_case(document, "case.json");
      ImplicitSolver solver(c);
      ADD_FAILURE() << "accepted; expected a refusal at " << path;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("case.json: " + path), std::string::npos) << e.what();
    }
  };
  nlohmann::json base = column_case("quadratic_bspline", 5e5);
  nlohmann::json damped = base;
  damped["solver"]["damping"] = 0.1;
  refused(damped, "/solver/damping");
  nlohmann::json cfl = base;
  cfl["time"]["cfl"] = 0.5;
  refused(cfl, "/time/cfl");
  // The strength reduction: a factor above 1, from a time before the end.
  nlohmann::json weak = base;
  weak["implicit"]["strength_reduction"] = {{"start_time", 0.5}, {"final_factor", 1.0}};
  refused(weak, "/implicit/strength_reduction/final_factor");
  nlohmann::json late = base;
  late["implicit"]["strength_reduction"] = {{"start_time", 1.0}, {"final_factor", 2.0}};
  refused(late, "/implicit/strength_reduction/start_time");
  // The ghost penalty is the implicit tangent's, next to the ties.
  nlohmann::json ghost_explicit = base;
  ghost_explicit.erase("implicit");
  ghost_explicit["solver"]["type"] = "explicit";
  ghost_explicit["solver"]["ghost_penalty"] = 1e-3;
  refused(ghost_explicit, "/solver/ghost_penalty");
  nlohmann::json ghost_untied = base;
  ghost_untied["solver"]["outer_node_fraction"] = 0.0;
  ghost_untied["solver"]["ghost_penalty"] = 1e-3;
  refused(ghost_untied, "/solver/ghost_penalty");
  // The implicit block belongs to the implicit solver.
  nlohmann::json explicit_case = base;
  explicit_case["solver"]["type"] = "explicit";
  try {
    (void)parse_case(explicit_case, "case.json");
    ADD_FAILURE() << "an implicit block in an explicit case was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/implicit"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace pfm

// UL-FEM physics: oedometric column, first step identical to the MPM's, element inversion,
// elastic bearing block.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "fem_reference/ulfem/ulfem_solver.hpp"
#include "mpm/core/json_input.hpp"
#include "mpm/solver/mpm_solver.hpp"
#include "ulfem_test_util.hpp"

namespace pfm::ulfem {
namespace {

constexpr double kE = 1e4, kNu = 0.15, kGamma = 20.0;
double constrained_modulus() {
  return kE * (1 - kNu) / ((1 + kNu) * (1 - 2 * kNu));
}

// Test 1. Oedometric column under self-weight, H = 5 m, h = 0.5 m (2 x 10 elements), gravity at
// once, local damping 0.7, damped to rest. Small-strain settlement gamma H^2 / (2 M); the UL
// (hypoelastic, Jaumann) solution is the large-strain one H - (M / gamma)(1 - exp(-gamma H / M))
// (log strain = sigma / M, mass conserved), 0.31 % below it.
TEST(UlFemPhysics, OedometricColumnSettlesToTheAnalyticValue) {
  const double height = 5.0;
  nlohmann::json j = testing::block_case(1.0, height, 0.5, 0, 2);
  const Case c = parse_case(j, "column");
  UlFemSolver solver(c);
  ASSERT_EQ(solver.mesh().n_elements(), 20u);
  const double used = testing::run_to_rest(solver, 1e-12, 20.0);
  ASSERT_GT(used, 0.0) << "not at rest within 20 s";
  const double m = constrained_modulus();
  const double small_strain = kGamma * height * height / (2.0 * m);
  const double large_strain = height - (m / kGamma) * (1.0 - std::exp(-kGamma * height / m));
  double worst_small = 0.0, worst_large = 0.0, settlement = 0.0;
  const auto u = solver.node_displacement();
  for (std::size_t n = 0; n < u.size(); ++n) {
    if (solver.mesh().node_position[n].y() < height - 1e-9) continue;
    settlement = -u[n].y();
    worst_small = std::max(worst_small, std::abs(settlement / small_strain - 1.0));
    worst_large = std::max(worst_large, std::abs(settlement / large_strain - 1.0));
  }
  // Stress at rest: sigma_yy = -(weight above per unit width) / 1 m, sxx = szz = K0 syy.
  double worst_k0 = 0.0;
  const Particles& p = solver.particles();
  const double k0 = kNu / (1 - kNu);
  for (std::size_t i = 0; i < p.size(); ++i) {
    worst_k0 =
        std::max(worst_k0, std::abs(p.stress[i][kXX] - k0 * p.stress[i][kYY]) / (kGamma * height));
  }
  std::printf(
      "[ulfem oedometer] settled after %.3f s (%ld steps, dt %.3e s): settlement "
      "%.7e m; small strain %.7e m (%+.4f %%), large strain %.7e m (%+.4f %%); "
      "max |sxx - K0 syy| / (gamma H) = %.2e\n",
      used, solver.step_count(), solver.dt(), settlement, small_strain,
      100 * (settlement / small_strain - 1), large_strain, 100 * (settlement / large_strain - 1),
      worst_k0);
  EXPECT_LE(worst_small, 5e-3);  // brief: within 0.5 % of gamma H^2 / (2 M)
  EXPECT_LE(worst_large, 5e-4);  // the UL solution: within 0.05 % of the large-strain one
  EXPECT_LE(worst_k0, 1e-3);
}

// Test 2. One step of the UL-FEM on a grid-aligned block equals one MpmSolver step with the
// points at the Gauss points: the same nodal forces, particle velocities, positions and stresses
// to round-off. K0 stress makes the internal forces non-zero; a load over [1.2, 2.7] m (ends
// inside elements) checks the consistent edge forces; MUSL and USL. With the mean dilatation
// (anti_locking "bbar") a cell's points are its element's: the averages agree too (the K0 stress
// varies with depth, so the averaged internal force differs from the plain one).
TEST(UlFemPhysics, FirstStepEqualsMpmStep) {
  for (const std::string anti_locking : {"none", "bbar"}) {
    for (const std::string scheme : {"musl", "usl"}) {
      SCOPED_TRACE(anti_locking);
      nlohmann::json j = testing::block_case(4.0, 3.0, 0.5, 2, 3);
      j["solver"]["anti_locking"] = anti_locking;
      j["initial_stress"] = {{"method", "k0"}};
      j["loads"] = nlohmann::json::parse(
          R"([{"type": "vertical_pressure", "pressure": 40.0, "x_range": [1.2, 2.7]}])");
      j["solver"]["scheme"] = scheme;
      j["time"]["dt"] = 2e-3;
      const Case c = parse_case(j, "block");
      UlFemSolver fem(c);
      MpmSolver mpm(c);
      ASSERT_EQ(fem.particles().size(), mpm.particles().size());
      fem.initialise_stress();
      mpm.initialise_stress();
      fem.step();
      mpm.step();

      auto relative = [](double diff, double scale) { return scale > 0 ? diff / scale : diff; };
      // Nodal forces, node by node through the grid node at the same position.
      const Grid& grid = c.grid;
      double fint_scale = 0, fext_scale = 0, fint_diff = 0, fext_diff = 0, v_scale = 0, v_diff = 0;
      for (std::size_t n = 0; n < fem.mesh().n_nodes(); ++n) {
        const Vec2 x = fem.mesh().node_position[n];
        const int i = static_cast<int>(std::lround((x.x() - grid.origin.x()) / grid.cell_size));
        const int jj = static_cast<int>(std::lround((x.y() - grid.origin.y()) / grid.cell_size));
        const auto g = static_cast<std::size_t>(grid.node_index(i, jj));
        fint_scale = std::max(fint_scale, mpm.grid_state().internal_force[g].norm());
        fext_scale = std::max(fext_scale, mpm.grid_state().external_force[g].norm());
        v_scale = std::max(v_scale, mpm.grid_state().velocity[g].norm());
        fint_diff = std::max(
            fint_diff,
            (fem.node_state().internal_force[n] - mpm.grid_state().internal_force[g]).norm());
        fext_diff = std::max(
            fext_diff,
            (fem.node_state().external_force[n] - mpm.grid_state().external_force[g]).norm());
        v_diff =
            std::max(v_diff, (fem.node_state().velocity[n] - mpm.grid_state().velocity[g]).norm());
      }
      double pv_scale = 0, pv_diff = 0, s_scale = 0, s_diff = 0, x_diff = 0;
      const Particles& a = fem.particles();
      const Particles& b = mpm.particles();
      for (std::size_t p = 0; p < a.size(); ++p) {
        pv_scale = std::max(pv_scale, b.velocity[p].norm());
        pv_diff = std::max(pv_diff, (a.velocity[p] - b.velocity[p]).norm());
        s_scale = std::max(s_scale, b.stress[p].norm());
        s_diff = std::max(s_diff, (a.stress[p] - b.stress[p]).norm());
        x_diff = std::max(x_diff, (a.position[p] - b.position[p]).norm());
      }
      std::printf(
          "[ulfem vs mpm, %s] relative max differences after one step: f_int %.2e, "
          "f_ext %.2e, nodal v %.2e, particle v %.2e, stress %.2e; position %.2e m\n",
          scheme.c_str(), relative(fint_diff, fint_scale), relative(fext_diff, fext_scale),
          relative(v_diff, v_scale), relative(pv_diff, pv_scale), relative(s_diff, s_scale),
          x_diff);
      EXPECT_GT(fint_scale, 1.0);
      EXPECT_LE(fint_diff, 1e-12 * fint_scale) << scheme;
      EXPECT_LE(fext_diff, 1e-12 * fext_scale) << scheme;
      EXPECT_LE(v_diff, 1e-12 * v_scale) << scheme;
      EXPECT_LE(pv_diff, 1e-12 * pv_scale) << scheme;
      EXPECT_LE(s_diff, 1e-12 * s_scale) << scheme;
      EXPECT_LE(x_diff, 1e-12 * 4.0) << scheme;  // relative to the block size
    }
  }
}

// Test 3a. A mesh motion that folds an element is stopped with a message naming the element,
// its position and the time.
TEST(UlFemPhysics, InvertedElementIsReported) {
  nlohmann::json j = testing::block_case(1.0, 1.0, 0.5, 0, 0);
  const Case c = parse_case(j, "block");
  UlFemSolver solver(c);
  solver.step();
  std::vector<Vec2> u(solver.mesh().n_nodes(), Vec2::Zero());
  // Node 8 is the top-right corner (1, 1) of element 3: pull it past the element's centre.
  ASSERT_TRUE(solver.mesh().node_position[8].isApprox(Vec2(1.0, 1.0)));
  u[8] = Vec2(-0.9, -0.9);
  try {
    solver.displace_nodes(u);
    FAIL() << "no error for an inverted element";
  } catch (const SimulationError& e) {
    const std::string what = e.what();
    std::printf("[ulfem inversion] %s\n", what.c_str());
    EXPECT_NE(what.find("element inverted: element 3 "), std::string::npos) << what;
    EXPECT_NE(what.find("centred at ("), std::string::npos) << what;
    EXPECT_NE(what.find("t = 0.00"), std::string::npos) << what;
    EXPECT_NE(what.find("(step 1)"), std::string::npos) << what;
  }
}

// Test 3b. The same check during a run: a block far too soft for its weight (E = 50 kPa,
// undamped) collapses; the run stops with SimulationError when an element folds or the time
// step of the crushed elements is exceeded, never with NaN.
TEST(UlFemPhysics, CollapsingBlockStopsWithSimulationError) {
  nlohmann::json j = testing::block_case(1.0, 1.0, 0.5, 0, 0);
  j["materials"][0]["youngs_modulus"] = 10.0;
  j["solver"]["damping"] = 0.0;
  const Case c = parse_case(j, "soft");
  UlFemSolver solver(c);
  std::string message;
  try {
    for (int k = 0; k < 2000; ++k) solver.step();
  } catch (const SimulationError& e) {
    message = e.what();
  }
  std::printf("[ulfem collapse] %s\n", message.c_str());
  EXPECT_NE(message.find("element inverted: element "), std::string::npos) << message;
  EXPECT_GT(solver.step_count(), 10);  // a collapse during the run, not a bad first step
}

// Test 5. Elastic bearing block 15 x 5 m, h = 0.5 m, gravity loading procedure (to a kinetic
// energy ratio of 1e-14, so that no gravity settlement is left for the load phase), then
// q_v = 50 kPa on [5, 10] m, damped to rest (kinetic energy 1e-16 of its peak). Vertical
// equilibrium of the base reactions (1e-6) and the settlement of the strip centre within 2 % of
// the dolfinx value.
TEST(UlFemPhysics, ElasticBearingBlockSettlement) {
  nlohmann::json j = testing::block_case(15.0, 5.0, 0.5, 0, 2);
  j["initial_stress"] = {{"method", "gravity"}, {"kinetic_energy_ratio", 1e-14}};
  j["loads"] = nlohmann::json::parse(
      R"([{"type": "vertical_pressure", "pressure": 50.0, "x_range": [5.0, 10.0]}])");
  const Case c = parse_case(j, "bearing");
  UlFemSolver solver(c);
  solver.initialise_stress();
  const double used = testing::run_to_rest(solver, 1e-16, 20.0);
  ASSERT_GT(used, 0.0) << "not at rest within 20 s";
  std::size_t centre = solver.mesh().n_nodes();
  for (std::size_t n = 0; n < solver.mesh().n_nodes(); ++n) {
    if ((solver.mesh().node_position[n] - Vec2(7.5, 5.0)).norm() < 1e-9) centre = n;
  }
  ASSERT_LT(centre, solver.mesh().n_nodes());
  const double settlement = -solver.node_displacement()[centre].y();
  // Base reaction = - (internal + external) force on the fixed base nodes; at rest it carries
  // the weight and the load.
  double reaction = 0.0, weight = 0.0;
  for (std::size_t n = 0; n < solver.mesh().n_nodes(); ++n) {
    const Vec2 f = solver.node_state().internal_force[n] + solver.node_state().external_force[n];
    if (solver.mesh().node_position[n].y() < 1e-9) reaction -= f.y();
  }
  for (double m : solver.particles().mass) weight += m * c.gravity.g;
  const double expected = weight + 50.0 * 5.0;
  std::printf(
      "[ulfem bearing block] gravity phase %ld steps; rest after %.3f s (%ld steps): "
      "strip-centre settlement %.7e m; base reaction %.6f kN vs weight + qB %.6f kN "
      "(%.2e)\n",
      solver.initial_stress_steps(), used, solver.step_count(), settlement, reaction, expected,
      reaction / expected - 1);
  EXPECT_LE(std::abs(reaction / expected - 1.0), 1e-6);
  // Issue 5 item 2: within 2 % of the dolfinx settlement of the same case, 2.0634e-2 m (P2,
  // mesh-converged; fem_reference/tests/test_dolfinx_model.py::
  // test_bearing_block_elastic_settlement asserts that its runs give this value within 0.1 %, and
  // fem_reference/tests/test_cross_codes.py compares the two codes' actual runs). Q1 2 x 2 on
  // h = 0.5 m is stiffer by its discretisation error; the UL geometry changes it by ~0.1 %.
  constexpr double kDolfinxSettlement = 2.0634e-2;  // m
  EXPECT_NEAR(settlement, kDolfinxSettlement, 0.02 * kDolfinxSettlement);
}

}  // namespace
}  // namespace pfm::ulfem

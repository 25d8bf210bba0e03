// The implicit UL-FEM (fem_reference/ulfem/ulfem_implicit.hpp): the implicit solver's load steps
// on the UL-FEM's mesh. The oedometric column against the large-strain closed form, the
// surcharged column against the small-strain one at its nodes, the first load step against the
// implicit MPM's on the same points, the strength reduction's factor of safety of a pressed
// block, the run's files, and what it refuses.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>

#include "fem_reference/ulfem/ulfem_implicit.hpp"
#include "fem_reference/ulfem/ulfem_run.hpp"
#include "mpm/core/json_input.hpp"
#include "tests/cpp/implicit/implicit_checks.hpp"
#include "ulfem_test_util.hpp"

namespace pfm::ulfem {
namespace {

// The block of testing::block_case (E = 1e4 kPa, nu = 0.15, gamma = 20) as an implicit case:
// gravity ramped over the run, `steps` load steps.
nlohmann::json implicit_block(double width, double height, double h, int steps) {
  nlohmann::json j = testing::block_case(width, height, h, 0, 2);
  j["solver"] = {{"type", "implicit"}};
  j["implicit"] = {{"load_steps", steps}};
  j["gravity"]["ramp_time"] = 1.0;
  j["time"] = {{"end_time", 1.0}};
  return j;
}

// Element e's volume-weighted mean sigma_yy (kPa) and its centre's height on the initial
// mesh (m).
std::pair<double, double> element_mean_syy(const ImplicitQuadMesh& mesh, const Particles& p,
                                           std::size_t e) {
  double syy = 0.0, volume = 0.0, y = 0.0;
  for (std::size_t k = 0; k < 4; ++k) {
    syy += p.volume[4 * e + k] * p.stress[4 * e + k][kYY];
    volume += p.volume[4 * e + k];
    const auto node = static_cast<std::size_t>(mesh.mesh().element_nodes[e][k]);
    y += 0.25 * mesh.mesh().node_position[node].y();
  }
  return {syy / volume, y};
}

// A solver on the case's mesh (the case must outlive it).
ImplicitSolver solver_on_mesh(const Case& c) {
  return ImplicitSolver(c, std::make_unique<ImplicitQuadMesh>(c, mesh_case(c)));
}

const ImplicitQuadMesh& mesh_of(const ImplicitSolver& solver) {
  return static_cast<const ImplicitQuadMesh&>(*solver.mesh());
}

TEST(ImplicitUlFem, OedometricColumnReachesTheLargeStrainSolution) {
  // H = 5 m under its weight (strain about 1 %): the updated-Lagrangian answer is the
  // large-strain one, H - (M / gamma)(1 - exp(-gamma H / M)) (log strain = sigma / M, mass
  // conserved), 0.31 % below the small-strain gamma H^2 / (2 M). A load step's strain increment
  // sym(G) misses the log strain's by G^2 / 2: over 20 steps of 5e-4 that is 2.5e-4 of it.
  const double height = 5.0;
  const Case c = parse_case(implicit_block(1.0, height, 0.5, 20), "column.json");
  ImplicitSolver solver = solver_on_mesh(c);
  solver.run_to(1.0);
  const double m = 1e4 * 0.85 / (1.15 * 0.7);
  const double small_strain = 20.0 * height * height / (2.0 * m);
  const double large_strain = height - (m / 20.0) * (1.0 - std::exp(-20.0 * height / m));
  const ImplicitQuadMesh& mesh = mesh_of(solver);
  const std::vector<Vec2> u = mesh.node_displacement();
  int top = 0;
  for (std::size_t n = 0; n < u.size(); ++n) {
    if (mesh.mesh().node_position[n].y() < height - 1e-9) continue;
    ++top;
    EXPECT_NEAR(-u[n].y() / large_strain, 1.0, 5e-4);
    EXPECT_GT(1.0 + u[n].y() / small_strain, 2e-3);  // not the small-strain answer
    EXPECT_NEAR(u[n].x(), 0.0, 1e-12);
  }
  EXPECT_EQ(top, 3);
  // Elastic: each step's first correction leaves the relative residual at the geometry's
  // change, and the iteration ends within 3.
  for (const LoadStepLog& e : solver.log()) {
    EXPECT_TRUE(e.converged);
    EXPECT_LE(e.residuals.size(), 4u);
  }
}

TEST(ImplicitUlFem, SurchargedColumnMatchesTheClosedFormAtItsNodes) {
  // E = 5e5 kPa (strains of 1e-4: the small-strain answer to about 1e-4), 30 kPa on the exact
  // top edges and the weight, both ramped: u(y) = -[q y + gamma (H y - y^2 / 2)] / M. Bilinear
  // elements with consistent loads are exact at the nodes of this one-dimensional problem, and
  // an element's mean stress is the exact stress at its centre.
  const double height = 4.0, q = 30.0;
  nlohmann::json j = implicit_block(1.0, height, 0.25, 5);
  j["materials"][0]["youngs_modulus"] = 5e5;
  j["materials"][0]["poisson_ratio"] = 0.25;
  j["loads"] = pressure_on_top(q);
  const Case c = parse_case(j, "column.json");
  ImplicitSolver solver = solver_on_mesh(c);
  solver.run_to(1.0);
  const double m = 5e5 * 0.75 / (1.25 * 0.5);
  const ImplicitQuadMesh& mesh = mesh_of(solver);
  const std::vector<Vec2> u = mesh.node_displacement();
  for (std::size_t n = 0; n < u.size(); ++n) {
    const double y = mesh.mesh().node_position[n].y();
    if (y == 0.0) continue;
    const double exact = (q * y + 20.0 * (height * y - 0.5 * y * y)) / m;
    EXPECT_NEAR(-u[n].y() / exact, 1.0, 1e-3) << "node " << n << " at y = " << y;
  }
  for (std::size_t e = 0; e < mesh.n_elements(); ++e) {
    const auto [syy, y] = element_mean_syy(mesh, solver.particles(), e);
    EXPECT_NEAR(syy / (-q - 20.0 * (height - y)), 1.0, 1e-3) << "element " << e;
  }
}

TEST(ImplicitUlFem, GravityLoadingSettlesThenTheMeshIsTheReference) {
  // initial_stress "gravity" on the stiff column: settled under its weight before t = 0, every
  // element's mean syy the weight above its centre (1e-3), the nodes' displacements measured
  // from the settled mesh; then the surcharge alone moves the top nodes by q H / M.
  const double height = 4.0, q = 30.0;
  nlohmann::json j = implicit_block(1.0, height, 0.25, 5);
  j["materials"][0]["youngs_modulus"] = 5e5;
  j["materials"][0]["poisson_ratio"] = 0.25;
  j["initial_stress"] = {{"method", "gravity"}};
  j["loads"] = pressure_on_top(q);
  const Case c = parse_case(j, "column.json");
  ImplicitSolver solver = solver_on_mesh(c);
  solver.initialise_stress();
  const ImplicitQuadMesh& mesh = mesh_of(solver);
  for (const Vec2& u : mesh.node_displacement()) EXPECT_EQ(u, Vec2::Zero());
  for (std::size_t e = 0; e < mesh.n_elements(); ++e) {
    const auto [syy, y] = element_mean_syy(mesh, solver.particles(), e);
    EXPECT_NEAR(syy / (-20.0 * (height - y)), 1.0, 1e-3) << "element " << e;
  }
  solver.run_to(1.0);
  const double m = 5e5 * 0.75 / (1.25 * 0.5);
  const std::vector<Vec2> u = mesh.node_displacement();
  for (std::size_t n = 0; n < u.size(); ++n) {
    if (mesh.mesh().node_position[n].y() < height - 1e-9) continue;
    EXPECT_NEAR(-u[n].y() / (q * height / m), 1.0, 1e-3) << "node " << n;
  }
}

TEST(ImplicitUlFem, FirstStepEqualsTheImplicitMpmsOnTheSamePoints) {
  // A Tresca block (c = 14 kPa) free on its right side, under its weight at once, in one load
  // step: it yields, so Newton takes several iterations. Linear shape functions on a grid whose
  // cells are the mesh's elements, with the points at the cells' Gauss points, are the Q4
  // elements: the same tangent, the same iterations, the same answer to round-off, with B-bar
  // (its mean over a cell or an element alike) and without. The volumes differ with B-bar only:
  // the MPM's is det F V_0 with F from the B-bar gradient, the mesh's det J of the moved
  // element; without it both are det(I + G) det J_n.
  for (const char* anti_locking : {"none", "bbar"}) {
    SCOPED_TRACE(anti_locking);
    nlohmann::json j = implicit_block(2.0, 2.0, 0.5, 1);
    j["materials"][0]["model"] = "tresca";
    j["materials"][0]["cohesion"] = 14.0;
    j["grid"]["n_cells"] = {6, 6};
    j["boundary_conditions"] = {{{"where", "bottom"}, {"fix", "xy"}},
                                {{"where", "left"}, {"fix", "x"}}};
    j["gravity"].erase("ramp_time");
    j["solver"]["shape_function"] = "linear";
    j["solver"]["anti_locking"] = anti_locking;
    const Case c = parse_case(j, "block.json");
    ImplicitSolver fem = solver_on_mesh(c);
    ImplicitSolver mpm(c);
    fem.run_to(1.0);
    mpm.run_to(1.0);
    ASSERT_EQ(fem.log().size(), 1u);
    ASSERT_EQ(mpm.log().size(), 1u);
    EXPECT_GE(fem.log()[0].residuals.size(), 4u);  // plastic: several corrections
    ASSERT_EQ(fem.log()[0].residuals.size(), mpm.log()[0].residuals.size());
    const Particles& a = fem.particles();
    const Particles& b = mpm.particles();
    ASSERT_EQ(a.size(), b.size());
    double largest = 0.0, stress_scale = 0.0;
    int plastic = 0;
    for (std::size_t k = 0; k < a.size(); ++k) {
      largest = std::max(largest, (b.position[k] - b.reference_position[k]).norm());
      stress_scale = std::max(stress_scale, b.stress[k].cwiseAbs().maxCoeff());
      plastic += b.state[k].plastic_strain > 0.0;
    }
    EXPECT_GT(plastic, 4);
    const bool bbar = std::string(anti_locking) == "bbar";
    for (std::size_t k = 0; k < a.size(); ++k) {
      EXPECT_LE((a.position[k] - b.position[k]).norm(), 1e-10 * largest) << "point " << k;
      EXPECT_LE((a.stress[k] - b.stress[k]).cwiseAbs().maxCoeff(), 1e-10 * stress_scale)
          << "point " << k;
      if (!bbar) {
        EXPECT_NEAR(a.volume[k], b.volume[k], 1e-12 * b.volume[k]) << "point " << k;
      }
    }
  }
}

TEST(ImplicitUlFem, StrengthReductionFindsTheFactorOfSafetyOfAPressedBlock) {
  // The implicit MPM's pressed block (test_implicit_solver): a weightless Tresca block, c =
  // 20 kPa, 1 m high and by symmetry 2 m wide, smooth base, free right side, q = 30 kPa ramped
  // on its top, then its strength reduced up to 1.6: F = 2 c / q, with q the mean sigma_yy the
  // block carries under the full load (30 kPa on its top, which has widened a little). The
  // mesh's top is exact and the stress uniform: the bracket [last converged, failed], steps of
  // 0.03 in F halved up to 6 times (so at most twice 0.03 / 64 wide), must hold 2 c / q within
  // 0.2 %.
  nlohmann::json j = implicit_block(1.0, 1.0, 0.125, 40);
  j["materials"][0] = {{"name", "soil"},       {"model", "tresca"},   {"youngs_modulus", 1e4},
                       {"poisson_ratio", 0.3}, {"unit_weight", 18.0}, {"cohesion", 20.0}};
  j["gravity"] = {{"g", 0.0}};
  j["boundary_conditions"] = {{{"where", "bottom"}, {"fix", "y"}},
                              {{"where", "left"}, {"fix", "x"}}};
  j["grid"]["n_cells"] = {16, 12};
  j["loads"] = pressure_on_top(30.0);
  j["implicit"] = {{"load_steps", 40},
                   {"max_cuts", 6},
                   {"strength_reduction", {{"start_time", 1.0}, {"final_factor", 1.6}}}};
  j["time"] = {{"end_time", 2.0}};
  const Case c = parse_case(j, "block.json");
  ImplicitSolver solver = solver_on_mesh(c);
  solver.run_to(1.0);
  const double safety = 2.0 * 20.0 / carried_pressure(solver.particles());
  solver.run_to(2.0);
  ASSERT_TRUE(solver.collapsed());
  EXPECT_LE(solver.failed_factor() - solver.strength_factor(), 2.0 * 0.03 / 64.0 + 1e-12);
  EXPECT_LE(solver.strength_factor(), safety * 1.002);
  EXPECT_GE(solver.failed_factor(), safety * 0.998);
}

TEST(ImplicitUlFem, RunWritesThePointsTheMeshAndTheLoadSteps) {
  nlohmann::json j = implicit_block(1.0, 2.0, 0.5, 4);
  j["output"] = {{"interval", 1.0}};
  const Case c = parse_case(j, "column.json");
  const std::filesystem::path out =
      std::filesystem::temp_directory_path() / "pfm_ulfem_implicit_run";
  std::filesystem::remove_all(out);
  RunOptions options;
  options.out_dir = out.string();
  options.threads = 1;
  options.progress = false;
  ASSERT_EQ(run_ulfem_case(c, options), kExitOk);
  for (const char* file :
       {"run.json", "timeseries.csv", "particles.h5", "particles.xdmf", "final_particles.csv",
        "mesh.h5", "mesh.xdmf", "boundary_00000000.csv", "boundary_00000004.csv"}) {
    EXPECT_TRUE(std::filesystem::exists(out / file)) << file;
  }
  std::ifstream in(out / "run.json");
  const nlohmann::json run = nlohmann::json::parse(in);
  EXPECT_EQ(run["status"], "completed");
  EXPECT_EQ(run["summary"]["solver"], "ulfem_implicit");
  EXPECT_EQ(run["summary"]["n_steps"], 4);
  EXPECT_EQ(run["summary"]["mesh"]["n_elements"], 8);
  ASSERT_EQ(run["outputs"].size(), 2u);
  EXPECT_EQ(run["outputs"][1]["boundary"], "boundary_00000004.csv");
  EXPECT_EQ(run["load_steps"].size(), 4u);
  std::filesystem::remove_all(out);
}

TEST(ImplicitUlFem, RefusesConstraintsOnADetectedBoundary) {
  nlohmann::json j = implicit_block(1.0, 2.0, 0.5, 4);
  j["constraints"] = {{{"apply_on", "detected_boundary"},
                       {"faces", "top"},
                       {"normal_displacement", -0.01},
                       {"method", "nitsche"}}};
  const Case c = parse_case(j, "column.json");
  try {
    ImplicitSolver solver = solver_on_mesh(c);
    FAIL() << "accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("/constraints"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace pfm::ulfem

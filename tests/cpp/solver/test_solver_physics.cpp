// MPM solver physics: patch test, oedometric column, free vibration energy, determinism.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>

#include "mpm/core/json_input.hpp"
#include "mpm/solver/mpm_solver.hpp"
#include "solver_test_util.hpp"

namespace pfm {
namespace {

// Patch test: a uniform velocity gradient imposed on the grid nodes (v_I = L x_I) must give
// the same strain increment, hence the same stress, at every particle (linear and GIMP, any
// placement): sum_I x_I (x) grad N_I = identity. The mean dilatation (B-bar) of a uniform
// field is the field itself, so it passes the same test.
TEST(SolverPhysics, PatchTestUniformStrainGivesUniformStress) {
  for (const std::string shape : {"linear", "gimp"}) {
    for (const std::string placement : {"equal", "gauss"}) {
      for (const std::string anti_locking : {"none", "bbar"}) {
        nlohmann::json j = testing::column_case(3.0, 0.5, 3, placement);
        j["grid"]["n_cells"] = {8, 10};
        j["bodies"][0]["rectangle"] = {{1.0, 0.5}, {3.0, 3.5}};  // one cell away from every edge
        j["solver"]["shape_function"] = shape;
        j["solver"]["anti_locking"] = anti_locking;
        const Case c = parse_case(j, "patch");
        MpmSolver solver(c);
        Mat2 l;
        l << 1e-3, 4e-4, -2e-4, -5e-4;  // includes spin
        std::vector<Vec2> v(static_cast<std::size_t>(c.grid.n_nodes()));
        for (int jn = 0; jn < c.grid.n_nodes_y(); ++jn) {
          for (int in = 0; in < c.grid.n_nodes_x(); ++in) {
            v[static_cast<std::size_t>(c.grid.node_index(in, jn))] =
                l * c.grid.node_position(in, jn);
          }
        }
        solver.update_stress_from_grid_velocity(v);
        const Particles& p = solver.particles();
        const Stress reference = p.stress.front();
        EXPECT_GT(reference.norm(), 1e-3);
        double worst = 0.0;
        for (const Stress& s : p.stress) worst = std::max(worst, (s - reference).norm());
        EXPECT_LE(worst, 1e-10 * reference.norm())
            << shape << " " << placement << " " << anti_locking;
        // And equals Hooke's law for the imposed strain increment.
        const Strain de(l(0, 0) * solver.dt(), l(1, 1) * solver.dt(),
                        (l(0, 1) + l(1, 0)) * solver.dt(), 0.0);
        const Stress expected =
            elastic_stress_increment(elastic_parameters(c.materials[0].model), de);
        EXPECT_LE((reference - expected).norm(), 1e-10 * expected.norm());
      }
    }
  }
}

// A grid motion that folds the material over (v_x = -2 x / dt: I + L dt = diag(-1, 1), det F =
// -1 at every particle) stops with a SimulationError naming the last inverted particle, its
// det F and the time, instead of handing a body of negative volumes to what follows (a
// collapse's inverted point once reached the detector, which stopped with an input error).
TEST(SolverPhysics, InvertedParticleStopsTheRun) {
  nlohmann::json j = testing::column_case(3.0, 0.5, 3, "equal");
  j["grid"]["n_cells"] = {8, 10};
  j["bodies"][0]["rectangle"] = {{1.0, 0.5}, {3.0, 3.5}};
  const Case c = parse_case(j, "folded");
  MpmSolver solver(c);
  std::vector<Vec2> v(static_cast<std::size_t>(c.grid.n_nodes()));
  for (int jn = 0; jn < c.grid.n_nodes_y(); ++jn) {
    for (int in = 0; in < c.grid.n_nodes_x(); ++in) {
      v[static_cast<std::size_t>(c.grid.node_index(in, jn))] =
          Vec2(-2.0 / solver.dt() * c.grid.node_position(in, jn).x(), 0.0);
    }
  }
  const std::size_t last = solver.particles().size() - 1;
  try {
    solver.update_stress_from_grid_velocity(v);
    FAIL() << "no error for inverted particles";
  } catch (const SimulationError& e) {
    const std::string what = e.what();
    std::printf("[mpm inversion] %s\n", what.c_str());
    EXPECT_EQ(what.find("particle " + std::to_string(last) + " at ("), 0u) << what;
    EXPECT_NE(what.find(" inverted (det F = -1, F = [[-1, 0], [0, 1]]: its material folded over)"),
              std::string::npos)
        << what;
    EXPECT_NE(what.find("at t = 0.0"), std::string::npos) << what;
  }
  EXPECT_NEAR(solver.particles().deformation_gradient[last].determinant(), -1.0, 1e-12);
}

struct ColumnResult {
  double settlement_error = 0.0;  // max relative error of the top row's settlement
  double stress_error = 0.0;      // relative error of the mid-depth cell-mean stress
};

// Column under self-weight damped to rest: u(y0) = gamma / M (H y0 - y0^2 / 2) and
// sigma_yy = -gamma (H - y).
ColumnResult run_column(const std::string& placement, int points_per_cell) {
  const double height = 5.0, cell = 0.5, gamma = 20.0;
  const Case c =
      parse_case(testing::column_case(height, cell, points_per_cell, placement), "column");
  MpmSolver solver(c);
  while (solver.time() < c.time.end_time) solver.step();
  const double m = elastic_parameters(c.materials[0].model).constrained_modulus();
  const Particles& p = solver.particles();
  ColumnResult r;
  double top_y0 = 0.0;
  for (const Vec2& x : p.reference_position) top_y0 = std::max(top_y0, x.y());
  for (std::size_t k = 0; k < p.size(); ++k) {
    const double y0 = p.reference_position[k].y();
    if (y0 < top_y0 - 1e-9) continue;
    const double exact = -gamma / m * (height * y0 - 0.5 * y0 * y0);
    const double u = p.position[k].y() - y0;
    r.settlement_error = std::max(r.settlement_error, std::abs(u - exact) / std::abs(exact));
  }
  // Linear shape functions give one strain per cell row: compare the mean stress of the cell
  // rows on either side of mid-depth with the exact stress at their mean position.
  std::map<int, std::pair<double, double>> rows;  // cell row -> (sum syy, sum exact)
  std::map<int, int> count;
  for (std::size_t k = 0; k < p.size(); ++k) {
    const int row = static_cast<int>(std::floor(p.reference_position[k].y() / cell));
    if (row != 4 && row != 5) continue;  // cells [2, 2.5] and [2.5, 3]
    rows[row].first += p.stress[k][kYY];
    rows[row].second += -gamma * (height - p.position[k].y());
    ++count[row];
  }
  for (const auto& [row, sums] : rows) {
    r.stress_error =
        std::max(r.stress_error, std::abs(sums.first - sums.second) / std::abs(sums.second));
  }
  return r;
}

TEST(SolverPhysics, OedometricColumnEqualSpacing) {
  const ColumnResult r = run_column("equal", 2);
  std::printf("column equal 2x2: settlement error %.3e, mid-depth stress error %.3e\n",
              r.settlement_error, r.stress_error);
  EXPECT_LE(r.settlement_error, 0.01);
  EXPECT_LE(r.stress_error, 0.02);
}

TEST(SolverPhysics, OedometricColumnGaussPoints) {
  const ColumnResult r = run_column("gauss", 2);
  std::printf("column gauss 2x2: settlement error %.3e, mid-depth stress error %.3e\n",
              r.settlement_error, r.stress_error);
  EXPECT_LE(r.settlement_error, 0.01);
  EXPECT_LE(r.stress_error, 0.02);
}

// Free vibration of the column in its first mode (no gravity, no damping): the total energy
// (kinetic + stored, i.e. the accumulated stress power) drifts less than 1 % over 10 periods.
// Kinetic energy and stress power live at staggered time levels in the explicit scheme, so
// the sampled total oscillates by O(dt) within a period (about 4 % at CFL 0.5 here, five
// times less at CFL 0.1) without drifting: the drift is measured on period averages (first
// period against last), and the oscillation must not grow.
TEST(SolverPhysics, FreeVibrationConservesEnergy) {
  const double height = 5.0;
  nlohmann::json j = testing::column_case(height, 0.5, 2, "equal");
  j["gravity"] = {{"g", 0.0}};
  j["solver"]["damping"] = 0.0;
  const Case c = parse_case(j, "vibration");
  MpmSolver solver(c);
  const double m = elastic_parameters(c.materials[0].model).constrained_modulus();
  const double density = 20.0 / 9.81;
  const double period = 4.0 * height / std::sqrt(m / density);
  Particles& p = solver.mutable_particles();
  const double v0 = 0.01;  // m/s: small strain
  for (std::size_t k = 0; k < p.size(); ++k) {
    p.velocity[k] = Vec2(0.0, v0 * std::sin(std::numbers::pi * p.position[k].y() / (2 * height)));
  }
  const double e0 = solver.energy().kinetic_energy;
  double min_ke = e0, first_sum = 0, last_sum = 0;
  double first_lo = 1e300, first_hi = -1e300, last_lo = 1e300, last_hi = -1e300, worst = 0;
  int first_n = 0, last_n = 0;
  while (solver.time() < 10.0 * period) {
    solver.step();
    const EnergyBalance e = solver.energy();
    const double total = e.kinetic_energy + e.internal_work();
    worst = std::max(worst, std::abs(total - e0) / e0);
    min_ke = std::min(min_ke, e.kinetic_energy);
    if (solver.time() <= period) {
      first_sum += total, ++first_n;
      first_lo = std::min(first_lo, total), first_hi = std::max(first_hi, total);
    } else if (solver.time() > 9.0 * period) {
      last_sum += total, ++last_n;
      last_lo = std::min(last_lo, total), last_hi = std::max(last_hi, total);
    }
  }
  const double drift = std::abs(last_sum / last_n - first_sum / first_n) / e0;
  std::printf(
      "free vibration: period %.4f s, %ld steps, period-averaged drift %.3e, "
      "sampled max deviation %.3e, oscillation first/last period %.3e / %.3e\n",
      period, solver.step_count(), drift, worst, (first_hi - first_lo) / e0,
      (last_hi - last_lo) / e0);
  EXPECT_LT(min_ke, 0.05 * e0);  // it really oscillates: energy goes into strain and back
  EXPECT_LT(drift, 0.01);
  EXPECT_LE(last_hi - last_lo, 1.1 * (first_hi - first_lo));  // no growth
}

// A grid_top_nodes pressure with B-splines: the forces are the integrals of N_I along the initial
// top (the top edge of each cell column's highest occupied cell), here a stepped top (y = 3 m
// for x < 2 m, 2 m beyond) loaded over x in [0.3, 3.7] m, which starts and ends inside cells.
// Partition of unity and linear precision make the force (x1 - x0) and its moment int x dx
// exact, and the forces of a node column sum to int N_i(x) dx, which is h for a node whose
// support lies inside the loaded range (x = 1.5, 2 and 2.5 m). In the step, nodes too light to
// carry their share (mass <= 0.01 of a full cell's: the rows above the top with one point per
// cell, and next to the corners with two) pass it down their node column, which keeps all three
// sums; no node that carries load is light. That is the rule without ties
// (solver.outer_node_fraction 0); GridTopLoadWithTiedBsplinesActsOnTheMovingTop has the default.
TEST(SolverPhysics, GridTopLoadWithBsplinesIsTheIntegralAlongTheTop) {
  const double q = 10.0;
  for (const char* shape : {"quadratic_bspline", "cubic_bspline"}) {
    for (const int points_per_cell : {1, 2}) {
      SCOPED_TRACE(std::string(shape) + ", " + std::to_string(points_per_cell) + " per cell");
      nlohmann::json j = nlohmann::json::parse(R"({
        "grid": {"origin": [0, 0], "cell_size": 0.5, "n_cells": [10, 8]},
        "materials": [{"name": "soil", "model": "linear_elastic", "youngs_modulus": 10000.0,
                       "poisson_ratio": 0.3, "unit_weight": 20.0}],
        "bodies": [{"name": "block", "material": "soil",
                    "polygon": [[0, 0], [4, 0], [4, 2], [2, 2], [2, 3], [0, 3]]}],
        "gravity": {"g": 0.0},
        "boundary_conditions": [{"where": "bottom", "fix": "xy"}],
        "loads": [{"type": "vertical_pressure", "pressure": 10.0, "x_range": [0.3, 3.7]}],
        "time": {"end_time": 1.0}
      })");
      j["solver"]["shape_function"] = shape;
      j["solver"]["outer_node_fraction"] = 0.0;
      j["bodies"][0]["points_per_cell"] = points_per_cell;
      const Case c = parse_case(j, "stepped block");
      MpmSolver solver(c);
      const Grid& grid = solver.grid();
      const double h = grid.cell_size;
      const Particles& p = solver.particles();
      const double full_cell = p.mass[0] / p.initial_volume[0] * h * h;
      const auto& load = solver.top_node_loads().at(0);
      std::vector<double> stored(static_cast<std::size_t>(grid.n_nodes()), 0.0);
      for (std::size_t k = 0; k < load.node.size(); ++k)
        stored[static_cast<std::size_t>(load.node[k])] = -q * load.vertical_force_per_kpa[k];
      std::vector<double> applied, mass;
      solver.set_external_force_hook(
          [&](const StepView&, GridState& state, std::vector<Vec2>& force) {
            for (const Vec2& f : force) applied.push_back(f.y());
            mass = state.mass;
          });
      solver.step();
      int light = 0;
      for (const auto* forces : {&stored, &applied}) {
        double force = 0.0, moment = 0.0;
        std::map<int, double> column;  // node column -> its forces' sum
        for (int node = 0; node < grid.n_nodes(); ++node) {
          const double f = (*forces)[static_cast<std::size_t>(node)];
          const int i = node % grid.n_nodes_x();
          force += f;
          moment += f * (grid.origin.x() + i * h);
          column[i] += f;
          if (forces == &applied && f != 0.0) {
            EXPECT_GT(mass[static_cast<std::size_t>(node)], 0.01 * full_cell) << "node " << node;
          }
          if (forces == &stored && f != 0.0 &&
              mass[static_cast<std::size_t>(node)] <= 0.01 * full_cell) {
            ++light;
          }
        }
        EXPECT_NEAR(force, -q * 3.4, 1e-12);
        EXPECT_NEAR(moment, -q * 0.5 * (3.7 * 3.7 - 0.3 * 0.3), 1e-12);
        for (const int i : {3, 4, 5}) EXPECT_NEAR(column[i], -q * h, 1e-13) << "column " << i;
      }
      EXPECT_GT(light, 0) << "the light-node rule must be at work for the test to tell";
    }
  }
}

// The same stepped block with the default ties (basis_extension.hpp): the load acts on each
// cell column's top edge as the top layer of points has moved, with the same forces as the
// integral along the initial top while nothing has moved (first step); a node that takes a force
// either keeps material after the ties or is tied. Then the block is lowered rigidly by 0.3 h:
// the forces keep their sum and moment and move down with it (the grid reaches a cell below the
// block, so that it stays on the grid).
TEST(SolverPhysics, GridTopLoadWithTiedBsplinesActsOnTheMovingTop) {
  const double q = 10.0;
  for (const char* shape : {"quadratic_bspline", "cubic_bspline"}) {
    SCOPED_TRACE(shape);
    nlohmann::json j = nlohmann::json::parse(R"({
      "grid": {"origin": [0, -0.5], "cell_size": 0.5, "n_cells": [10, 9]},
      "materials": [{"name": "soil", "model": "linear_elastic", "youngs_modulus": 10000.0,
                     "poisson_ratio": 0.3, "unit_weight": 20.0}],
      "bodies": [{"name": "block", "material": "soil", "points_per_cell": 2,
                  "polygon": [[0, 0], [4, 0], [4, 2], [2, 2], [2, 3], [0, 3]]}],
      "gravity": {"g": 0.0},
      "boundary_conditions": [{"where": "bottom", "fix": "xy"}],
      "loads": [{"type": "vertical_pressure", "pressure": 10.0, "x_range": [0.3, 3.7]}],
      "time": {"end_time": 1.0}
    })");
    j["solver"]["shape_function"] = shape;
    const Case c = parse_case(j, "stepped block");
    ASSERT_EQ(c.solver.outer_node_fraction, kDefaultOuterNodeFraction);
    for (const double lowered : {0.0, 0.3}) {
      SCOPED_TRACE("lowered by " + std::to_string(lowered) + " h");
      MpmSolver solver(c);
      const Grid& grid = solver.grid();
      const double h = grid.cell_size;
      for (Vec2& x : solver.mutable_particles().position) x.y() -= lowered * h;
      const auto& load = solver.top_node_loads().at(0);
      std::vector<double> stored(static_cast<std::size_t>(grid.n_nodes()), 0.0);
      for (std::size_t k = 0; k < load.node.size(); ++k)
        stored[static_cast<std::size_t>(load.node[k])] = -q * load.vertical_force_per_kpa[k];
      std::vector<double> applied;
      solver.set_external_force_hook([&](const StepView&, GridState&, std::vector<Vec2>& force) {
        for (const Vec2& f : force) applied.push_back(f.y());
      });
      solver.step();
      // The step's ties, those of loaded nodes without material included.
      const GridState& state = solver.grid_state();
      ASSERT_NE(state.ties, nullptr);
      int untied_without_mass = 0, tied_with_force = 0;
      for (std::size_t node = 0; node < applied.size(); ++node) {
        if (applied[node] == 0.0) continue;
        const bool tied = std::count(state.ties->outer.begin(), state.ties->outer.end(),
                                     static_cast<int>(node)) > 0;
        tied_with_force += tied;
        untied_without_mass += !tied && !(state.mass[node] > 0.0);
      }
      EXPECT_EQ(untied_without_mass, 0);
      EXPECT_GT(tied_with_force, 0) << "the ties must be at work for the test to tell";
      double force = 0.0, moment = 0.0, first_moment_y = 0.0, stored_first_moment_y = 0.0;
      for (int node = 0; node < grid.n_nodes(); ++node) {
        const double f = applied[static_cast<std::size_t>(node)];
        const Vec2 x = grid.node_position(node % grid.n_nodes_x(), node / grid.n_nodes_x());
        force += f;
        moment += f * x.x();
        first_moment_y += f * x.y();
        stored_first_moment_y += stored[static_cast<std::size_t>(node)] * x.y();
        if (lowered == 0.0) {
          EXPECT_NEAR(f, stored[static_cast<std::size_t>(node)], 1e-12) << "node " << node;
        }
      }
      EXPECT_NEAR(force, -q * 3.4, 1e-12);
      EXPECT_NEAR(moment, -q * 0.5 * (3.7 * 3.7 - 0.3 * 0.3), 1e-12);
      // Linear precision along y: the forces' centre moves down with the top.
      EXPECT_NEAR(first_moment_y, stored_first_moment_y - force * lowered * h, 1e-11);
    }
  }
}

// Two runs give bitwise identical particles, with 1 and with 2 threads (the quadratic B-splines
// with XPIC(3), whose passes scatter to the grid as particles_to_grid does).
TEST(SolverPhysics, BitwiseDeterministicAcrossThreadCounts) {
  for (const std::string shape : {"linear", "gimp", "quadratic_bspline"}) {
    nlohmann::json j = read_json_file(std::string(PFM_SOURCE_DIR) +
                                      "/cases/thesis62_bearing_dynamic_zero_start.json");
    j["time"]["end_time"] = 0.5;
    if (shape == "gimp") {
      j["grid"]["origin"] = {-0.5, -0.5};
      j["grid"]["n_cells"] = {32, 17};
      j["boundary_conditions"] = nlohmann::json::parse(
          R"([{"where": "bottom_of_block", "fix": "xy"}, {"where": "left_of_block", "fix": "x"},
              {"where": "right_of_block", "fix": "x"}])");
      j["node_sets"] = nlohmann::json::parse(
          R"([{"name": "bottom_of_block", "box": [[-0.5, 0], [15.5, 0]]},
              {"name": "left_of_block", "box": [[0, 0], [0, 7]]},
              {"name": "right_of_block", "box": [[15, 0], [15, 7]]}])");
    }
    j["solver"]["shape_function"] = shape;
    if (shape == "quadratic_bspline") {
      j["solver"]["pic_fraction"] = 0.05;
      j["solver"]["xpic_order"] = 3;
    }
    const Case c = parse_case(j, "determinism");
    std::vector<Particles> results;
    for (const int threads : {1, 1, 2}) {
      omp_set_num_threads(threads);
      MpmSolver solver(c);
      while (solver.time() < c.time.end_time) solver.step();
      results.push_back(solver.particles());
    }
    for (std::size_t r = 1; r < results.size(); ++r) {
      ASSERT_EQ(results[r].size(), results[0].size());
      for (std::size_t k = 0; k < results[0].size(); ++k) {
        ASSERT_EQ(results[r].position[k], results[0].position[k]) << shape << " run " << r;
        ASSERT_EQ(results[r].velocity[k], results[0].velocity[k]) << shape << " run " << r;
        ASSERT_EQ(results[r].stress[k], results[0].stress[k]) << shape << " run " << r;
      }
    }
  }
}

}  // namespace
}  // namespace pfm

// The energy ledger (mpm/step/energy_ledger.hpp): each term is exact for its stage, and the
// identity kinetic + elastic + dissipation = initial + supplied closes to rounding over whole
// runs of both solvers, MUSL and USL, elastic and plastic.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <random>

#include "fem_reference/ulfem/ulfem_solver.hpp"
#include "mpm/core/kinematics.hpp"
#include "mpm/solver/boundary_coupling.hpp"
#include "mpm/solver/mpm_solver.hpp"
#include "mpm/step/case.hpp"
#include "mpm/step/energy_ledger.hpp"

namespace pfm {
namespace {

// One node: the change of its kinetic energy over the update equals the work of its forces,
// gravity, loads, internal and damping, and the constraint's share (the velocity it replaces and
// the reaction's work). A support (prescribed zero) only takes energy; a moving one ends at its
// prescribed velocity, with the reaction m a - f that its acceleration needs.
TEST(EnergyLedger, NodeUpdateSplitsItsKineticEnergyChangeByForce) {
  std::mt19937 random(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const double dt = 0.01;
  for (int trial = 0; trial < 1000; ++trial) {
    const double m = 0.1 + std::abs(u(random));
    const Vec2 p(u(random), u(random)), f_int(u(random), u(random)), f_ext(u(random), u(random));
    const double gravity_y = -std::abs(u(random));
    const unsigned fx = trial % 4 == 1 || trial % 4 == 3, fy = trial % 4 == 2 || trial % 4 == 3;
    const bool moving = trial % 8 >= 4;
    const Vec2 start = moving ? Vec2(u(random), u(random)) : Vec2::Zero();
    const Vec2 end = moving ? Vec2(u(random), u(random)) : Vec2::Zero();
    NodeEnergy e;
    Vec2 v, a, reaction;
    const DampingForm form = trial % 2 ? DampingForm::kAlongVelocity : DampingForm::kPerAxis;
    const Vec2 f_all(f_ext.x(), f_ext.y() + gravity_y);
    update_node(m, p, f_int, f_all, Vec2(0.0, gravity_y), fx, fy, 0.05 * (trial % 3), form, dt,
                start, end, v, a, reaction, e);
    const double change = e.kinetic_after - e.kinetic_before;
    const double work = e.gravity + e.load + e.internal + e.damping + e.constraint;
    EXPECT_NEAR(change, work, 1e-14 * (1.0 + e.kinetic_after + e.kinetic_before));
    if (!moving) {
      EXPECT_LE(e.constraint, 0.0);
    }
    const Vec2 f = f_int + f_all;
    if (fx) {
      EXPECT_NEAR(v.x(), end.x(), 1e-15);
      EXPECT_NEAR(reaction.x(), m * (end.x() - start.x()) / dt - f.x(), 1e-12);
    } else {
      EXPECT_EQ(reaction.x(), 0.0);
    }
    if (fy) {
      EXPECT_NEAR(v.y(), end.y(), 1e-15);
      EXPECT_NEAR(reaction.y(), m * (end.y() - start.y()) / dt - f.y(), 1e-12);
    } else {
      EXPECT_EQ(reaction.y(), 0.0);
    }
  }
}

// One point: V1 psi(s1) - V0 psi(s0) = P - D + rotation + volume, through a yielding Tresca
// update with rotation and a change of volume; D >= 0 when it yields, D = 0 when elastic.
TEST(EnergyLedger, StressUpdateTermsAddUpToTheElasticEnergyChange) {
  Tresca model;
  model.elastic = {1000.0, 0.3};
  model.cohesion = {{0.0, 0.1}, {10.0, 5.0}};
  const MaterialConstants c = model.constants();
  std::mt19937 random(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  int yielded = 0;
  for (int trial = 0; trial < 1000; ++trial) {
    Stress s0(-20.0 + 5 * u(random), -30.0 + 5 * u(random), 3.0 * u(random), -25.0);
    PointState state;
    Mat2 l;
    l << u(random), u(random), u(random), u(random);
    const double dt = 0.002 * (1 + trial % 5);
    const Strain de = strain_increment(l, dt);
    Stress s = s0;
    jaumann_rotate(l, dt, s);
    const Stress rotated = s;
    const ReturnInfo info = model.update_with_info(de, s, state);
    const double v0 = 0.25, v1 = v0 * (1.0 + dt * (l(0, 0) + l(1, 1)));
    PointEnergy e;
    const double power = add_stress_update_energy(c, s0, rotated, s, de, v0, v1, e);
    EXPECT_EQ(power, e.stress_power);
    const double change = v1 * elastic_energy_density(c, s) - v0 * elastic_energy_density(c, s0);
    EXPECT_NEAR(change, e.stress_power - e.plastic_dissipation + e.rotation + e.volume,
                1e-13 * v0 * elastic_energy_density(c, s0));
    if (info.n_active > 0) {
      ++yielded;
      EXPECT_GT(e.plastic_dissipation, 0.0);
    } else {
      EXPECT_NEAR(e.plastic_dissipation, 0.0, 1e-14 * v0 * elastic_energy_density(c, s0));
    }
  }
  EXPECT_GT(yielded, 20);
}

// The energy density of a uniaxial plane-strain state: psi = s : eps / 2 with eps = C^-1 s.
TEST(EnergyLedger, ElasticEnergyDensityIsHalfStressTimesStrain) {
  LinearElastic model;
  model.elastic = {2000.0, 0.25};
  const MaterialConstants c = model.constants();
  const Strain eps(-0.01, 0.003, 0.002, 0.0);
  Stress s = Stress::Zero();
  PointState state;
  model.update(eps, s, state);
  EXPECT_NEAR(elastic_energy_density(c, s), 0.5 * s.dot(eps), 1e-14 * s.norm() * eps.norm());
}

nlohmann::json elastic_block(const std::string& scheme, double damping) {
  // The bearing block's soil made elastic, gravity at once, 0.25 m cells, 2 x 2 points per cell.
  nlohmann::json j = nlohmann::json::parse(R"({
    "grid": {"origin": [0, 0], "cell_size": 0.25, "n_cells": [60, 30]},
    "materials": [{"name": "soil", "model": "linear_elastic", "youngs_modulus": 1000.0,
                   "poisson_ratio": 0.15, "unit_weight": 20.0}],
    "bodies": [{"name": "block", "material": "soil", "rectangle": [[0, 0], [15, 5]]}],
    "boundary_conditions": [{"where": "bottom", "fix": "xy"}, {"where": "left", "fix": "x"},
                            {"where": "right", "fix": "x"}],
    "time": {"end_time": 1.0, "cfl": 0.5}
  })");
  j["solver"] = {{"scheme", scheme}, {"damping", damping}};
  return j;
}

struct Closure {
  double worst = 0.0;    ///< largest |energy_error| / largest term over the steps
  double largest = 0.0;  ///< the largest term at the end
};

template <class Solver>
Closure run_and_check(Solver& solver, int n_steps) {
  Closure closure;
  for (int k = 0; k < n_steps; ++k) {
    solver.step();
    const EnergyBalance e = solver.energy();
    closure.worst = std::max(closure.worst, std::abs(e.energy_error()) / e.largest_term());
    closure.largest = e.largest_term();
  }
  return closure;
}

TEST(EnergyLedger, ClosesOnTheUndampedElasticBlockMuslAndUsl) {
  for (const std::string scheme : {"musl", "usl"}) {
    const Case c = parse_case(elastic_block(scheme, 0.0), "elastic_block");
    MpmSolver solver(c);
    solver.initialise_stress();
    // USL on this block goes unstable after about 110 steps (the 0.125 m block of the issue
    // after about 240, as in cb-geo/mpm): stop before.
    const Closure closure = run_and_check(solver, scheme == "usl" ? 90 : 400);
    const EnergyBalance e = solver.energy();
    std::printf(
        "%s elastic block: worst |error| / largest term %.2e; gravity %.2f, kinetic %.2f, "
        "elastic %.2f, transfers %.2f + %.2f, internal force %.2f + stress power %.2f kJ/m\n",
        scheme.c_str(), closure.worst, e.ledger.gravity_work, e.kinetic_energy, e.elastic_energy,
        e.ledger.transfer_to_grid, e.ledger.transfer_to_particles, e.ledger.internal_force_work,
        e.ledger.stress_power);
    EXPECT_LE(closure.worst, 1e-9);
    EXPECT_GT(e.ledger.gravity_work, 1.0);
  }
}

TEST(EnergyLedger, ClosesOnTheUlFemDampedAndUndamped) {
  for (const double damping : {0.0, 0.1}) {
    const Case c = parse_case(elastic_block("musl", damping), "elastic_block");
    ulfem::UlFemSolver solver(c);
    solver.initialise_stress();
    const Closure closure = run_and_check(solver, 300);
    const EnergyBalance e = solver.energy();
    std::printf("UL-FEM elastic block, damping %.1f: worst |error| / largest term %.2e\n", damping,
                closure.worst);
    EXPECT_LE(closure.worst, 1e-9);
    // No cell crossing on a mesh that moves with the material: the transfers are those of the
    // consistent-to-lumped projection only, and the scheme's own term stays small.
    EXPECT_LE(std::abs(e.ledger.internal_force_work + e.ledger.stress_power),
              0.05 * e.ledger.gravity_work);
  }
}

// The undamped elastic block under its weight applied at once (15 x 5 m, rollers on the sides,
// fixed base, E = 1000 kPa, nu = 0.15, 0.25 m cells with a 2-cell margin, 2 x 2 points per cell):
// the top cannot settle more than twice its static settlement, gamma H^2 / M = 0.4735 m
// (M = E (1 - nu) / ((1 + nu)(1 - 2 nu)), the column in one-dimensional compression). With linear
// shape functions the top goes to 0.67 m: points crossing cells take energy from the grid
// (transfer_to_grid -7,631 kJ/m, internal force work +2,192 against a stress power of 85, at
// 2.5 s), the scheme's, not the physics'. With uGIMP the crossing is smooth and the top stays
// below the bound (0.460 m).
double peak_top_settlement_of_undamped_block(const std::string& shape_function) {
  const double h = 0.25, far = 1e3;
  nlohmann::json j = elastic_block("musl", 0.0);
  j["grid"] = {{"origin", {-2 * h, -2 * h}}, {"cell_size", h}, {"n_cells", {64, 24}}};
  j["node_sets"] = {{{"name", "base"}, {"box", {{-far, -far}, {15 + far, 1e-9}}}},
                    {{"name", "left_wall"}, {"box", {{-far, 0.0}, {1e-9, 6.0}}}},
                    {{"name", "right_wall"}, {"box", {{15 - 1e-9, 0.0}, {15 + far, 6.0}}}}};
  j["boundary_conditions"] = {{{"where", "base"}, {"fix", "xy"}},
                              {{"where", "left_wall"}, {"fix", "x"}},
                              {{"where", "right_wall"}, {"fix", "x"}}};
  j["solver"]["shape_function"] = shape_function;
  const Case c = parse_case(j, "elastic_block_" + shape_function);
  MpmSolver solver(c);
  solver.initialise_stress();
  const Particles& p = solver.particles();
  std::vector<std::size_t> top;
  double top_y = 0.0;
  for (std::size_t k = 0; k < p.size(); ++k) top_y = std::max(top_y, p.position[k].y());
  for (std::size_t k = 0; k < p.size(); ++k)
    if (p.position[k].y() > top_y - 1e-9) top.push_back(k);
  double peak = 0.0, worst = 0.0;
  while (solver.time() < 2.5) {
    solver.step();
    double settlement = 0.0;
    for (const std::size_t k : top) settlement -= p.position[k].y() - p.reference_position[k].y();
    peak = std::max(peak, settlement / static_cast<double>(top.size()));
    const EnergyBalance e = solver.energy();
    worst = std::max(worst, std::abs(e.energy_error()) / e.largest_term());
  }
  const EnergyBalance e = solver.energy();
  std::printf(
      "undamped elastic block, %s: peak top settlement %.3f m; at 2.5 s transfers %.1f + %.1f, "
      "internal force work %.1f, stress power %.1f kJ/m; worst |error| / largest term %.1e\n",
      shape_function.c_str(), peak, e.ledger.transfer_to_grid, e.ledger.transfer_to_particles,
      e.ledger.internal_force_work, e.ledger.stress_power, worst);
  EXPECT_LE(worst, 1e-9);
  return peak;
}

TEST(EnergyLedger, UndampedElasticBlockOvershootIsTheLinearCellCrossing) {
  const double m = 1000.0 * 0.85 / (1.15 * 0.7), bound = 20.0 * 5.0 * 5.0 / m;  // 0.4735 m
  EXPECT_GT(peak_top_settlement_of_undamped_block("linear"), 1.2 * bound);
  EXPECT_LE(peak_top_settlement_of_undamped_block("gimp"), bound);
}

// Through failure: the softening Tresca block of cases/thesis62_bearing_dynamic_k0_start.json under
// its load on the detected top, K0 start (initial elastic energy), damped.
TEST(EnergyLedger, ClosesThroughFailureUnderADetectedBoundaryLoad) {
  const Case c = read_case("cases/thesis62_bearing_dynamic_k0_start.json");
  MpmSolver solver(c);
  BoundaryCoupling coupling(c);
  solver.initialise_stress();
  coupling.attach(solver);
  EXPECT_GT(solver.energy().ledger.initial_energy, 0.0);
  const Closure closure = run_and_check(solver, 150);
  const EnergyBalance e = solver.energy();
  std::printf("bearing block K0, 150 steps: worst |error| / largest term %.2e, dissipation %.2f\n",
              closure.worst, e.ledger.plastic_dissipation);
  EXPECT_LE(closure.worst, 1e-9);
  EXPECT_GT(e.ledger.plastic_dissipation, 0.0);
  EXPECT_GT(e.ledger.load_work, 0.0);
}

// The work of each load on its own (EnergyLedger::load_work_by_load): the quasi-static strip
// load of cases/bearing_quasi_static.json (load 0, on the detected top) with a load on the grid's
// top nodes (1) and a copy of load 0 (2). At every step the works add up to the ledger's
// load_work to rounding, and the copy's work is load 0's bit for bit; MPM and UL-FEM.
template <class Solver>
void check_each_loads_work(Solver& solver, int n_steps, const char* name) {
  double worst = 0.0;
  for (int k = 0; k < n_steps; ++k) {
    solver.step();
    const EnergyLedger& l = solver.energy().ledger;
    ASSERT_EQ(l.load_work_by_load.size(), 3u);
    const double sum = l.load_work_by_load[0] + l.load_work_by_load[1] + l.load_work_by_load[2];
    worst = std::max(worst, std::abs(sum - l.load_work) / std::max(1e-300, std::abs(l.load_work)));
    ASSERT_EQ(l.load_work_by_load[0], l.load_work_by_load[2]) << "step " << k;
  }
  const EnergyLedger& l = solver.energy().ledger;
  std::printf(
      "%s: works of the loads %.4f, %.4f, %.4f kJ/m, load_work %.4f, worst |sum - "
      "load_work| / |load_work| %.1e\n",
      name, l.load_work_by_load[0], l.load_work_by_load[1], l.load_work_by_load[2], l.load_work,
      worst);
  EXPECT_LE(worst, 1e-12);
  EXPECT_GT(l.load_work_by_load[0], 0.0);
  EXPECT_GT(l.load_work_by_load[1], 0.0);
}

TEST(EnergyLedger, EachLoadsWorkAddsUpToTheLoadWork) {
  std::ifstream in("cases/bearing_quasi_static.json");
  nlohmann::json j = nlohmann::json::parse(in);
  nlohmann::json copy = j["loads"][0];
  j["loads"].push_back({{"type", "vertical_pressure"},
                        {"pressure", 30.0},
                        {"x_range", {11.0, 14.0}},
                        {"apply_on", "grid_top_nodes"},
                        {"time_function", {{"type", "ramp"}, {"ramp_time", 0.5}}}});
  j["loads"].push_back(copy);
  const Case c = parse_case(j, "three_loads");
  MpmSolver mpm(c);
  BoundaryCoupling coupling(c);
  mpm.initialise_stress();
  coupling.attach(mpm);
  check_each_loads_work(mpm, 300, "MPM");
  ulfem::UlFemSolver fem(c);
  fem.initialise_stress();
  check_each_loads_work(fem, 300, "UL-FEM");
}

}  // namespace
}  // namespace pfm

// Constraints on the detected boundary (issue: "Prescribed displacement and velocity on the
// detected moving boundary", must-shows 1, 3 and 4, and its bad input).
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>

#include "mpm/core/json_input.hpp"
#include "mpm/solver/boundary_coupling.hpp"
#include "mpm/solver/mpm_solver.hpp"
#include "mpm/step/case.hpp"
#include "tests/cpp/inclined_block.hpp"

namespace pfm {
namespace {

// These runs take one thread: ctest runs two tests at once on two cores, and two OpenMP teams
// waiting on each other's cores cost ten times the work (issue 19).
class OneThread {
 public:
  OneThread() : before_(omp_get_max_threads()) { omp_set_num_threads(1); }
  ~OneThread() { omp_set_num_threads(before_); }
  OneThread(const OneThread&) = delete;
  OneThread& operator=(const OneThread&) = delete;

 private:
  int before_;
};

struct BlockResult {
  double interior_nn_error = 0.0;      // mean sigma_nn of the interior points / exact - 1
  double interior_tt_error = 0.0;      // the same for sigma_tt
  double worst_point_error = 0.0;      // largest |sigma_nn / exact - 1| over the interior points
  double reaction_error = 0.0;         // force on the loaded face . (-n) / exact - 1
  double opposite_error = 0.0;         // force on the opposite face . n / exact - 1
  double energy_error = 0.0;           // the ledger's, relative to the elastic energy
  double kinetic_ratio = 0.0;          // kinetic / elastic energy at the end
  double constraint_work_ratio = 0.0;  // constraint work / elastic energy at the end
};

// cases/constraint_inclined_block.json with the penalty factor given (0: the default), against
// its closed form (tests/cpp/inclined_block.hpp).
BlockResult run_inclined_block(double penalty_factor,
                               ConstraintMethod method = ConstraintMethod::kPenalty) {
  const OneThread one_thread;
  Case c = read_case("cases/constraint_inclined_block.json");
  for (ConstraintSpec& s : c.constraints) s.method = method;
  if (penalty_factor > 0.0) {
    const double modulus = elastic_parameters(c.materials[0].model).constrained_modulus();
    for (ConstraintSpec& s : c.constraints) s.penalty = penalty_factor * modulus / c.grid.cell_size;
  }
  MpmSolver solver(c);
  BoundaryCoupling coupling(c);
  solver.initialise_stress();
  coupling.attach(solver);
  const long steps = static_cast<long>(std::ceil(c.time.end_time / solver.dt() - 1e-9));
  for (long s = 0; s < steps; ++s) solver.step();

  const inclined_block::Errors errors =
      inclined_block::measure(solver.particles(), elastic_parameters(c.materials[0].model),
                              coupling.constraints().reports());
  BlockResult r;
  r.interior_nn_error = errors.interior_nn;
  r.interior_tt_error = errors.interior_tt;
  r.worst_point_error = errors.worst_point;
  r.reaction_error = errors.reaction;
  r.opposite_error = errors.opposite;
  const EnergyBalance b = solver.energy();
  r.energy_error = std::abs(b.energy_error()) / b.elastic_energy;
  r.kinetic_ratio = b.kinetic_energy / b.elastic_energy;
  r.constraint_work_ratio = b.ledger.constraint_work / b.elastic_energy;
  std::printf(
      "inclined block, %s, penalty factor %g: interior sigma_nn %+.4f, sigma_tt %+.4f, worst point "
      "%.4f, reaction %+.4f, opposite face %+.4f, |energy error| / elastic %.1e, kinetic / "
      "elastic %.1e, constraint work / elastic %.4f\n",
      method == ConstraintMethod::kNitsche ? "Nitsche" : "penalty", penalty_factor,
      r.interior_nn_error, r.interior_tt_error, r.worst_point_error, r.reaction_error,
      r.opposite_error, r.energy_error, r.kinetic_ratio, r.constraint_work_ratio);
  return r;
}

// Must-shows 1 and 4: the homogeneous state of uniaxial strain in a block turned 30 degrees, from
// normal displacements of its four detected faces, at the case's time step (cfl 0.5).
TEST(BoundaryConstraint, InclinedBlockReachesUniaxialStrain) {
  const BlockResult r = run_inclined_block(0.0);  // the default penalty, 100 M / h
  // The penalty's compliance, h / (100 L) per face, and the discretisation's error: 2 % in the
  // interior (the issue's bound), 1 % on the reactions (measured: -0.65 %, -0.53 %, at rest:
  // kinetic / elastic 1e-6 with the case's 5 % PIC).
  EXPECT_LE(std::abs(r.interior_nn_error), 0.02);
  EXPECT_LE(std::abs(r.interior_tt_error), 0.02);
  EXPECT_LE(r.worst_point_error, 0.04);  // every interior point
  EXPECT_LE(std::abs(r.reaction_error), 0.01);
  EXPECT_LE(std::abs(r.opposite_error), 0.01);
  // The ledger closes with the constraints' work as a term, and nothing grows: the work the
  // constraints did is the elastic energy stored (a static state, the damping and the PIC
  // transfer took the rest: 1.8 % more at the default factor).
  EXPECT_LE(r.energy_error, 1e-9);
  EXPECT_LE(r.kinetic_ratio, 0.01);
  EXPECT_LE(r.constraint_work_ratio, 1.05);
  EXPECT_GE(r.constraint_work_ratio, 0.95);
}

// Must-show 1: the penalty's error falls as the penalty grows (the compliance h / (factor L)).
TEST(BoundaryConstraint, PenaltyErrorFallsWithThePenalty) {
  const BlockResult soft = run_inclined_block(1.0), stiff = run_inclined_block(16.0);
  // A factor of 1 leaves about 2 h / L = 12 % of the compression to the penalty's springs
  // (measured -13.1 %; factor 16: -1.2 %, 1000: +0.1 %).
  EXPECT_LE(soft.reaction_error, -0.05);
  EXPECT_LE(std::abs(stiff.reaction_error), std::abs(soft.reaction_error) / 5.0);
}

// Item 1: Nitsche's method is consistent. Its error stays the discretisation's where the
// penalty method's is still its compliance, about 2 h / (factor L) (header comment).
TEST(BoundaryConstraint, NitscheIsConsistentAtALowPenalty) {
  const BlockResult nitsche = run_inclined_block(4.0, ConstraintMethod::kNitsche);
  const BlockResult penalty = run_inclined_block(4.0);
  // Measured: Nitsche -0.28 % (reaction), -0.27 % (interior), at rest (kinetic / elastic
  // 2e-6); the penalty method -3.8 %. The bounds are must-show 1's.
  EXPECT_LE(std::abs(nitsche.interior_nn_error), 0.02);
  EXPECT_LE(std::abs(nitsche.interior_tt_error), 0.02);
  EXPECT_LE(nitsche.worst_point_error, 0.04);
  EXPECT_LE(std::abs(nitsche.reaction_error), 0.01);
  EXPECT_LE(std::abs(nitsche.opposite_error), 0.01);
  EXPECT_LE(nitsche.energy_error, 1e-9);
  EXPECT_LE(nitsche.kinetic_ratio, 0.01);
  EXPECT_LE(penalty.reaction_error, -0.03);
}

// Must-show 3: a block sliding at an angle, moving with a prescribed velocity on one detected
// face, crosses cells with no stress: the material's displacement is a translation, which the
// gap reproduces exactly, so the constraint exerts no force.
TEST(BoundaryConstraint, SlidingBlockStaysFreeOfStress) {
  const nlohmann::json document = nlohmann::json::parse(R"({
    "grid": {"cell_size": 0.0625, "n_cells": [48, 32]},
    "materials": [{"name": "b", "model": "linear_elastic", "youngs_modulus": 10000.0,
                   "poisson_ratio": 0.3, "unit_weight": 20.0}],
    "bodies": [{"name": "b", "material": "b", "rectangle": [[0.5, 0.5], [1.5, 1.25]]}],
    "gravity": {"g": 0.0},
    "constraints": [{"apply_on": "detected_boundary", "velocity": [1.0, 0.5],
                     "normal": {"direction": [1.0, 0.0], "max_angle": 45.0}}],
    "solver": {"shape_function": "quadratic_bspline"},
    "time": {"end_time": 0.25, "cfl": 0.5}
  })");
  const Case c = parse_case(document, "sliding.json");
  const OneThread one_thread;
  MpmSolver solver(c);
  BoundaryCoupling coupling(c);
  solver.initialise_stress();
  coupling.attach(solver);
  const Vec2 v(1.0, 0.5);
  for (Vec2& velocity : solver.mutable_particles().velocity) velocity = v;
  const long steps = static_cast<long>(std::ceil(c.time.end_time / solver.dt() - 1e-9));
  double largest_stress = 0.0, largest_force = 0.0;
  for (long s = 0; s < steps; ++s) {
    solver.step();
    for (const Stress& stress : solver.particles().stress)
      largest_stress = std::max(largest_stress, stress.cwiseAbs().maxCoeff());
    largest_force = std::max(largest_force, coupling.constraints().reports()[0].force.norm());
  }
  // 0.25 s at 1.1 m/s: the face crosses 4 cells. The strain scale: |v| T / L = 0.28.
  const double strain_scale = v.norm() * c.time.end_time / 1.0;
  const double bound = 1e-6 * 10000.0 * strain_scale;
  std::printf("sliding block: largest |stress| %.2e kPa (bound %.2e), largest force %.2e kN/m\n",
              largest_stress, bound, largest_force);
  EXPECT_LE(largest_stress, bound);
  const Vec2 moved = solver.particles().position[0] - solver.particles().reference_position[0];
  EXPECT_NEAR(moved.x(), v.x() * solver.time(), 1e-9);
  EXPECT_NEAR(moved.y(), v.y() * solver.time(), 1e-9);
}

// A 2 m x 1 m block (base at y = 0.5 m) without gravity, its detected top over x in [1.0, 1.6]
// held at zero normal displacement; `detection`: the case's detection settings; `shape`: the
// shape function (empty: the default).
Case held_top_case(const nlohmann::json& detection, const std::string& shape = "gimp") {
  nlohmann::json document = nlohmann::json::parse(R"({
    "grid": {"cell_size": 0.125, "n_cells": [24, 16]},
    "materials": [{"name": "b", "model": "linear_elastic", "youngs_modulus": 10000.0,
                   "poisson_ratio": 0.3, "unit_weight": 20.0}],
    "bodies": [{"name": "b", "material": "b", "rectangle": [[0.5, 0.5], [2.5, 1.5]]}],
    "gravity": {"g": 0.0},
    "constraints": [{"apply_on": "detected_boundary", "x_range": [1.0, 1.6], "faces": "top",
                     "normal": {"direction": [0.0, 1.0], "max_angle": 45.0},
                     "normal_displacement": 0.0}],
    "solver": {"shape_function": "gimp"},
    "time": {"end_time": 0.1, "cfl": 0.5}
  })");
  if (!detection.empty()) document["detection"] = detection;
  if (shape.empty()) {
    document.erase("solver");
  } else {
    document["solver"]["shape_function"] = shape;
  }
  return parse_case(document, "held_top.json");
}

// The fit takes the material over the part's x_range only: under a footing's edge the soil
// beside it heaves while the soil under it follows the footing, and a fit across the edge would
// read a gap that neither has. Here the material over the part has moved down by 1 mm (a
// translation, which the fit reproduces exactly, also one-sided at the part's ends), the
// material beside it up by 10 mm; the constraint holds the top at rest. The gap along the whole
// part is the 1 mm, to rounding; it does not depend on the material beside the part at all.
TEST(BoundaryConstraint, FitTakesOnlyTheMaterialOverThePart) {
  const Case c = held_top_case(nlohmann::json::object());
  const auto first_step = [&](double beside) {
    const OneThread one_thread;
    MpmSolver solver(c);
    BoundaryCoupling coupling(c);
    solver.initialise_stress();
    coupling.attach(solver);
    Particles& p = solver.mutable_particles();
    for (std::size_t k = 0; k < p.size(); ++k) {
      const double x = p.position[k].x();
      const double uy = x >= 1.0 && x <= 1.6 ? -0.001 : beside;
      p.reference_position[k].y() -= uy;  // u_p = x_p - X_p: uy upwards
    }
    solver.step();
    return coupling.constraints().reports()[0];
  };
  const ConstraintReport heave = first_step(0.01), none = first_step(-0.001);
  std::printf("fit over the part: rms gap %.15g m (heave beside), %.15g m (none), length %g m\n",
              heave.rms_gap, none.rms_gap, heave.length);
  EXPECT_NEAR(heave.length, 0.6, 1e-4);  // the detected top: within 1e-4 m of flat
  EXPECT_NEAR(heave.rms_gap, 0.001, 1e-15);
  EXPECT_EQ(heave.rms_gap, none.rms_gap);
  EXPECT_EQ(heave.force, none.force);
}

// Between two detections the constrained part moves with the material: each point of the part is
// shifted along its normal by the material's motion since the detection. Here the body is
// stretched upwards by 5 % about its base after the detection (its top rises by 0.05 m, within the
// 0.5 h of motion that the case allows before it detects again), the reference kept: the top's
// displacement is e H = 0.05 m, and so is the gap of the part held at zero. Read at the detected
// (stale) points instead, the gap is the displacement of the material 0.05 m below the top,
// e H / (1 + e): 4.8 % short (with the constraint's stiffness of 16 M / h or more per unit gap,
// such a lag between detections reads as a force, and jumps at each detection).
TEST(BoundaryConstraint, PartFollowsTheMaterialBetweenDetections) {
  // uGIMP, and the default shape function (quadratic B-splines: the fit's weights then come
  // from them): the fit is exact for the linear field either way.
  for (const std::string shape : {"gimp", ""}) {
    SCOPED_TRACE(shape.empty() ? "default shape function" : shape);
    const Case c = held_top_case({{"max_motion", 0.5}}, shape);
    const OneThread one_thread;
    MpmSolver solver(c);
    BoundaryCoupling coupling(c);
    solver.initialise_stress();
    coupling.attach(solver);
    solver.step();  // detects
    const long detections = coupling.times().detections;
    Particles& p = solver.mutable_particles();
    const double e = 0.05, base = 0.5, height = 1.0;
    for (std::size_t k = 0; k < p.size(); ++k) {
      p.reference_position[k] = p.position[k];
      p.position[k].y() = base + (1.0 + e) * (p.position[k].y() - base);
    }
    solver.step();
    ASSERT_EQ(coupling.times().detections, detections);  // the part is the one detected before
    const ConstraintReport& report = coupling.constraints().reports()[0];
    // The shifted point reads the field e (x - base) / (1 + e) a second-order step off the top:
    // e H (1 + 2 e) / (1 + e)^2, 0.23 % short; and the detected top is flat within 1e-4 m.
    EXPECT_NEAR(report.rms_gap / (e * height), 1.0, 0.005) << "gap " << report.rms_gap << " m";
  }
}

// Bad input: exit-2 errors (InputError) naming the JSON path.
void expect_refused(const std::string& constraint, const std::string& where) {
  const nlohmann::json document = nlohmann::json::parse(R"({
    "grid": {"cell_size": 0.25, "n_cells": [8, 8]},
    "materials": [{"name": "b", "model": "linear_elastic", "youngs_modulus": 10000.0,
                   "poisson_ratio": 0.3, "unit_weight": 20.0}],
    "bodies": [{"name": "b", "material": "b", "rectangle": [[0.5, 0.5], [1.5, 1.5]]}],
    "constraints": [)" + constraint + R"(],
    "time": {"end_time": 0.1}
  })");
  try {
    parse_case(document, "bad.json");
    ADD_FAILURE() << "accepted: " << constraint;
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(where), std::string::npos) << e.what();
  }
}

TEST(BoundaryConstraint, BadInputNamesTheJsonPath) {
  expect_refused(R"({"apply_on": "detected_boundary"})", "/constraints/0: give one of");
  expect_refused(R"({"apply_on": "detected_boundary", "velocity": [1, 0],
                     "displacement": [0, 0]})",
                 "/constraints/0: give one of");
  expect_refused(R"({"apply_on": "grid_top_nodes", "velocity": [1, 0]})",
                 "/constraints/0/apply_on");
  expect_refused(R"({"apply_on": "detected_boundary", "velocity": [1, 0],
                     "penalty": 1e6, "penalty_factor": 10})",
                 "/constraints/0: give penalty");
  expect_refused(R"({"apply_on": "detected_boundary", "velocity": [1, 0], "penalty": -1})",
                 "/constraints/0/penalty");
  expect_refused(R"({"apply_on": "detected_boundary", "velocity": [1, 0], "method": "lagrange"})",
                 "/constraints/0/method");
  expect_refused(R"({"apply_on": "detected_boundary", "velocity": [1, 0],
                     "normal": {"direction": [0, 0], "max_angle": 10}})",
                 "/constraints/0/normal/direction");
  expect_refused(R"({"apply_on": "detected_boundary", "velocity": [1, 0],
                     "interval": "material"})",
                 "/constraints/0/interval");
}

}  // namespace
}  // namespace pfm

// UL-FEM loads on the exact mesh boundary: the three load types of the case file (vertical,
// follower pressure, traction) on the slope's edges, the fixed and the material interval, the
// load diagnostics, and the refusal of a load without its specification.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

#include "fem_reference/ulfem/ulfem_solver.hpp"
#include "mpm/core/json_input.hpp"
#include "ulfem_test_util.hpp"

namespace pfm::ulfem {
namespace {

// The slope of cases/thesis55_slope_dynamic_zero_start.json, weightless, with the given loads (JSON
// array text).
Case weightless_slope(const std::string& loads) {
  nlohmann::json j = read_json_file("cases/thesis55_slope_dynamic_zero_start.json");
  j["gravity"] = {{"g", 0.0}};
  j["loads"] = nlohmann::json::parse(loads);
  return parse_case(j, "slope");
}

Vec2 external_resultant(const UlFemSolver& solver) {
  Vec2 sum = Vec2::Zero();
  for (const Vec2& f : solver.node_state().external_force) sum += f;
  return sum;
}

// Surface of the slope y(x): 6 m up to the toe x = 10.125, the face y = x - 4.125, 10 m after
// the crest x = 14.125. Range [8.3, 15.7]: y = 6 at 8.3 and 10 at 15.7; the loaded length of
// the surface is 1.825 + 4 sqrt(2) + 1.575 m.
constexpr double kX0 = 8.3, kX1 = 15.7, kRise = 4.0;
const double kSurfaceLength = 1.825 + 4.0 * std::numbers::sqrt2 + 1.575;

// A vertical pressure q over [x0, x1] is t = (0, -q n_y) on the upward faces (the MPM's law,
// mpm/boundary/surface_load.hpp): resultant (0, -q (x1 - x0)), whatever the surface's slope,
// for both apply_on values; the diagnostics report target = applied, nothing lost.
TEST(UlFemLoads, VerticalPressureResultantOnTheSlopeIsExact) {
  for (const char* target : {"grid_top_nodes", "detected_boundary"}) {
    const Case c = weightless_slope(std::string(R"([{"type": "vertical_pressure", "pressure": 30,
        "x_range": [8.3, 15.7], "apply_on": ")") +
                                    target + "\"}]");
    UlFemSolver solver(c);
    solver.step();
    const Vec2 resultant = external_resultant(solver);
    const Vec2 expected(0.0, -30.0 * (kX1 - kX0));
    const EdgeLoadDiagnostics& d = solver.load_diagnostics();
    std::printf(
        "[ulfem vertical pressure, %s] resultant (%.15g, %.15g) kN/m, expected (0, %.15g); "
        "target (%.15g, %.15g), applied (%.15g, %.15g), %d loaded nodes\n",
        target, resultant.x(), resultant.y(), expected.y(), d.target.x(), d.target.y(),
        d.applied.x(), d.applied.y(), d.loaded_nodes);
    EXPECT_LE((resultant - expected).norm(), 1e-12 * expected.norm()) << target;
    EXPECT_LE((d.applied - d.target).norm(), 1e-12 * expected.norm()) << target;
    EXPECT_LE((d.applied - expected).norm(), 1e-12 * expected.norm()) << target;
    EXPECT_EQ(d.lost, Vec2::Zero());
    EXPECT_EQ(d.off_grid, Vec2::Zero());
    EXPECT_EQ(d.lost_nodes, 0);
    EXPECT_GT(d.loaded_nodes, 10);
  }
}

// A follower pressure p is t = -p n: on the upward faces over [x0, x1] its resultant is
// -p int n ds = p (y(x1) - y(x0), -(x1 - x0)); over the whole closed boundary (no x_range,
// faces "all") it is zero (int n ds = 0 around a closed curve).
TEST(UlFemLoads, FollowerPressureResultants) {
  const double p = 30.0;
  {
    const Case c = weightless_slope(R"([{"type": "follower_pressure", "pressure": 30,
        "x_range": [8.3, 15.7], "faces": "upward", "apply_on": "detected_boundary"}])");
    UlFemSolver solver(c);
    solver.step();
    const Vec2 resultant = external_resultant(solver);
    const Vec2 expected(p * kRise, -p * (kX1 - kX0));
    std::printf("[ulfem follower, upward] resultant (%.15g, %.15g), expected (%.15g, %.15g)\n",
                resultant.x(), resultant.y(), expected.x(), expected.y());
    EXPECT_LE((resultant - expected).norm(), 1e-12 * expected.norm());
  }
  {
    const Case c = weightless_slope(
        R"([{"type": "follower_pressure", "pressure": 30, "apply_on": "detected_boundary"}])");
    UlFemSolver solver(c);
    solver.step();
    const Vec2 resultant = external_resultant(solver);
    double perimeter = 0.0;
    for (const LoadedEdge& e : solver.boundary_edges()) {
      perimeter += (solver.mesh().node_position[static_cast<std::size_t>(e.to)] -
                    solver.mesh().node_position[static_cast<std::size_t>(e.from)])
                       .norm();
    }
    std::printf("[ulfem follower, closed boundary] resultant (%.3g, %.3g) kN/m; p x perimeter %g\n",
                resultant.x(), resultant.y(), p * perimeter);
    EXPECT_LE(resultant.norm(), 1e-12 * p * perimeter);
    EXPECT_GT(solver.load_diagnostics().loaded_nodes, 100);
  }
}

// A traction vector t per current length over the upward faces in [x0, x1]: resultant t x the
// loaded surface length.
TEST(UlFemLoads, TractionResultantIsTractionTimesLength) {
  const Case c = weightless_slope(R"([{"type": "traction", "traction": [4, -7],
      "x_range": [8.3, 15.7], "faces": "upward", "apply_on": "detected_boundary"}])");
  UlFemSolver solver(c);
  solver.step();
  const Vec2 resultant = external_resultant(solver);
  const Vec2 expected = kSurfaceLength * Vec2(4.0, -7.0);
  std::printf("[ulfem traction] resultant (%.15g, %.15g), expected (%.15g, %.15g)\n", resultant.x(),
              resultant.y(), expected.x(), expected.y());
  EXPECT_LE((resultant - expected).norm(), 1e-12 * expected.norm());
}

// Interval "fixed" stays in space, "material" moves with the material: after a rigid shift of
// the block by 0.3 m both resultants are q (x1 - x0), and their centres of force (sum x_I f_I /
// sum f_I, exact for the linear edge forces) are the middle of [x0, x1] and that middle + 0.3 m.
TEST(UlFemLoads, FixedAndMaterialIntervals) {
  for (const char* interval : {"fixed", "material"}) {
    nlohmann::json j = testing::block_case(4.0, 3.0, 0.5, 2, 3);
    j["gravity"] = {{"g", 0.0}};
    j["loads"] = nlohmann::json::parse(std::string(R"([{"type": "vertical_pressure",
        "pressure": 40, "x_range": [1.2, 2.7], "apply_on": "detected_boundary",
        "interval": ")") + interval + "\"}]");
    j["boundary_conditions"] = nlohmann::json::array();
    const Case c = parse_case(j, "block");
    UlFemSolver solver(c);
    solver.displace_nodes(std::vector<Vec2>(solver.mesh().n_nodes(), Vec2(0.3, 0.0)));
    solver.step();
    const auto& force = solver.node_state().external_force;
    double fy = 0.0, moment = 0.0;
    for (std::size_t n = 0; n < force.size(); ++n) {
      fy += force[n].y();
      // Forces act at the positions at the start of the step.
      moment +=
          (solver.node_position()[n].x() - solver.dt() * solver.node_state().velocity[n].x()) *
          force[n].y();
    }
    const double centre = moment / fy;
    const double expected = 1.95 + (std::string(interval) == "material" ? 0.3 : 0.0);
    std::printf(
        "[ulfem interval %s] fy %.15g kN/m (expected %.15g), centre %.15g m (expected %g)\n",
        interval, fy, -40.0 * 1.5, centre, expected);
    EXPECT_NEAR(fy, -60.0, 1e-12 * 60.0) << interval;
    EXPECT_NEAR(centre, expected, 1e-12 * 4.0) << interval;
  }
}

// Faces "top" against "upward" under an overhang: a C-shaped body opening to the right (arms
// 1 m thick, slot 1 m high, x in [1, 4]) has two upward faces under x_range [0.5, 4]: the top
// (y = 3, 3.5 m loaded) and the slot's floor (y = 1, 3 m). "upward" loads both, "top" (the
// default of vertical_pressure, and grid_top_nodes) only the top.
TEST(UlFemLoads, TopFacesSkipTheShadowedSlotFloor) {
  for (const auto& [faces, loaded_length] :
       {std::pair<std::string, double>{"upward", 6.5}, {"top", 3.5}, {"grid_top_nodes", 3.5}}) {
    nlohmann::json j = testing::block_case(4.0, 3.0, 0.5, 2, 2);
    j["gravity"] = {{"g", 0.0}};
    j["bodies"][0].erase("rectangle");
    j["bodies"][0]["polygon"] =
        nlohmann::json::parse("[[0, 0], [4, 0], [4, 1], [1, 1], [1, 2], [4, 2], [4, 3], [0, 3]]");
    nlohmann::json load = {
        {"type", "vertical_pressure"}, {"pressure", 30.0}, {"x_range", {0.5, 4.0}}};
    if (faces == "grid_top_nodes") {
      load["apply_on"] = "grid_top_nodes";
    } else {
      load["apply_on"] = "detected_boundary";
      load["faces"] = faces;
    }
    j["loads"] = {load};
    const Case c = parse_case(j, "c-shape");
    UlFemSolver solver(c);
    ASSERT_EQ(solver.mesh().generator, "grid");
    solver.step();
    const Vec2 resultant = external_resultant(solver);
    std::printf("[ulfem faces %s] resultant (%.15g, %.15g) kN/m, expected (0, %.15g)\n",
                faces.c_str(), resultant.x(), resultant.y(), -30.0 * loaded_length);
    EXPECT_LE((resultant - Vec2(0.0, -30.0 * loaded_length)).norm(), 1e-12 * 30.0 * 6.5) << faces;
  }
}

// A detected-boundary load without its parsed specification (only possible for a Case built in
// code) is refused with an InputError naming the load, never silently dropped.
TEST(UlFemLoads, LoadWithoutSpecificationIsRefused) {
  Case c = weightless_slope("[]");
  LoadSpec load;
  load.type = "follower_pressure";
  load.apply_on = LoadTarget::kDetectedBoundary;
  c.loads = {load};
  try {
    UlFemSolver solver(c);
    FAIL() << "no error";
  } catch (const InputError& e) {
    std::printf("[ulfem load refused] %s\n", e.what());
    EXPECT_NE(std::string(e.what()).find("/loads/0"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace pfm::ulfem

// parse_boundary_load: defaults, every key, and rejection of bad input with the JSON pointer.
#include <gtest/gtest.h>

#include <string>

#include "mpm/boundary/load_input.hpp"

namespace pfm::boundary {
namespace {

BoundaryLoadSpec parse(const std::string& text) {
  const nlohmann::json document = nlohmann::json::parse(text);
  return parse_boundary_load(JsonView(document["loads"][0], "case.json", "/loads/0"));
}

std::string error_of(const std::string& text) {
  try {
    parse(text);
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(BoundaryLoadInput, ThesisLoadWithDefaults) {
  const BoundaryLoadSpec spec = parse(R"({"loads": [{"type": "vertical_pressure",
      "apply_on": "detected_boundary", "pressure": 100, "x_range": [5, 10],
      "time_function": {"type": "ramp", "ramp_time": 0.5}}]})");
  EXPECT_EQ(spec.type, BoundaryLoadType::kVerticalPressure);
  EXPECT_EQ(spec.pressure, 100.0);
  ASSERT_TRUE(spec.x_range.has_value());
  EXPECT_EQ(*spec.x_range, Vec2(5.0, 10.0));
  EXPECT_EQ(spec.faces, LoadedFaces::kTop);
  EXPECT_EQ(spec.curve, CurveKind::kLinear);
  EXPECT_EQ(spec.quadrature.mode, IntegrationMode::kExact);
  EXPECT_EQ(spec.quadrature.gauss_points, 5);
  EXPECT_TRUE(spec.quadrature.split_at_cell_edges);
  EXPECT_FALSE(spec.quadrature.scale_eq_6_15);
  EXPECT_TRUE(spec.redistribute_lost_load);
  EXPECT_EQ(spec.min_node_mass_fraction, 0.01);
  EXPECT_EQ(spec.interval, LoadInterval::kFixed);
  const TractionLaw law = spec.traction_law(0.5);
  EXPECT_EQ(law.normal_scale, Vec2(0.0, -50.0));
}

TEST(BoundaryLoadInput, EveryKeySet) {
  const BoundaryLoadSpec spec = parse(R"({"loads": [{"type": "follower_pressure",
      "apply_on": "detected_boundary", "pressure": -20, "faces": "upward",
      "curve": "cubic", "integration": "thesis", "gauss_points": 7, "scale_eq_6_15": true,
      "redistribute_lost_load": false, "min_node_mass_fraction": 0.25,
      "interval": "material", "x_range": [1, 2],
      "normal": {"direction": [0, 2], "max_angle": 60}}]})");
  EXPECT_EQ(spec.type, BoundaryLoadType::kFollowerPressure);
  EXPECT_EQ(*spec.x_range, Vec2(1.0, 2.0));
  ASSERT_TRUE(spec.normal_window.has_value());
  EXPECT_EQ(spec.normal_window->direction, Vec2(0.0, 1.0));
  EXPECT_NEAR(spec.normal_window->min_cosine, 0.5, 1e-15);
  EXPECT_EQ(spec.faces, LoadedFaces::kUpward);
  EXPECT_EQ(spec.curve, CurveKind::kCubicC2);
  EXPECT_EQ(spec.quadrature.mode, IntegrationMode::kThesis);
  EXPECT_FALSE(spec.quadrature.split_at_cell_edges);  // thesis default: no splitting
  EXPECT_EQ(spec.quadrature.gauss_points, 7);
  EXPECT_TRUE(spec.quadrature.scale_eq_6_15);
  EXPECT_FALSE(spec.redistribute_lost_load);
  EXPECT_EQ(spec.min_node_mass_fraction, 0.25);
  EXPECT_EQ(spec.interval, LoadInterval::kMaterial);
  const BoundaryLoadSpec traction = parse(R"({"loads": [{"type": "traction",
      "apply_on": "detected_boundary", "traction": [1.5, -2], "curve": "catmull_rom",
      "split_at_cell_edges": false}]})");
  EXPECT_EQ(traction.traction, Vec2(1.5, -2.0));
  EXPECT_EQ(traction.faces, LoadedFaces::kAll);
  EXPECT_EQ(traction.curve, CurveKind::kCatmullRom);
  EXPECT_FALSE(traction.quadrature.split_at_cell_edges);
}

TEST(BoundaryLoadInput, BadInputNamesTheJsonPointer) {
  const std::string head = R"({"loads": [{"apply_on": "detected_boundary", )";
  EXPECT_EQ(
      error_of(head +
               R"("type": "vertical_pressure", "pressure": 1, "x_range": [0, 1], "colour": 3}]})")
          .rfind("case.json: /loads/0/colour: unknown key", 0),
      0u);
  EXPECT_NE(error_of(head + R"("type": "vertical_pressure", "pressure": -1, "x_range": [0, 1]}]})")
                .find("/loads/0/pressure: must be >= 0"),
            std::string::npos);
  EXPECT_NE(error_of(head + R"("type": "vertical_pressure", "pressure": 1}]})")
                .find("missing key \"x_range\""),
            std::string::npos);
  EXPECT_NE(error_of(head + R"("type": "vertical_pressure", "pressure": 1, "x_range": [2, 1]}]})")
                .find("/loads/0/x_range: must be [x0, x1]"),
            std::string::npos);
  EXPECT_NE(error_of(head + R"("type": "traction", "traction": [1, 2],
                                "min_node_mass_fraction": 1}]})")
                .find("/loads/0/min_node_mass_fraction: must be in [0, 1)"),
            std::string::npos);
  EXPECT_NE(error_of(head + R"("type": "traction", "traction": [1, 2], "gauss_points": 0}]})")
                .find("/loads/0/gauss_points"),
            std::string::npos);
  EXPECT_NE(error_of(head + R"("type": "traction", "traction": [1, 2], "curve": "spline"}]})")
                .find("/loads/0/curve"),
            std::string::npos);
  EXPECT_NE(error_of(head + R"("type": "traction", "traction": [1, 2], "pressure": 3}]})")
                .find("/loads/0/pressure"),
            std::string::npos);
  EXPECT_NE(
      error_of(
          R"({"loads": [{"apply_on": "grid_top_nodes", "type": "traction", "traction": [1, 2]}]})")
          .find("/loads/0/apply_on"),
      std::string::npos);
  EXPECT_NE(error_of(head + R"("type": "follower_pressure", "pressure": 1, "scale_eq_6_15": 1}]})")
                .find("/loads/0/scale_eq_6_15"),
            std::string::npos);
}

}  // namespace
}  // namespace pfm::boundary

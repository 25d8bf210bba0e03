// The conforming placement (body_fill.hpp): the points' volumes add up to the polygon's area and
// their first moment to its first moment, exactly, for convex and concave polygons at any angle
// to the grid; on a rectangle whose edges lie on cell lines it is the equal placement, bit for
// bit.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "mpm/step/body_fill.hpp"

namespace pfm {
namespace {

Case one_body(const nlohmann::json& shape, const std::string& placement, int n) {
  nlohmann::json j = nlohmann::json::parse(R"({
    "grid": {"origin": [0, 0], "cell_size": 0.25, "n_cells": [40, 40]},
    "materials": [{"name": "soil", "model": "linear_elastic", "youngs_modulus": 1000.0,
                   "poisson_ratio": 0.3, "unit_weight": 20.0}],
    "bodies": [{"name": "b", "material": "soil"}],
    "time": {"end_time": 1.0}
  })");
  j["bodies"][0].update(shape);
  j["bodies"][0]["placement"] = placement;
  j["bodies"][0]["points_per_cell"] = n;
  return parse_case(j, "fill");
}

std::vector<Vec2> turned_square(double angle_degrees, double half, const Vec2& centre) {
  const double a = angle_degrees * std::numbers::pi / 180.0;
  std::vector<Vec2> corners;
  for (const Vec2& c : {Vec2(-1, -1), Vec2(1, -1), Vec2(1, 1), Vec2(-1, 1)}) {
    corners.push_back(centre + half * Vec2(c.x() * std::cos(a) - c.y() * std::sin(a),
                                           c.x() * std::sin(a) + c.y() * std::cos(a)));
  }
  return corners;
}

TEST(BodyFill, ConformingPointsCarryThePolygonsAreaAndFirstMoment) {
  std::vector<std::vector<Vec2>> shapes;
  for (const double angle : {7.0, 20.0, 33.0, 45.0})
    shapes.push_back(turned_square(angle, 2.3, Vec2(5.1, 4.9)));
  // Concave: an L with a slanted notch.
  shapes.push_back({Vec2(1.1, 1.05), Vec2(8.3, 1.4), Vec2(8.0, 3.3), Vec2(4.45, 3.1),
                    Vec2(3.9, 8.7), Vec2(1.3, 8.1)});
  for (const auto& polygon : shapes) {
    nlohmann::json vertices = nlohmann::json::array();
    for (const Vec2& v : polygon) vertices.push_back({v.x(), v.y()});
    for (const int n : {1, 2, 3}) {
      const Case c = one_body({{"polygon", vertices}}, "conforming", n);
      const Particles p = fill_bodies(c);
      double volume = 0.0;
      Vec2 moment = Vec2::Zero();
      // No sliver: every point holds at least a quarter of a sub-square (a cell whose only part
      // is smaller gives it to a neighbouring cell's part).
      const double h = c.grid.cell_size, quarter = 0.25 * h * h / (n * n);
      for (std::size_t k = 0; k < p.size(); ++k) {
        volume += p.volume[k];
        moment += p.volume[k] * p.position[k];
        EXPECT_GE(p.volume[k], quarter * (1.0 - 1e-12)) << k;
      }
      const std::vector<Vec2>& body = c.bodies[0].polygon;
      double area = 0.0;
      Vec2 first = Vec2::Zero();
      for (std::size_t k = 0; k < body.size(); ++k) {
        const Vec2& a = body[k];
        const Vec2& b = body[(k + 1) % body.size()];
        const double twice = a.x() * b.y() - b.x() * a.y();
        area += 0.5 * twice;
        first += twice / 6.0 * (a + b);
      }
      EXPECT_NEAR(volume, area, 1e-12 * area) << "n = " << n;
      EXPECT_NEAR(moment.x(), first.x(), 1e-11 * std::abs(first.x())) << "n = " << n;
      EXPECT_NEAR(moment.y(), first.y(), 1e-11 * std::abs(first.y())) << "n = " << n;
      // The equal placement misses the area by the staircase of whole sub-squares.
      const Particles equal = fill_bodies(one_body({{"polygon", vertices}}, "equal", n));
      double equal_volume = 0.0;
      for (const double v : equal.volume) equal_volume += v;
      std::printf("n = %d: conforming area error %.1e, equal %.1e (of %.3f m^2)\n", n,
                  volume / area - 1.0, equal_volume / area - 1.0, area);
    }
  }
}

TEST(BodyFill, ConformingIsEqualOnAGridAlignedRectangle) {
  const nlohmann::json rectangle = {{"rectangle", {{1.0, 0.5}, {7.5, 4.25}}}};
  for (const int n : {1, 2, 3}) {
    const Particles a = fill_bodies(one_body(rectangle, "conforming", n));
    const Particles b = fill_bodies(one_body(rectangle, "equal", n));
    ASSERT_EQ(a.size(), b.size());
    for (std::size_t k = 0; k < a.size(); ++k) {
      EXPECT_EQ(a.position[k], b.position[k]);
      EXPECT_EQ(a.volume[k], b.volume[k]);
    }
  }
}

}  // namespace
}  // namespace pfm

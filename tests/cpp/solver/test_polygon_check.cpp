// The case reader's polygon check (polygon_self_intersects, a Shamos-Hoey sweep) against the
// plain test of every pair of edges (with the same segment test, polygon.hpp), on polygons made to
// be degenerate: small integer coordinates (vertices on edges, collinear overlaps, vertical and
// horizontal edges, touching corners), star-shaped simple polygons, and the same with one vertex
// moved.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "mpm/core/polygon.hpp"
#include "mpm/step/case.hpp"

namespace pfm {
namespace {

/// Every pair of edges: the oracle (quadratic).
bool every_pair(const std::vector<Vec2>& polygon) {
  const std::size_t n = polygon.size();
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) {
      if (polygon[i] == polygon[j]) return true;
      if (j == i + 1 || (i == 0 && j == n - 1)) continue;
      if (segments_intersect(polygon[i], polygon[(i + 1) % n], polygon[j], polygon[(j + 1) % n]))
        return true;
    }
  }
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2& a = polygon[(i + n - 1) % n];
    const Vec2& b = polygon[i];
    const Vec2& c = polygon[(i + 1) % n];
    if (orient(a, b, c) == 0.0 && (a - b).dot(c - b) > 0.0) return true;
  }
  return false;
}

TEST(PolygonCheck, SweepAgreesWithEveryPairOnDegeneratePolygons) {
  std::mt19937_64 random(2026);
  int simple = 0, not_simple = 0;
  for (int trial = 0; trial < 200000; ++trial) {
    const int n = 3 + static_cast<int>(random() % 10);
    const int span = 2 + static_cast<int>(random() % 5);  // coordinates 0..span
    std::vector<Vec2> polygon;
    for (int k = 0; k < n; ++k) {
      polygon.emplace_back(static_cast<double>(random() % (span + 1)),
                           static_cast<double>(random() % (span + 1)));
    }
    const bool expected = every_pair(polygon);
    ASSERT_EQ(polygon_self_intersects(polygon), expected) << "trial " << trial;
    (expected ? not_simple : simple) += 1;
  }
  EXPECT_GT(simple, 1000);  // both outcomes are exercised
  EXPECT_GT(not_simple, 1000);
}

TEST(PolygonCheck, SweepAgreesWithEveryPairOnStarsAndMovedVertices) {
  std::mt19937_64 random(7);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  int simple = 0, not_simple = 0;
  for (int trial = 0; trial < 3000; ++trial) {
    const int n = 3 + static_cast<int>(random() % 200);
    std::vector<double> angles(static_cast<std::size_t>(n));
    for (double& a : angles) a = 2.0 * std::numbers::pi * unit(random);
    std::sort(angles.begin(), angles.end());
    std::vector<Vec2> polygon;
    for (const double a : angles) {
      const double r = 0.2 + unit(random);
      polygon.emplace_back(r * std::cos(a), r * std::sin(a));
    }
    if (trial % 2 == 1) polygon[random() % polygon.size()] = Vec2(unit(random), unit(random));
    const bool expected = every_pair(polygon);
    ASSERT_EQ(polygon_self_intersects(polygon), expected) << "trial " << trial;
    (expected ? not_simple : simple) += 1;
  }
  EXPECT_GT(simple, 1000);
  EXPECT_GT(not_simple, 300);
}

TEST(PolygonCheck, ALargeSimplePolygonAndOneCrossingInIt) {
  // 60,000 vertices on a wavy circle (the case file that took 43 s to validate).
  const int n = 60000;
  std::vector<Vec2> polygon;
  for (int k = 0; k < n; ++k) {
    const double a = 2.0 * std::numbers::pi * k / n;
    const double r = 10.0 + 0.5 * std::sin(40.0 * a);
    polygon.emplace_back(r * std::cos(a), r * std::sin(a));
  }
  EXPECT_FALSE(polygon_self_intersects(polygon));
  std::swap(polygon[100], polygon[30000]);  // two long edges across the disk
  EXPECT_TRUE(polygon_self_intersects(polygon));
}

}  // namespace
}  // namespace pfm

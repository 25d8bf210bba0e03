// Marching squares: exact vertex lists on small fields, orientation, open chains on the field
// edge, saddle rules, tie handling, canonical order and bad input.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <stdexcept>

#include "mpm/detect/marching_squares.hpp"

namespace pfm {
namespace {

NodalField make_field(int n_x, int n_y, double spacing, std::vector<double> values) {
  NodalField f;
  f.origin = Vec2::Zero();
  f.spacing = spacing;
  f.n_x = n_x;
  f.n_y = n_y;
  f.values = std::move(values);
  return f;
}

double signed_area(const Contour& c) {
  double a = 0.0;
  for (std::size_t k = 0; k < c.points.size(); ++k) {
    const Vec2& p = c.points[k];
    const Vec2& q = c.points[(k + 1) % c.points.size()];
    a += p.x() * q.y() - q.x() * p.y();
  }
  return 0.5 * a;
}

TEST(MarchingSquares, SingleMaterialNodeGivesCounterClockwiseDiamond) {
  // 3 x 3 nodes, centre node 1, others 0, level 0.5: crossings half way along the 4 edges.
  const auto f = make_field(3, 3, 1.0, {0, 0, 0, 0, 1, 0, 0, 0, 0});
  const auto b = marching_squares(f, 0.5);
  ASSERT_EQ(b.contours.size(), 1u);
  const auto& c = b.contours[0];
  EXPECT_TRUE(c.closed);
  const std::vector<Vec2> expected = {Vec2(1.0, 0.5), Vec2(1.5, 1.0), Vec2(1.0, 1.5),
                                      Vec2(0.5, 1.0)};
  ASSERT_EQ(c.points.size(), expected.size());
  for (std::size_t k = 0; k < expected.size(); ++k) {
    EXPECT_EQ(c.points[k], expected[k]) << k;
  }
  EXPECT_DOUBLE_EQ(signed_area(c), 0.5);  // counter-clockwise: material on the left
}

TEST(MarchingSquares, SingleVoidNodeGivesClockwiseHole) {
  const auto f = make_field(3, 3, 1.0, {1, 1, 1, 1, 0, 1, 1, 1, 1});
  const auto b = marching_squares(f, 0.5);
  // Material touches the field edge everywhere but no contour runs along it: only the hole.
  ASSERT_EQ(b.contours.size(), 1u);
  EXPECT_TRUE(b.contours[0].closed);
  EXPECT_DOUBLE_EQ(signed_area(b.contours[0]), -0.5);
  EXPECT_EQ(b.contours[0].points[0], Vec2(1.0, 0.5));
}

TEST(MarchingSquares, MaterialOnTheFieldEdgeGivesOpenChainEndingOnTheEdge) {
  // Lower row material: a straight open chain at y = 0.5 running right to left (material below
  // is on the left when walking in -x).
  const auto f = make_field(3, 2, 1.0, {1, 1, 1, 0, 0, 0});
  const auto b = marching_squares(f, 0.5);
  ASSERT_EQ(b.contours.size(), 1u);
  const auto& c = b.contours[0];
  EXPECT_FALSE(c.closed);
  ASSERT_EQ(c.points.size(), 3u);
  EXPECT_EQ(c.points.front(), Vec2(2.0, 0.5));
  EXPECT_EQ(c.points.back(), Vec2(0.0, 0.5));
}

TEST(MarchingSquares, SaddleRulesJoinOrSeparateTheDiagonal) {
  // Corners 0 and 2 material. Strong material values: the asymptotic decider joins them (one
  // contour piece cuts off each void corner); weak values separate them.
  const auto strong = make_field(2, 2, 1.0, {1.0, -0.2, -0.2, 1.0});
  const auto weak = make_field(2, 2, 1.0, {0.2, -1.0, -1.0, 0.2});
  for (const auto rule : {SaddleRule::kAsymptoticDecider, SaddleRule::kCentreSample}) {
    const auto joined = marching_squares(strong, 0.0, rule);
    ASSERT_EQ(joined.contours.size(), 2u);
    // The chain cutting off void corner (1, 0) runs from the bottom edge to the right edge.
    const auto& first = joined.contours[0];
    EXPECT_FALSE(first.closed);
    EXPECT_DOUBLE_EQ(first.points.front().y(), 0.0);
    EXPECT_DOUBLE_EQ(first.points.back().x(), 1.0);
    const auto separated = marching_squares(weak, 0.0, rule);
    ASSERT_EQ(separated.contours.size(), 2u);
    // The chain cutting off material corner (0, 0) runs from the bottom edge to the left edge.
    EXPECT_DOUBLE_EQ(separated.contours[0].points.front().y(), 0.0);
    EXPECT_DOUBLE_EQ(separated.contours[0].points.back().x(), 0.0);
  }
  // The exact sample overrides the corner mean for kCentreSample.
  const auto forced = marching_squares(strong, 0.0, SaddleRule::kCentreSample, {},
                                       [](const Vec2&) { return -1.0; });
  EXPECT_DOUBLE_EQ(forced.contours[0].points.back().x(), 0.0);
}

TEST(MarchingSquares, ValueEqualToLevelIsOutsideAndCrossingLandsOnTheNode) {
  const auto f = make_field(3, 3, 1.0, {0, 0, 0, 0, 1, 0.5, 0, 0, 0});
  const auto b = marching_squares(f, 0.5);
  ASSERT_EQ(b.contours.size(), 1u);
  bool on_node = false;
  for (const auto& p : b.contours[0].points) on_node = on_node || p == Vec2(2.0, 1.0);
  EXPECT_TRUE(on_node);
}

TEST(MarchingSquares, CircleAreaConvergesAndEdgeRefinerIsUsed) {
  // Signed distance field of a circle of radius 1: the polygon through the exact crossings is
  // inscribed, its area error below the inscribed-polygon bound.
  const int n = 41;
  const double h = 3.0 / (n - 1);
  NodalField f;
  f.origin = Vec2(-1.5, -1.5);
  f.spacing = h;
  f.n_x = f.n_y = n;
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) f.values.push_back(1.0 - (f.origin + Vec2(i, j) * h).norm());
  }
  const auto exact_crossing = [](const Vec2& a, double, const Vec2& b, double) {
    // Root of 1 - |x| on the segment a-b.
    const Vec2 d = b - a;
    const double qa = d.squaredNorm(), qb = 2 * a.dot(d), qc = a.squaredNorm() - 1.0;
    const double disc = std::sqrt(qb * qb - 4 * qa * qc);
    double t = (-qb + disc) / (2 * qa);
    if (t < 0 || t > 1) t = (-qb - disc) / (2 * qa);
    return Vec2(a + t * d);
  };
  const auto b = marching_squares(f, 0.0, SaddleRule::kAsymptoticDecider, exact_crossing);
  ASSERT_EQ(b.contours.size(), 1u);
  double max_radius_error = 0.0;
  for (const auto& p : b.contours[0].points) {
    max_radius_error = std::max(max_radius_error, std::abs(p.norm() - 1.0));
  }
  EXPECT_LT(max_radius_error, 1e-12);
  const double area = signed_area(b.contours[0]);
  EXPECT_GT(area, 0.0);
  EXPECT_LT(std::numbers::pi - area, 0.02);
  EXPECT_GT(std::numbers::pi - area, 0.0);  // inscribed polygon
}

TEST(MarchingSquares, OutputOrderIsCanonicalAndDeterministic) {
  // Two blobs: the lower one comes first; each closed loop starts at its lowest-leftmost point.
  std::vector<double> v(6 * 6, 0.0);
  v[4 * 6 + 1] = 1.0;  // upper-left blob
  v[1 * 6 + 4] = 1.0;  // lower-right blob
  const auto f = make_field(6, 6, 1.0, v);
  const auto b1 = marching_squares(f, 0.5);
  const auto b2 = marching_squares(f, 0.5);
  ASSERT_EQ(b1.contours.size(), 2u);
  EXPECT_LT(b1.contours[0].points[0].y(), b1.contours[1].points[0].y());
  for (std::size_t c = 0; c < 2; ++c) {
    ASSERT_EQ(b1.contours[c].points.size(), b2.contours[c].points.size());
    for (std::size_t k = 0; k < b1.contours[c].points.size(); ++k) {
      EXPECT_EQ(b1.contours[c].points[k], b2.contours[c].points[k]);
    }
    for (const auto& p : b1.contours[c].points) {
      EXPECT_LE(b1.contours[c].points[0].y(), p.y());
    }
  }
}

TEST(MarchingSquares, NarrowBandOnALargeFieldGivesTheFullFieldsContours) {
  // A checkerboard of 20 x 20 nodes (every edge between them crossed: about two crossings per
  // cell, where the band's edge table starts with room for one) on a 200 x 200 field: given
  // only the block's cells, marching_squares_cells takes its sparse edge table, which has to
  // grow, and must give the contours of the whole field, point for point.
  const int n = 200, lo = 90, hi = 110;
  std::vector<double> v(static_cast<std::size_t>(n) * n, 0.0);
  for (int j = lo; j < hi; ++j)
    for (int i = lo; i < hi; ++i) v[static_cast<std::size_t>(j) * n + i] = (i + j) % 2 ? 1.0 : 0.2;
  const auto f = make_field(n, n, 1.0, v);
  std::vector<int> cells;
  for (int j = lo - 1; j < hi; ++j)
    for (int i = lo - 1; i < hi; ++i) cells.push_back(j * (n - 1) + i);
  const auto node_value = [&f](int i, int j) {
    return f.values[static_cast<std::size_t>(j) * f.n_x + i];
  };
  const DetectedBoundary whole = marching_squares(f, 0.5);
  const DetectedBoundary band = marching_squares_cells(f, node_value, cells, 0.5);
  ASSERT_GT(whole.contours.size(), 100u);  // one diamond per material node, joined at saddles
  ASSERT_EQ(band.contours.size(), whole.contours.size());
  for (std::size_t c = 0; c < whole.contours.size(); ++c) {
    EXPECT_EQ(band.contours[c].closed, whole.contours[c].closed);
    EXPECT_EQ(band.contours[c].points, whole.contours[c].points) << "contour " << c;
  }
}

TEST(MarchingSquares, RejectsMalformedFields) {
  EXPECT_THROW(marching_squares(make_field(1, 3, 1.0, {0, 0, 0}), 0.5), std::invalid_argument);
  EXPECT_THROW(marching_squares(make_field(2, 2, 1.0, {0, 0, 0}), 0.5), std::invalid_argument);
  EXPECT_THROW(marching_squares(make_field(2, 2, 0.0, {0, 0, 0, 0}), 0.5), std::invalid_argument);
  EXPECT_THROW(marching_squares(make_field(2, 2, 1.0, {0, NAN, 0, 0}), 0.5), std::invalid_argument);
}

}  // namespace
}  // namespace pfm

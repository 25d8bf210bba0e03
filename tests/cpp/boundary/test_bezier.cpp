// Composite Bezier curves (thesis 4.1): interpolation, continuity, the C2 system against a
// dense solve, splitting, grid crossings and clipping.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <numbers>
#include <random>

#include "mpm/boundary/bezier.hpp"
#include "mpm/boundary/gauss_quadrature.hpp"
#include "mpm/boundary/tridiagonal.hpp"

namespace pfm::boundary {
namespace {

// A wobbly closed loop (counter-clockwise) and an open polyline with uneven spacing.
Contour wobbly_loop(int n) {
  Contour c;
  c.closed = true;
  for (int k = 0; k < n; ++k) {
    const double a = 2.0 * std::numbers::pi * k / n;
    const double r = 2.0 + 0.4 * std::sin(3.0 * a) + 0.1 * std::cos(7.0 * a);
    c.points.emplace_back(0.3 + r * std::cos(a), 0.7 + r * std::sin(a));
  }
  return c;
}
Contour open_line() {
  Contour c;
  c.closed = false;
  c.points = {Vec2(0.0, 0.0), Vec2(0.7, 0.4), Vec2(1.1, 1.3), Vec2(2.4, 1.0),
              Vec2(3.0, 2.2), Vec2(3.1, 3.0), Vec2(4.5, 2.9)};
  return c;
}

double relative(const Vec2& a, const Vec2& b, double scale) {
  return (a - b).norm() / scale;
}

TEST(Bezier, EveryKindPassesThroughTheEdgePointsAndClosedCurvesClose) {
  for (const Contour& contour : {wobbly_loop(11), open_line()}) {
    for (CurveKind kind :
         {CurveKind::kLinear, CurveKind::kQuadratic, CurveKind::kCubicC2, CurveKind::kCatmullRom}) {
      const CompositeBezier curve = make_composite_bezier(contour, kind);
      const int n = static_cast<int>(contour.points.size());
      ASSERT_EQ(curve.n_segments(), contour.closed ? n : n - 1);
      for (int j = 0; j < curve.n_segments(); ++j) {
        EXPECT_EQ(curve.segments[j].point(0.0), contour.points[j]);
        EXPECT_EQ(curve.segments[j].point(1.0), contour.points[(j + 1) % n]);
      }
      if (contour.closed) {
        EXPECT_EQ(curve.segments.back().end(), curve.segments.front().start());
      }
    }
  }
}

TEST(Bezier, CubicIsC2AtEveryJointIncludingTheClosure) {
  for (const Contour& contour : {wobbly_loop(9), wobbly_loop(3), open_line()}) {
    const CompositeBezier curve = make_composite_bezier(contour, CurveKind::kCubicC2);
    const int m = curve.n_segments();
    double scale1 = 0.0, scale2 = 0.0;
    for (const auto& s : curve.segments) {
      scale1 = std::max({scale1, s.derivative(0.0).norm(), s.derivative(1.0).norm()});
      scale2 = std::max({scale2, s.second_derivative(0.0).norm(), s.second_derivative(1.0).norm()});
    }
    const int joints = contour.closed ? m : m - 1;
    for (int j = 0; j < joints; ++j) {
      const auto& a = curve.segments[j];
      const auto& b = curve.segments[(j + 1) % m];
      EXPECT_LE(relative(a.derivative(1.0), b.derivative(0.0), scale1), 1e-10) << "joint " << j;
      EXPECT_LE(relative(a.second_derivative(1.0), b.second_derivative(0.0), scale2), 1e-10)
          << "joint " << j;
    }
  }
}

TEST(Bezier, CatmullRomIsC1) {
  const CompositeBezier curve = make_composite_bezier(wobbly_loop(10), CurveKind::kCatmullRom);
  for (int j = 0; j < curve.n_segments(); ++j) {
    const auto& a = curve.segments[j];
    const auto& b = curve.segments[(j + 1) % curve.n_segments()];
    EXPECT_LE(relative(a.derivative(1.0), b.derivative(0.0), a.derivative(1.0).norm()), 1e-14);
  }
}

TEST(Bezier, QuadraticReproducesAParabolaSampledAtUniformSteps) {
  auto parabola = [](double s) { return Vec2(0.3 + 0.8 * s, 1.0 - 0.5 * s + 0.21 * s * s); };
  Contour c;
  c.closed = false;
  for (int k = 0; k <= 6; ++k) c.points.push_back(parabola(k));
  const CompositeBezier curve = make_composite_bezier(c, CurveKind::kQuadratic);
  for (int j = 0; j < curve.n_segments(); ++j) {
    for (double t : {0.1, 0.37, 0.5, 0.9}) {
      EXPECT_LE((curve.segments[j].point(t) - parabola(j + t)).norm(), 1e-13);
    }
  }
}

// The full 2m x 2m system of thesis eq. 4.3 with eq. 4.4 (C2 line corrected, see bezier.hpp)
// or eq. 4.5, solved densely.
std::vector<Vec2> dense_middle_points(const std::vector<Vec2>& p, bool closed) {
  const int n = static_cast<int>(p.size());
  const int m = closed ? n : n - 1;
  auto P = [&](int j) { return p[j % n]; };
  Eigen::MatrixXd a = Eigen::MatrixXd::Zero(2 * m, 2 * m);
  Eigen::MatrixXd rhs = Eigen::MatrixXd::Zero(2 * m, 2);
  int row = 0;
  auto Q = [](int i) { return i - 1; };             // thesis Q_i -> column
  for (int i = 2; i <= 2 * m - 2; i += 2, ++row) {  // eq. 4.3, C1
    a(row, Q(i)) = 1.0;
    a(row, Q(i + 1)) = 1.0;
    rhs.row(row) = 2.0 * P(i / 2).transpose();
  }
  for (int i = 1; i <= 2 * m - 3; i += 2, ++row) {  // eq. 4.3, C2
    a(row, Q(i)) = 1.0;
    a(row, Q(i + 1)) = -2.0;
    a(row, Q(i + 2)) = 2.0;
    a(row, Q(i + 3)) = -1.0;
  }
  if (closed) {  // eq. 4.4
    a(row, Q(1)) = 1.0;
    a(row, Q(2 * m)) = 1.0;
    rhs.row(row++) = 2.0 * P(0).transpose();
    a(row, Q(2 * m - 1)) = 1.0;
    a(row, Q(2 * m)) = -2.0;
    a(row, Q(1)) = 2.0;
    a(row, Q(2)) = -1.0;
    ++row;
  } else {  // eq. 4.5
    a(row, Q(1)) = 1.0;
    rhs.row(row++) = (0.75 * P(0) + 0.25 * P(1)).transpose();
    a(row, Q(2 * m)) = 1.0;
    rhs.row(row++) = (0.75 * P(m) + 0.25 * P(m - 1)).transpose();
  }
  EXPECT_EQ(row, 2 * m);
  const Eigen::MatrixXd q = a.fullPivLu().solve(rhs);
  std::vector<Vec2> out(2 * m);
  for (int k = 0; k < 2 * m; ++k) out[k] = q.row(k).transpose();
  return out;
}

TEST(Bezier, C2MiddlePointsMatchADenseSolveOfEq43) {
  for (const Contour& contour :
       {wobbly_loop(3), wobbly_loop(4), wobbly_loop(17), open_line(), open_line()}) {
    for (int trim : {0, 3, 4}) {
      std::vector<Vec2> points = contour.points;
      if (!contour.closed) points.resize(points.size() - trim);  // m = 6, 3, 2 segments
      const auto fast = c2_middle_points(points, contour.closed);
      const auto dense = dense_middle_points(points, contour.closed);
      ASSERT_EQ(fast.size(), dense.size());
      for (std::size_t k = 0; k < fast.size(); ++k) {
        EXPECT_LE((fast[k] - dense[k]).norm() / dense[k].norm(), 1e-12) << k;
      }
    }
  }
}

TEST(Tridiagonal, ThomasAndShermanMorrisonMatchDenseSolves) {
  std::mt19937_64 generator(5);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int n : {3, 4, 7, 40}) {
    std::vector<double> lower(n), diag(n), upper(n);
    std::vector<Vec2> rhs(n);
    for (int i = 0; i < n; ++i) {
      lower[i] = u(generator);
      upper[i] = u(generator);
      diag[i] = 3.0 + u(generator);
      rhs[i] = Vec2(u(generator), u(generator));
    }
    Eigen::MatrixXd plain = Eigen::MatrixXd::Zero(n, n), b(n, 2);
    for (int i = 0; i < n; ++i) {
      plain(i, i) = diag[i];
      if (i > 0) plain(i, i - 1) = lower[i];
      if (i + 1 < n) plain(i, i + 1) = upper[i];
      b.row(i) = rhs[i].transpose();
    }
    Eigen::MatrixXd cyclic = plain;
    cyclic(0, n - 1) = lower[0];
    cyclic(n - 1, 0) = upper[n - 1];
    const Eigen::MatrixXd x_plain = plain.fullPivLu().solve(b);
    const Eigen::MatrixXd x_cyclic = cyclic.fullPivLu().solve(b);
    const auto thomas = solve_tridiagonal(lower, diag, upper, rhs);
    const auto sherman = solve_cyclic_tridiagonal(lower, diag, upper, rhs);
    for (int i = 0; i < n; ++i) {
      EXPECT_LE((thomas[i] - x_plain.row(i).transpose()).norm(), 1e-12 * x_plain.norm());
      EXPECT_LE((sherman[i] - x_cyclic.row(i).transpose()).norm(), 1e-12 * x_cyclic.norm());
    }
  }
}

BezierSegment sample_cubic() {
  return BezierSegment::cubic(Vec2(0.2, 0.1), Vec2(3.1, 2.9), Vec2(-1.2, 2.4), Vec2(2.6, 0.3));
}

TEST(Bezier, SplitHalvesTraceTheSameCurve) {
  const BezierSegment s = sample_cubic();
  for (double t : {0.13, 0.5, 0.81}) {
    const auto [left, right] = s.split(t);
    for (double u : {0.0, 0.2, 0.7, 1.0}) {
      EXPECT_LE((left.point(u) - s.point(t * u)).norm(), 1e-14);
      EXPECT_LE((right.point(u) - s.point(t + (1.0 - t) * u)).norm(), 1e-14);
      EXPECT_LE((left.derivative(u) - t * s.derivative(t * u)).norm(), 1e-13);
    }
    const BezierSegment middle = s.sub_segment(0.5 * t, t);
    EXPECT_LE((middle.point(0.3) - s.point(0.5 * t + 0.3 * (0.5 * t))).norm(), 1e-14);
  }
}

TEST(Bezier, DerivativeMatchesFiniteDifferencesAndNormalIsOutward) {
  const BezierSegment s = sample_cubic();
  const double h = 1e-6;
  for (double t : {0.1, 0.45, 0.9}) {
    const Vec2 fd = (s.point(t + h) - s.point(t - h)) / (2.0 * h);
    EXPECT_LE((s.derivative(t) - fd).norm(), 1e-8);
    const Vec2 fd2 = (s.derivative(t + h) - s.derivative(t - h)) / (2.0 * h);
    EXPECT_LE((s.second_derivative(t) - fd2).norm(), 1e-7);
  }
  // Counter-clockwise loop around the origin: the outward normal points away from the centre.
  const CompositeBezier loop = make_composite_bezier(wobbly_loop(12), CurveKind::kCubicC2);
  for (const auto& segment : loop.segments) {
    const Vec2 x = segment.point(0.5) - Vec2(0.3, 0.7);
    EXPECT_GT(segment.outward_normal(0.5).dot(x), 0.0);
    EXPECT_NEAR(segment.outward_normal(0.5).norm(), 1.0, 1e-15);
  }
}

TEST(Bezier, ArcLengthOfAParabolaAndOfAStraightCubic) {
  // y = x^2 on [0, 1]: L = sqrt(5) / 2 + asinh(2) / 4.
  const BezierSegment parabola = BezierSegment::quadratic(Vec2(0, 0), Vec2(0.5, 0), Vec2(1, 1));
  EXPECT_NEAR(parabola.length(), std::sqrt(5.0) / 2.0 + std::asinh(2.0) / 4.0, 1e-14);
  const BezierSegment straight =
      BezierSegment::cubic(Vec2(0, 0), Vec2(0.1, 0.2), Vec2(1.0, 2.0), Vec2(1.5, 3.0));
  EXPECT_NEAR(straight.length(), std::sqrt(1.5 * 1.5 + 9.0), 1e-14);
  EXPECT_TRUE(straight.is_straight());
  EXPECT_FALSE(sample_cubic().is_straight());
}

TEST(Bezier, CoordinateCrossingsAreRootsIncludingTouchingAndConstantCases) {
  // x(t) = 0.5 + 3 (t - 1/3)(t - 1/2)(t - 3/4) ... built from control points of a cubic whose
  // x has three crossings of x = 0.5.
  auto from_power = [](double c0, double c1, double c2, double c3) {
    // Power basis -> Bezier control values.
    const double p0 = c0, p1 = c0 + c1 / 3.0, p2 = c0 + 2.0 * c1 / 3.0 + c2 / 3.0,
                 p3 = c0 + c1 + c2 + c3;
    return std::array<double, 4>{p0, p1, p2, p3};
  };
  const double r1 = 1.0 / 3.0, r2 = 0.5, r3 = 0.75;
  // 3 (t - r1)(t - r2)(t - r3) expanded, plus 0.5.
  const double c3 = 3.0, c2 = -3.0 * (r1 + r2 + r3), c1 = 3.0 * (r1 * r2 + r1 * r3 + r2 * r3),
               c0 = 0.5 - 3.0 * r1 * r2 * r3;
  const auto x = from_power(c0, c1, c2, c3);
  const BezierSegment s =
      BezierSegment::cubic(Vec2(x[0], 0), Vec2(x[1], 1), Vec2(x[2], 2), Vec2(x[3], 3));
  std::vector<double> roots;
  coordinate_crossings(s, 0, 0.5, roots);
  ASSERT_EQ(roots.size(), 3u);
  EXPECT_NEAR(roots[0], r1, 1e-15);
  EXPECT_NEAR(roots[1], r2, 1e-15);
  EXPECT_NEAR(roots[2], r3, 1e-15);
  // Touching a line at the vertex of a parabola: one root, the vertex.
  roots.clear();
  const BezierSegment touch = BezierSegment::quadratic(Vec2(0, 1), Vec2(0.5, -1), Vec2(1, 1));
  coordinate_crossings(touch, 1, 0.0, roots);
  ASSERT_EQ(roots.size(), 1u);
  EXPECT_NEAR(roots[0], 0.5, 1e-15);
  // A coordinate constant along the segment gives no crossings.
  roots.clear();
  coordinate_crossings(BezierSegment::line(Vec2(0, 2), Vec2(3, 2)), 1, 2.0, roots);
  EXPECT_TRUE(roots.empty());
}

TEST(Bezier, GridSplitPiecesLieInOneCellAndCoverTheCurve) {
  Grid grid;
  grid.origin = Vec2(-2.0, -1.0);
  grid.cell_size = 0.5;
  grid.n_cells_x = grid.n_cells_y = 20;
  const BezierSegment s = sample_cubic();
  std::vector<double> breaks;
  grid_crossing_parameters(s, grid, 0.0, 1.0, breaks);
  ASSERT_GE(breaks.size(), 10u);
  EXPECT_EQ(breaks.front(), 0.0);
  EXPECT_EQ(breaks.back(), 1.0);
  for (std::size_t p = 0; p + 1 < breaks.size(); ++p) {
    const Vec2 mid = s.point(0.5 * (breaks[p] + breaks[p + 1]));
    const Vec2 lower = grid.node_position(grid.cell_i(mid.x()), grid.cell_j(mid.y()));
    for (int q = 0; q <= 20; ++q) {  // samples of the piece stay in the midpoint's cell
      const Vec2 x = s.point(breaks[p] + (breaks[p + 1] - breaks[p]) * q / 20.0);
      EXPECT_GE(x.x() - lower.x(), -1e-12);
      EXPECT_LE(x.x() - lower.x(), grid.cell_size + 1e-12);
      EXPECT_GE(x.y() - lower.y(), -1e-12);
      EXPECT_LE(x.y() - lower.y(), grid.cell_size + 1e-12);
    }
  }
  EXPECT_EQ(split_at_grid_lines(s, grid).size(), breaks.size() - 1);
}

TEST(Bezier, ClipToXIntervalKeepsExactlyThePartsInside) {
  const BezierSegment s = sample_cubic();
  const auto parts = clip_to_x_interval(s, 0.5, 1.5);
  ASSERT_FALSE(parts.empty());
  for (const auto& part : parts) {
    for (int q = 0; q <= 20; ++q) {
      const double x = part.point(q / 20.0).x();
      EXPECT_GE(x, 0.5 - 1e-13);
      EXPECT_LE(x, 1.5 + 1e-13);
    }
  }
  // Each part ends on x = 0.5 or x = 1.5 or at an end of s, and the gaps between parts
  // (and before the first, after the last) lie outside the interval.
  const auto ranges = x_interval_parameters(s, 0.5, 1.5);
  ASSERT_EQ(ranges.size(), parts.size());
  double previous_end = 0.0;
  for (const auto& [t0, t1] : ranges) {
    for (double t : {t0, t1}) {
      const double x = s.point(t).x();
      const bool on_bound = std::abs(x - 0.5) < 1e-14 || std::abs(x - 1.5) < 1e-14;
      EXPECT_TRUE(on_bound || t == 0.0 || t == 1.0) << t;
    }
    if (t0 > previous_end) {
      const double x = s.point(0.5 * (previous_end + t0)).x();
      EXPECT_TRUE(x < 0.5 || x > 1.5);
    }
    previous_end = t1;
  }
  if (previous_end < 1.0) {
    const double x = s.point(0.5 * (previous_end + 1.0)).x();
    EXPECT_TRUE(x < 0.5 || x > 1.5);
  }
}

TEST(Gauss, RulesIntegratePolynomialsOfDegree2kMinus1Exactly) {
  for (int k = 1; k <= kMaxGaussPoints; ++k) {
    const GaussRule rule = gauss_legendre(k);
    for (int degree = 0; degree <= 2 * k - 1; ++degree) {
      double sum = 0.0;
      for (int q = 0; q < k; ++q) sum += rule.weight[q] * std::pow(rule.node[q], degree);
      const double exact = degree % 2 == 1 ? 0.0 : 2.0 / (degree + 1);
      EXPECT_NEAR(sum, exact, 1e-14) << "k " << k << " degree " << degree;
    }
  }
  // Table 6.1 of the thesis (k = 5).
  const GaussRule five = gauss_legendre(5);
  EXPECT_NEAR(five.weight[2], 128.0 / 225.0, 1e-15);
  EXPECT_NEAR(five.node[4], std::sqrt(5.0 + 2.0 * std::sqrt(10.0 / 7.0)) / 3.0, 1e-15);
  EXPECT_NEAR(five.weight[4], (322.0 - 13.0 * std::sqrt(70.0)) / 900.0, 1e-15);
}

}  // namespace
}  // namespace pfm::boundary

// Shape functions: partition of unity, zero gradient sum, exact reproduction of linear fields,
// for linear grid functions, uGIMP, the edge-modified B-splines and the isoparametric Q4; the
// B-splines also against the closed-form uniform splines, their continuity, and the critical
// time step their lumped masses allow.
#include <gtest/gtest.h>

#include <Eigen/Eigenvalues>
#include <random>
#include <vector>

#include "mpm/core/shape_functions.hpp"

namespace pfm {
namespace {

Grid test_grid() {
  Grid g;
  g.origin = Vec2(-1.0, 2.0);
  g.cell_size = 0.5;
  g.n_cells_x = 10;
  g.n_cells_y = 8;
  return g;
}

// Sum of N, sum of grad N, and sum of N * x_node for the linear field reproduction test.
void check_stencil(const Grid& grid, const ShapeStencil& s, const Vec2& x) {
  double sum = 0.0;
  Vec2 gradient_sum = Vec2::Zero();
  Vec2 reproduced = Vec2::Zero();
  Mat2 gradient_of_position = Mat2::Zero();  // sum of x_node (x) grad N = identity
  for (int b = 0; b < s.width; ++b) {
    for (int a = 0; a < s.width; ++a) {
      const int k = b * s.width + a;
      const Vec2 node = grid.node_position(s.base_i + a, s.base_j + b);
      sum += s.value[k];
      gradient_sum += s.gradient[k];
      reproduced += s.value[k] * node;
      gradient_of_position += node * s.gradient[k].transpose();
      EXPECT_GE(s.value[k], -1e-15);
    }
  }
  EXPECT_NEAR(sum, 1.0, 1e-14);
  EXPECT_NEAR(gradient_sum.norm(), 0.0, 1e-12);
  EXPECT_NEAR((reproduced - x).norm(), 0.0, 1e-13);
  EXPECT_NEAR((gradient_of_position - Mat2::Identity()).norm(), 0.0, 1e-12);
}

TEST(ShapeFunctions, LinearPartitionOfUnityAtRandomPoints) {
  const Grid grid = test_grid();
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> ux(-1.0, 4.0 - 1e-9), uy(2.0, 6.0 - 1e-9);
  for (int n = 0; n < 2000; ++n) {
    const Vec2 x(ux(rng), uy(rng));
    check_stencil(grid, linear_stencil(grid, x), x);
  }
}

TEST(ShapeFunctions, GimpPartitionOfUnityAtRandomPoints) {
  const Grid grid = test_grid();
  std::mt19937_64 rng(11);
  // Stay one cell away from the grid edge, as the solver guarantees.
  std::uniform_real_distribution<double> ux(-0.5, 3.5), uy(2.5, 5.5);
  for (const double lp : {0.125, 0.0625, 0.25}) {
    for (int n = 0; n < 2000; ++n) {
      const Vec2 x(ux(rng), uy(rng));
      check_stencil(grid, gimp_stencil(grid, x, Vec2(lp, lp)), x);
    }
  }
}

TEST(ShapeFunctions, GimpDerivativeMatchesFiniteDifference) {
  const double h = 0.5, lp = 0.125, step = 1e-7;
  for (double d = -0.7; d <= 0.7; d += 0.01) {
    double dd, unused;
    gimp_1d(d, h, lp, dd);
    const double fd =
        (gimp_1d(d + step, h, lp, unused) - gimp_1d(d - step, h, lp, unused)) / (2 * step);
    EXPECT_NEAR(dd, fd, 1e-6) << "d = " << d;
  }
}

TEST(ShapeFunctions, GimpEqualsLinearAwayFromNodesForVanishingParticle) {
  // With lp -> 0 uGIMP tends to the linear functions.
  const Grid grid = test_grid();
  const Vec2 x(0.37, 3.81);
  const ShapeStencil lin = linear_stencil(grid, x);
  const ShapeStencil gimp = gimp_stencil(grid, x, Vec2(1e-9, 1e-9));
  for (int b = 0; b < 2; ++b) {
    for (int a = 0; a < 2; ++a) {
      const int gi = lin.base_i + a - gimp.base_i, gj = lin.base_j + b - gimp.base_j;
      EXPECT_NEAR(lin.value[b * 2 + a], gimp.value[gj * 3 + gi], 1e-8);
    }
  }
}

TEST(ShapeFunctions, BsplinePartitionOfUnityAndLinearFieldsOverTheWholeGrid) {
  // Edges included: the edge modification keeps every property (a support on the grid edge).
  const Grid grid = test_grid();
  std::mt19937_64 rng(13);
  std::uniform_real_distribution<double> ux(-1.0, 4.0 - 1e-9), uy(2.0, 6.0 - 1e-9);
  for (const int degree : {2, 3}) {
    for (int n = 0; n < 4000; ++n) {
      const Vec2 x(ux(rng), uy(rng));
      const ShapeStencil s = bspline_stencil(grid, degree, x);
      ASSERT_EQ(s.width, degree + 1);
      ASSERT_GE(s.base_i, 0);
      ASSERT_LE(s.base_i + degree, grid.n_cells_x);
      ASSERT_GE(s.base_j, 0);
      ASSERT_LE(s.base_j + degree, grid.n_cells_y);
      check_stencil(grid, s, x);
    }
  }
}

// The uniform B-splines in closed form (r = distance to the node in cells).
double uniform_bspline(int degree, double r) {
  r = std::abs(r);
  if (degree == 2) return r < 0.5 ? 0.75 - r * r : r < 1.5 ? 0.5 * (1.5 - r) * (1.5 - r) : 0.0;
  return r < 1.0   ? 2.0 / 3.0 - r * r + 0.5 * r * r * r
         : r < 2.0 ? (2.0 - r) * (2.0 - r) * (2.0 - r) / 6.0
                   : 0.0;
}

TEST(ShapeFunctions, BsplineIsTheUniformSplineAwayFromTheEdges) {
  // Nodes 2 .. n - 2 carry the unmodified uniform spline; the edge modification reaches
  // the functions of nodes 0 and 1 (n and n - 1) only.
  const int n = 12;
  for (const int degree : {2, 3}) {
    for (double u = 0.0; u < n; u += 0.0137) {
      double value[4], derivative[4];
      const int base = bspline_1d(degree, n, u, value, derivative);
      for (int a = 0; a <= degree; ++a) {
        const int node = base + a;
        if (node < 2 || node > n - 2) continue;
        EXPECT_NEAR(value[a], uniform_bspline(degree, u - node), 1e-14)
            << "degree " << degree << " u " << u << " node " << node;
      }
    }
  }
}

TEST(ShapeFunctions, BsplineDerivativesAndContinuity) {
  // The derivative matches a central difference everywhere but at the knots, and values and
  // derivatives are continuous across every knot (C1): checked at both sides of each.
  const int n = 7;
  auto node_value = [&](int degree, double u, int node, double* d) {
    double value[4], derivative[4];
    const int base = bspline_1d(degree, n, u, value, derivative);
    const int a = node - base;
    *d = a >= 0 && a <= degree ? derivative[a] : 0.0;
    return a >= 0 && a <= degree ? value[a] : 0.0;
  };
  for (const int degree : {2, 3}) {
    for (int node = 0; node <= n; ++node) {
      for (double u = 0.003; u < n - 0.003; u += 0.0191) {
        const double eps = 1e-6;
        double d, unused;
        node_value(degree, u, node, &d);
        const double fd = (node_value(degree, u + eps, node, &unused) -
                           node_value(degree, u - eps, node, &unused)) /
                          (2 * eps);
        EXPECT_NEAR(d, fd, 1e-6) << degree << " " << node << " " << u;
      }
      for (int k = 0; k <= n; ++k) {
        const double knot = degree == 2 ? k + 0.5 : k;
        if (knot <= 0.0 || knot >= n) continue;
        double d_left, d_right;
        const double left = node_value(degree, knot - 1e-12, node, &d_left);
        const double right = node_value(degree, knot, node, &d_right);
        EXPECT_NEAR(left, right, 1e-11);
        EXPECT_NEAR(d_left, d_right, 1e-10) << degree << " node " << node << " knot " << knot;
      }
    }
  }
}

TEST(ShapeFunctions, BsplineEdgeNodeAloneOnTheEdge) {
  // On a grid edge only the edge node's function is nonzero: a velocity fixed there holds on
  // the whole edge.
  for (const int degree : {2, 3}) {
    for (const int n : {degree, 9}) {
      double value[4], derivative[4];
      int base = bspline_1d(degree, n, 0.0, value, derivative);
      EXPECT_EQ(base, 0);
      EXPECT_EQ(value[0], 1.0);
      for (int a = 1; a <= degree; ++a) EXPECT_EQ(value[a], 0.0);
      base = bspline_1d(degree, n, n, value, derivative);
      EXPECT_EQ(base, n - degree);
      EXPECT_NEAR(value[degree], 1.0, 1e-15);
      for (int a = 0; a < degree; ++a) EXPECT_NEAR(value[a], 0.0, 1e-15);
    }
  }
}

// Largest frequency of the 1D lumped-mass wave equation on n cells (E = rho = h = 1), its
// stiffness and masses integrated exactly (a 6-point Gauss rule on every half cell, where the
// functions are polynomials), as the ratio of its stable time step 2 / omega to h / c.
// Degree 1: the linear (hat) functions.
double lumped_time_step_ratio(int degree, int n) {
  const double g[3] = {0.2386191860831969, 0.6612093864662645, 0.9324695142031521};
  const double w[3] = {0.4679139345726910, 0.3607615730481386, 0.1713244923791704};
  Eigen::MatrixXd stiffness = Eigen::MatrixXd::Zero(n + 1, n + 1);
  Eigen::VectorXd mass = Eigen::VectorXd::Zero(n + 1);
  for (int half = 0; half < 2 * n; ++half) {
    for (int q = 0; q < 6; ++q) {
      const double u = 0.5 * half + 0.25 + 0.25 * (q < 3 ? -g[q] : g[q - 3]);
      const double weight = 0.25 * w[q % 3];
      double value[4] = {1.0 - (u - std::floor(u)), u - std::floor(u)}, derivative[4] = {-1, 1};
      const int base = degree == 1 ? static_cast<int>(std::floor(u))
                                   : bspline_1d(degree, n, u, value, derivative);
      for (int a = 0; a <= degree; ++a) {
        mass(base + a) += weight * value[a];
        for (int b = 0; b <= degree; ++b) {
          stiffness(base + a, base + b) += weight * derivative[a] * derivative[b];
        }
      }
    }
  }
  const Eigen::VectorXd scale = mass.cwiseSqrt().cwiseInverse();
  const Eigen::MatrixXd a = scale.asDiagonal() * stiffness * scale.asDiagonal();
  const double omega =
      std::sqrt(Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd>(a).eigenvalues().maxCoeff());
  return 2.0 / omega;
}

TEST(ShapeFunctions, BsplineCriticalTimeStepIsAboveTheLinearOne) {
  // Linear functions: exactly h / c (the solver's limit). The B-splines allow more on every
  // grid, edges included, so h / c_p is a safe limit for them too (the header's figures).
  EXPECT_NEAR(lumped_time_step_ratio(1, 16), 1.0, 1e-12);
  for (const int degree : {2, 3}) {
    for (int n = degree; n <= 16; ++n) EXPECT_GE(lumped_time_step_ratio(degree, n), 1.2);
  }
  EXPECT_NEAR(lumped_time_step_ratio(2, 16), 1.311, 1e-3);
  EXPECT_NEAR(lumped_time_step_ratio(3, 16), 1.441, 1e-3);
}

TEST(ShapeFunctions, Q4PartitionOfUnityAndIsoparametricMap) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int n = 0; n < 500; ++n) {
    const double xi = u(rng), eta = u(rng);
    const Eigen::Vector4d values = q4_values(xi, eta);
    const Eigen::Matrix<double, 4, 2> grads = q4_natural_gradients(xi, eta);
    EXPECT_NEAR(values.sum(), 1.0, 1e-15);
    EXPECT_NEAR(grads.colwise().sum().norm(), 0.0, 1e-15);
    // The reference square maps onto itself: sum N_k xi_k = xi, sum dN_k/dxi xi_k = 1.
    const Eigen::Vector4d node_xi(-1, 1, 1, -1), node_eta(-1, -1, 1, 1);
    EXPECT_NEAR(values.dot(node_xi), xi, 1e-15);
    EXPECT_NEAR(values.dot(node_eta), eta, 1e-15);
    EXPECT_NEAR(grads.col(0).dot(node_xi), 1.0, 1e-15);
    EXPECT_NEAR(grads.col(1).dot(node_xi), 0.0, 1e-15);
  }
}

}  // namespace
}  // namespace pfm

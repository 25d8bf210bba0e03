// Shape functions: partition of unity, zero gradient sum, exact reproduction of linear fields,
// for linear grid functions, uGIMP and the isoparametric Q4.
#include <gtest/gtest.h>

#include <random>

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

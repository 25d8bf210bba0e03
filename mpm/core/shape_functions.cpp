#include "mpm/core/shape_functions.hpp"

#include <cmath>

namespace pfm {

double gimp_1d(double d, double h, double lp, double& derivative) {
  const double r = std::abs(d);
  const double sign = d < 0.0 ? -1.0 : 1.0;
  if (r < lp) {
    derivative = -d / (h * lp);
    return 1.0 - (d * d + lp * lp) / (2.0 * h * lp);
  }
  if (r < h - lp) {
    derivative = -sign / h;
    return 1.0 - r / h;
  }
  if (r < h + lp) {
    const double s = h + lp - r;
    derivative = -sign * s / (2.0 * h * lp);
    return s * s / (4.0 * h * lp);
  }
  derivative = 0.0;
  return 0.0;
}

ShapeStencil linear_stencil(const Grid& grid, const Vec2& x) {
  ShapeStencil s;
  s.width = 2;
  const double h = grid.cell_size;
  s.base_i = grid.cell_i(x.x());
  s.base_j = grid.cell_j(x.y());
  const double xi = (x.x() - grid.origin.x()) / h - s.base_i;  // in [0, 1)
  const double eta = (x.y() - grid.origin.y()) / h - s.base_j;
  const double nx[2] = {1.0 - xi, xi};
  const double ny[2] = {1.0 - eta, eta};
  const double dx[2] = {-1.0 / h, 1.0 / h};
  for (int b = 0; b < 2; ++b) {
    for (int a = 0; a < 2; ++a) {
      s.value[b * 2 + a] = nx[a] * ny[b];
      s.gradient[b * 2 + a] = Vec2(dx[a] * ny[b], nx[a] * dx[b]);
    }
  }
  return s;
}

ShapeStencil gimp_stencil(const Grid& grid, const Vec2& x, const Vec2& half_length) {
  ShapeStencil s;
  s.width = 3;
  const double h = grid.cell_size;
  const int ci = grid.cell_i(x.x());
  const int cj = grid.cell_j(x.y());
  const double xi = (x.x() - grid.origin.x()) / h - ci;
  const double eta = (x.y() - grid.origin.y()) / h - cj;
  // With lp <= h/2 a particle reaches at most 3 nodes per direction: the cell's two nodes and
  // the neighbour on the side of the cell centre the particle is closest to.
  s.base_i = xi < 0.5 ? ci - 1 : ci;
  s.base_j = eta < 0.5 ? cj - 1 : cj;
  double nx[3], ny[3], dx[3], dy[3];
  for (int a = 0; a < 3; ++a) {
    const double node_x = grid.origin.x() + (s.base_i + a) * h;
    const double node_y = grid.origin.y() + (s.base_j + a) * h;
    nx[a] = gimp_1d(x.x() - node_x, h, half_length.x(), dx[a]);
    ny[a] = gimp_1d(x.y() - node_y, h, half_length.y(), dy[a]);
  }
  for (int b = 0; b < 3; ++b) {
    for (int a = 0; a < 3; ++a) {
      s.value[b * 3 + a] = nx[a] * ny[b];
      s.gradient[b * 3 + a] = Vec2(dx[a] * ny[b], nx[a] * dy[b]);
    }
  }
  return s;
}

Eigen::Vector4d q4_values(double xi, double eta) {
  return 0.25 * Eigen::Vector4d((1 - xi) * (1 - eta), (1 + xi) * (1 - eta), (1 + xi) * (1 + eta),
                                (1 - xi) * (1 + eta));
}

Eigen::Matrix<double, 4, 2> q4_natural_gradients(double xi, double eta) {
  Eigen::Matrix<double, 4, 2> g;
  g << -(1 - eta), -(1 - xi),  //
      (1 - eta), -(1 + xi),    //
      (1 + eta), (1 + xi),     //
      -(1 + eta), (1 - xi);
  return 0.25 * g;
}

std::array<Vec2, 4> q4_gauss_points_2x2() {
  const double g = 1.0 / std::sqrt(3.0);
  return {Vec2(-g, -g), Vec2(g, -g), Vec2(g, g), Vec2(-g, g)};
}

}  // namespace pfm

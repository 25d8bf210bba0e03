#include "mpm/core/shape_functions.hpp"

#include <algorithm>
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

namespace {

// Knot k of the clamped knot vector of degree p on n cells, in cells: the cell midpoints
// (p even) or the nodes (p odd), the end knots repeated p + 1 times.
double bspline_knot(int p, int n, int k) {
  const double shift = p % 2 == 0 ? p + 0.5 : p;
  return std::clamp(k - shift, 0.0, static_cast<double>(n));
}

}  // namespace

int bspline_1d(int degree, int n_cells, double u, double* value, double* derivative) {
  constexpr int kMaxDegree = 3;
  const int p = degree, n = n_cells;
  // Away from the edges (every node of the stencil in 2 .. n - 2) the functions are the uniform
  // B-splines: their closed forms, cheaper than the recursion below.
  if (p == 2) {
    const int i = static_cast<int>(std::floor(u + 0.5));  // nearest node
    if (i >= 3 && i <= n - 3) {
      const double r = u - i;  // in [-1/2, 1/2)
      value[0] = 0.5 * (0.5 - r) * (0.5 - r);
      value[1] = 0.75 - r * r;
      value[2] = 0.5 * (0.5 + r) * (0.5 + r);
      derivative[0] = r - 0.5;
      derivative[1] = -2.0 * r;
      derivative[2] = r + 0.5;
      return i - 1;
    }
  } else if (p == 3) {
    const int c = static_cast<int>(std::floor(u));  // cell
    if (c >= 3 && c <= n - 4) {
      const double t = u - c, s = 1.0 - t;  // t in [0, 1)
      value[0] = s * s * s / 6.0;
      value[1] = (3.0 * t * t * t - 6.0 * t * t + 4.0) / 6.0;
      value[2] = (3.0 * s * s * s - 6.0 * s * s + 4.0) / 6.0;
      value[3] = t * t * t / 6.0;
      derivative[0] = -0.5 * s * s;
      derivative[1] = t * (1.5 * t - 2.0);
      derivative[2] = -s * (1.5 * s - 2.0);
      derivative[3] = 0.5 * t * t;
      return c - 1;
    }
  }
  // Knot span s (t_s <= u < t_{s+1}); the B-splines nonzero on it are B_{s-p} .. B_s.
  const double shift = p % 2 == 0 ? p + 0.5 : p;
  const int s = std::clamp(static_cast<int>(std::floor(u + shift)), p, n + 2);
  // Cox-de Boor on the span (values of degree p - 1 kept for the derivatives).
  double left[kMaxDegree + 1], right[kMaxDegree + 1];
  double b[kMaxDegree + 1] = {1.0}, lower[kMaxDegree + 1] = {1.0};
  for (int j = 1; j <= p; ++j) {
    left[j] = u - bspline_knot(p, n, s + 1 - j);
    right[j] = bspline_knot(p, n, s + j) - u;
    double saved = 0.0;
    for (int r = 0; r < j; ++r) {
      const double temp = b[r] / (right[r + 1] + left[j - r]);
      b[r] = saved + right[r + 1] * temp;
      saved = left[j - r] * temp;
    }
    b[j] = saved;
    if (j == p - 1) std::copy(b, b + p, lower);
  }
  // d B_i / du = p (B_{i,p-1} / (t_{i+p} - t_i) - B_{i+1,p-1} / (t_{i+p+1} - t_{i+1})).
  double db[kMaxDegree + 1];
  for (int r = 0; r <= p; ++r) {
    const int i = s - p + r;
    const double a = r > 0 ? lower[r - 1] : 0.0, c = r < p ? lower[r] : 0.0;
    const double da = bspline_knot(p, n, i + p) - bspline_knot(p, n, i);
    const double dc = bspline_knot(p, n, i + p + 1) - bspline_knot(p, n, i + 1);
    db[r] = p * ((da > 0.0 ? a / da : 0.0) - (dc > 0.0 ? c / dc : 0.0));
  }
  // B-splines to nodes: B_{k+1} to node k, B_0 to node 0, B_{n+2} to node n, and B_1 (B_{n+1})
  // shared by nodes 0 and 1 (n and n - 1) by its Greville abscissa g.
  double g = 0.0;
  for (int k = 2; k <= p + 1; ++k) g += bspline_knot(p, n, k);
  g /= p;
  const int base = std::clamp(s - p - 1, 0, n - p);
  std::fill(value, value + p + 1, 0.0);
  std::fill(derivative, derivative + p + 1, 0.0);
  auto add = [&](int node, double weight, int r) {
    value[node - base] += weight * b[r];
    derivative[node - base] += weight * db[r];
  };
  for (int r = 0; r <= p; ++r) {
    const int i = s - p + r;
    if (i == 1) {
      add(0, 1.0 - g, r);
      add(1, g, r);
    } else if (i == n + 1) {
      add(n, 1.0 - g, r);
      add(n - 1, g, r);
    } else {
      add(std::clamp(i - 1, 0, n), 1.0, r);
    }
  }
  return base;
}

ShapeStencil bspline_stencil(const Grid& grid, int degree, const Vec2& x) {
  ShapeStencil s;
  s.width = degree + 1;
  const double h = grid.cell_size;
  double nx[4], ny[4], dx[4], dy[4];
  s.base_i = bspline_1d(degree, grid.n_cells_x, (x.x() - grid.origin.x()) / h, nx, dx);
  s.base_j = bspline_1d(degree, grid.n_cells_y, (x.y() - grid.origin.y()) / h, ny, dy);
  for (int b = 0; b < s.width; ++b) {
    for (int a = 0; a < s.width; ++a) {
      s.value[b * s.width + a] = nx[a] * ny[b];
      s.gradient[b * s.width + a] = Vec2(dx[a] * ny[b], nx[a] * dy[b]) / h;
    }
  }
  return s;
}

ShapeStencil stencil(ShapeFunctionKind kind, const Grid& grid, const Vec2& x,
                     const Vec2& half_length) {
  switch (kind) {
    case ShapeFunctionKind::kLinear:
      return linear_stencil(grid, x);
    case ShapeFunctionKind::kGimp:
      return gimp_stencil(grid, x, half_length);
    default:
      return bspline_stencil(grid, shape_degree(kind), x);
  }
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

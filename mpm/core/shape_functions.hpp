// Shape functions shared by the MPM and the updated-Lagrangian FEM.
//
// * Grid (MPM) functions: linear (bilinear on a square cell, thesis 3.2), uGIMP
//   (Bardenhagen & Kober 2004) with the particle half-length fixed at its initial value, and
//   quadratic and cubic B-splines (Steffen, Kirby & Berzins 2008) modified at the grid's edges
//   (below). A particle's functions are returned as a small stencil of nodes (2x2 linear,
//   3x3 GIMP and quadratic B-splines, 4x4 cubic B-splines).
// * B-splines of degree p on a line of n cells, u = (x - x0) / h in [0, n]. Inside the grid a
//   node's function is the uniform B-spline centred on it (knots at the cell midpoints for
//   p = 2, at the nodes for p = 3; support 3h and 4h). At each grid edge the knot vector is
//   clamped (the end knot repeated p + 1 times), which gives n + 3 B-splines B_0 .. B_{n+2}
//   for the n + 1 nodes: node k (1 <= k <= n - 1) takes B_{k+1}, and the extra spline B_1
//   (B_{n+1} at the far edge) is shared between the edge node and its neighbour in the ratio
//   of its Greville abscissa g = (t_2 + ... + t_{p+1}) / p (1/4 for p = 2, 1/3 for p = 3):
//   node 0 takes B_0 + (1 - g) B_1, node 1 takes g B_1 + B_2. The functions then are
//   non-negative, a partition of unity, reproduce linear fields exactly (the nodal values of
//   x give x) and are C1 inside the grid; at an edge only the edge node's function is nonzero,
//   so a velocity fixed on the edge nodes holds on the whole edge. The grid edge can therefore
//   be a support, as with linear functions, and no margin of cells is needed.
// * Critical time step (MpmSolver): h / c_p for all four. The largest frequency of the 1D
//   lumped-mass system of the B-splines, edges included, gives 1.31 h / c_p (quadratic) and
//   1.44 h / c_p (cubic) on long lines, and no less than 1.22 h / c_p on the shortest grids
//   allowed (tests/cpp/core/test_shape_functions.cpp), so h / c_p is on the safe side.
// * Nodes with almost no material under them keep no unknown of their own with B-splines by
//   default: they are tied to inner nodes (extended B-splines, mpm/core/basis_extension.hpp).
// * Isoparametric 4-node quadrilateral functions in natural coordinates (xi, eta) in [-1, 1]^2
//   for the FEM, node order counter-clockwise from (-1, -1).
#pragma once

#include <array>

#include "mpm/core/grid.hpp"

namespace pfm {

enum class ShapeFunctionKind { kLinear, kGimp, kQuadraticBspline, kCubicBspline };

/// Nodes per direction that a particle's functions reach.
constexpr int stencil_width(ShapeFunctionKind kind) {
  return kind == ShapeFunctionKind::kLinear ? 2 : kind == ShapeFunctionKind::kCubicBspline ? 4 : 3;
}

/// Polynomial degree of the grid functions along a line (1 for linear and for uGIMP, whose
/// functions at a point of the boundary, where the traction acts, are the linear ones).
constexpr int shape_degree(ShapeFunctionKind kind) {
  return kind == ShapeFunctionKind::kQuadraticBspline ? 2
         : kind == ShapeFunctionKind::kCubicBspline   ? 3
                                                      : 1;
}

/// Nodes a particle reaches and the values and gradients of their functions at the particle.
/// Stencil node (a, b), a, b in [0, width), is grid node (base_i + a, base_j + b) and is
/// stored at index b * width + a. Entries past width * width are unused.
struct ShapeStencil {
  int base_i = 0;
  int base_j = 0;
  int width = 2;
  std::array<double, 16> value{};
  std::array<Vec2, 16> gradient{};  ///< 1/m
};

/// 1D uGIMP function of a node at signed distance d = x_p - x_node, cell h, half-length lp.
/// Requires 0 < lp <= h / 2. Returns the value; writes the derivative d S / d x_p.
double gimp_1d(double d, double h, double lp, double& derivative);

/// Linear functions of the cell containing x. The caller guarantees grid.contains(x).
ShapeStencil linear_stencil(const Grid& grid, const Vec2& x);

/// uGIMP functions for a particle of half-lengths half_length (m, each <= h / 2) at x.
/// The caller guarantees that x lies in the grid and at least one cell away from its edge
/// in any direction in which the particle domain reaches over a cell edge.
ShapeStencil gimp_stencil(const Grid& grid, const Vec2& x, const Vec2& half_length);

/// The edge-modified B-splines of degree 2 or 3 (header comment) of the nodes of a line of
/// n_cells >= degree cells at u = (x - x0) / h in [0, n_cells]. Writes the values and the
/// derivatives d/du of the degree + 1 nodes base .. base + degree and returns base.
int bspline_1d(int degree, int n_cells, double u, double* value, double* derivative);

/// B-spline functions of degree 2 or 3 at x; the caller guarantees grid.contains(x) and at
/// least `degree` cells along each axis.
ShapeStencil bspline_stencil(const Grid& grid, int degree, const Vec2& x);

/// The functions of `kind` at x (half_length is used by uGIMP alone).
ShapeStencil stencil(ShapeFunctionKind kind, const Grid& grid, const Vec2& x,
                     const Vec2& half_length);

/// Isoparametric Q4: values at natural coordinates (xi, eta).
Eigen::Vector4d q4_values(double xi, double eta);
/// Isoparametric Q4: derivatives, row k = (dN_k/dxi, dN_k/deta).
Eigen::Matrix<double, 4, 2> q4_natural_gradients(double xi, double eta);
/// Natural coordinates of the 2x2 Gauss points, counter-clockwise from (-1, -1).
std::array<Vec2, 4> q4_gauss_points_2x2();

}  // namespace pfm

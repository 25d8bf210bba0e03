// Shape functions shared by the MPM and the updated-Lagrangian FEM.
//
// * Grid (MPM) functions: linear (bilinear on a square cell, thesis 3.2) and uGIMP
//   (Bardenhagen & Kober 2004) with the particle half-length fixed at its initial value.
//   A particle's functions are returned as a small stencil of nodes (2x2 linear, 3x3 GIMP).
// * Isoparametric 4-node quadrilateral functions in natural coordinates (xi, eta) in [-1, 1]^2
//   for the FEM, node order counter-clockwise from (-1, -1).
#pragma once

#include <array>

#include "mpm/core/grid.hpp"

namespace pfm {

enum class ShapeFunctionKind { kLinear, kGimp };

/// Nodes a particle reaches and the values and gradients of their functions at the particle.
/// Stencil node (a, b), a, b in [0, width), is grid node (base_i + a, base_j + b) and is
/// stored at index b * width + a. Entries past width * width are unused.
struct ShapeStencil {
  int base_i = 0;
  int base_j = 0;
  int width = 2;
  std::array<double, 9> value{};
  std::array<Vec2, 9> gradient{};  ///< 1/m
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

inline ShapeStencil stencil(ShapeFunctionKind kind, const Grid& grid, const Vec2& x,
                            const Vec2& half_length) {
  return kind == ShapeFunctionKind::kLinear ? linear_stencil(grid, x)
                                            : gimp_stencil(grid, x, half_length);
}

/// Isoparametric Q4: values at natural coordinates (xi, eta).
Eigen::Vector4d q4_values(double xi, double eta);
/// Isoparametric Q4: derivatives, row k = (dN_k/dxi, dN_k/deta).
Eigen::Matrix<double, 4, 2> q4_natural_gradients(double xi, double eta);
/// Natural coordinates of the 2x2 Gauss points, counter-clockwise from (-1, -1).
std::array<Vec2, 4> q4_gauss_points_2x2();

}  // namespace pfm

// Structured background grid of square 4-node cells (thesis 3.2, 5 intro).
//
// Nodes are numbered row by row: node (i, j) has index j * n_nodes_x() + i, with i along x.
// Cell (i, j) spans [x0 + i h, x0 + (i + 1) h] x [y0 + j h, y0 + (j + 1) h].
#pragma once

#include <cmath>

#include "mpm/core/types.hpp"

namespace pfm {

struct Grid {
  Vec2 origin = Vec2::Zero();  ///< lower-left corner, m
  double cell_size = 1.0;      ///< h, m
  int n_cells_x = 1;
  int n_cells_y = 1;

  int n_nodes_x() const { return n_cells_x + 1; }
  int n_nodes_y() const { return n_cells_y + 1; }
  int n_nodes() const { return n_nodes_x() * n_nodes_y(); }
  int n_cells() const { return n_cells_x * n_cells_y; }
  int node_index(int i, int j) const { return j * n_nodes_x() + i; }
  int cell_index(int i, int j) const { return j * n_cells_x + i; }
  Vec2 node_position(int i, int j) const {
    return origin + Vec2(static_cast<double>(i) * cell_size, static_cast<double>(j) * cell_size);
  }
  Vec2 upper_corner() const { return origin + Vec2(n_cells_x * cell_size, n_cells_y * cell_size); }
  /// Cell column containing x (may be outside [0, n_cells_x) for points off the grid).
  int cell_i(double x) const { return static_cast<int>(std::floor((x - origin.x()) / cell_size)); }
  int cell_j(double y) const { return static_cast<int>(std::floor((y - origin.y()) / cell_size)); }
  /// True when x lies in the closed-open box [origin, upper corner).
  bool contains(const Vec2& x) const {
    const int i = cell_i(x.x()), j = cell_j(x.y());
    return i >= 0 && j >= 0 && i < n_cells_x && j < n_cells_y;
  }
};

}  // namespace pfm

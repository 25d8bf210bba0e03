// Loads on the grid-top nodes (loads[].apply_on "grid_top_nodes", the thesis's load path): a
// vertical pressure over a load's x_range on the top of the body as the grid sees it at the
// start, the top edge of each cell column's highest occupied cell. The explicit MPM
// (mpm/solver/mpm_solver.hpp) and the implicit one (mpm/implicit/implicit_solver.hpp) apply
// them alike.
//
// Linear and uGIMP functions: the top nodes' hat integrals over x_range, the consistent nodal
// forces per kPa on the initial top (a top node that the body leaves carries its force on
// nothing, as in the thesis). B-splines: the integrals of N_I along the initial top, on the
// node rows next to it too; with ties (solver.outer_node_fraction > 0, the default) applied on
// each column's top edge as the top layer of points has moved (TopColumn); without, a node too
// light to carry its share (mass <= 0.01 of a full cell's, the detected boundary's rule) passes
// it down its node column, which keeps the resultant and the moment (the rows above the top
// hold little mass at the start and none once the body settles).
#pragma once

#include <utility>
#include <vector>

#include "mpm/core/grid.hpp"
#include "mpm/core/shape_functions.hpp"
#include "mpm/step/case.hpp"
#include "mpm/step/particles.hpp"

namespace pfm {

class GridTopLoads {
 public:
  /// Consistent nodal forces per unit pressure of a load on the initial top surface.
  struct TopNodeLoad {
    std::vector<int> node;
    std::vector<double> vertical_force_per_kpa;  ///< kN per kPa (downwards positive)
  };
  /// A load with B-splines, per loaded cell column: the height of the column's top edge at the
  /// start, the particles whose squares reach it (the top layer), and int N_i dx over the
  /// load's part of the edge for each node column i it reaches (m). The edge moves with the
  /// top layer's mean vertical displacement, and node (i, j) takes -q int N_i dx N_j(y) (the
  /// traction integral on that horizontal edge).
  struct TopColumn {
    double y0 = 0.0;
    std::vector<int> particles;
    std::vector<std::pair<int, double>> x_integral;
  };

  GridTopLoads() = default;
  /// The case's grid_top_nodes loads on the top of `particles` (their start).
  GridTopLoads(const Case& c, const Particles& particles);

  /// Load k's nodal forces at pressure q (kPa), each passed to add(node, force): with B-splines
  /// and `tied`, on the top edges as the top layer of `particles` has moved; else on the top
  /// nodes, where with B-splines a node for which light(node) holds passes its share down its
  /// node column. Nothing for a load that is not on the grid-top nodes.
  template <class Light, class Add>
  void apply(std::size_t k, double q, const Particles& particles, bool tied, Light&& light,
             Add&& add) const;

  /// Per load of the case (empty for one on the detected boundary).
  const std::vector<TopNodeLoad>& top_node_loads() const { return loads_; }
  /// The mass (t) at and below which a node is too light to carry its share: 0.01 of a full
  /// cell's of the densest material.
  double light_node_mass() const { return light_node_mass_; }

 private:
  std::vector<TopColumn> bspline_columns(const LoadSpec& load, const Particles& particles,
                                         const std::vector<char>& occupied) const;
  TopNodeLoad bspline_load(const std::vector<TopColumn>& columns) const;
  /// Calls add(node, f) with f = int N_i dx N_j(y) (m, the force per kPa, downwards) for the
  /// nodes (i, j) that a column's top edge at height y reaches.
  template <class Add>
  void for_each_top_force(const TopColumn& column, double y, Add&& add) const;

  Grid grid_;
  int degree_ = 1;
  std::vector<TopNodeLoad> loads_;
  std::vector<std::vector<TopColumn>> columns_;  ///< per load (B-splines; empty otherwise)
  double light_node_mass_ = 0.0;
};

template <class Add>
void GridTopLoads::for_each_top_force(const TopColumn& column, double y, Add&& add) const {
  const double u = (y - grid_.origin.y()) / grid_.cell_size;
  if (!(u >= 0.0 && u <= grid_.n_cells_y)) return;  // the body has left the grid there
  double value[4], derivative[4];
  const int base = bspline_1d(degree_, grid_.n_cells_y, u, value, derivative);
  for (const auto& [i, integral] : column.x_integral) {
    for (int b = 0; b <= degree_; ++b) {
      if (value[b] != 0.0)
        add(static_cast<std::size_t>(grid_.node_index(i, base + b)), integral * value[b]);
    }
  }
}

template <class Light, class Add>
void GridTopLoads::apply(std::size_t k, double q, const Particles& particles, bool tied,
                         Light&& light, Add&& add) const {
  if (degree_ > 1 && tied) {
    for (const TopColumn& column : columns_[k]) {
      double dy = 0.0;
      for (const int p : column.particles) {
        const auto i = static_cast<std::size_t>(p);
        dy += particles.position[i].y() - particles.reference_position[i].y();
      }
      if (!column.particles.empty()) dy /= static_cast<double>(column.particles.size());
      for_each_top_force(column, column.y0 + dy,
                         [&](std::size_t node, double f) { add(node, Vec2(0.0, -q * f)); });
    }
    return;
  }
  const auto row = static_cast<std::size_t>(grid_.n_nodes_x());
  const TopNodeLoad& top = loads_[k];
  for (std::size_t i = 0; i < top.node.size(); ++i) {
    auto node = static_cast<std::size_t>(top.node[i]);
    if (degree_ > 1) {
      while (light(node) && node >= row) node -= row;
    }
    add(node, Vec2(0.0, -q * top.vertical_force_per_kpa[i]));
  }
}

}  // namespace pfm

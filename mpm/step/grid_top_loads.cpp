#include "mpm/step/grid_top_loads.hpp"

#include <algorithm>
#include <cmath>

#include "mpm/boundary/surface_load.hpp"

namespace pfm {

namespace {

// The node row of cell column c's top edge: the top of its highest occupied cell (-1: none).
int top_edge_row(const Grid& grid, const std::vector<char>& occupied, int c) {
  for (int j = grid.n_cells_y - 1; j >= 0; --j) {
    if (occupied[static_cast<std::size_t>(grid.cell_index(c, j))]) return j + 1;
  }
  return -1;
}

}  // namespace

GridTopLoads::GridTopLoads(const Case& c, const Particles& particles)
    : grid_(c.grid), degree_(shape_degree(c.solver.shape_function)) {
  const Grid& grid = grid_;
  std::vector<char> occupied(static_cast<std::size_t>(grid.n_cells()), 0);
  for (const Vec2& x : particles.position) {
    occupied[static_cast<std::size_t>(grid.cell_index(grid.cell_i(x.x()), grid.cell_j(x.y())))] = 1;
  }
  // Top node of each node column: the highest node that is a top corner of an occupied cell.
  std::vector<int> top(static_cast<std::size_t>(grid.n_nodes_x()), -1);
  for (int i = 0; i < grid.n_nodes_x(); ++i) {
    for (int j = grid.n_cells_y - 1; j >= 0 && top[static_cast<std::size_t>(i)] < 0; --j) {
      for (const int ci : {i - 1, i}) {
        if (ci >= 0 && ci < grid.n_cells_x &&
            occupied[static_cast<std::size_t>(grid.cell_index(ci, j))]) {
          top[static_cast<std::size_t>(i)] = j + 1;
        }
      }
    }
  }
  const double h = grid.cell_size;
  // Too light to carry a load: as for the loads on a detected boundary (surface_load.hpp), a
  // node of mass <= 0.01 of a full cell's.
  light_node_mass_ =
      boundary::BoundaryLoadSpec{}.min_node_mass_fraction * largest_density(particles) * h * h;
  columns_.resize(c.loads.size());
  for (std::size_t k = 0; k < c.loads.size(); ++k) {
    const LoadSpec& load = c.loads[k];
    TopNodeLoad entry;
    if (load.apply_on == LoadTarget::kGridTopNodes && degree_ > 1) {
      columns_[k] = bspline_columns(load, particles, occupied);
      entry = bspline_load(columns_[k]);
    } else if (load.apply_on == LoadTarget::kGridTopNodes) {
      for (int i = 0; i < grid.n_nodes_x(); ++i) {
        if (top[static_cast<std::size_t>(i)] < 0) continue;
        // Integral of the node's hat function over [x0, x1] (consistent nodal force).
        const double xn = grid.origin.x() + i * h;
        double integral = 0.0;
        const double pieces[2][2] = {{xn - h, xn}, {xn, xn + h}};
        for (const auto& piece : pieces) {
          const double a = std::max(piece[0], load.x0), b = std::min(piece[1], load.x1);
          if (b <= a) continue;
          // hat(x) = 1 - |x - xn| / h, integrated exactly (linear on each piece).
          const double ha = 1.0 - std::abs(a - xn) / h, hb = 1.0 - std::abs(b - xn) / h;
          integral += 0.5 * (ha + hb) * (b - a);
        }
        if (integral > 0.0) {
          entry.node.push_back(grid.node_index(i, top[static_cast<std::size_t>(i)]));
          entry.vertical_force_per_kpa.push_back(integral);
        }
      }
    }
    loads_.push_back(std::move(entry));
  }
}

GridTopLoads::TopNodeLoad GridTopLoads::bspline_load(const std::vector<TopColumn>& columns) const {
  // f_I = int N_I t dx along the top of each cell column (TopColumn) at its initial height,
  // t = (0, -1) per kPa, summed per node over the columns, in node order.
  std::vector<double> down(static_cast<std::size_t>(grid_.n_nodes()), 0.0);
  for (const TopColumn& column : columns) {
    for_each_top_force(column, column.y0, [&](std::size_t node, double f) { down[node] += f; });
  }
  TopNodeLoad entry;
  for (std::size_t node = 0; node < down.size(); ++node) {
    if (down[node] == 0.0) continue;
    entry.node.push_back(static_cast<int>(node));
    entry.vertical_force_per_kpa.push_back(down[node]);
  }
  return entry;
}

std::vector<GridTopLoads::TopColumn> GridTopLoads::bspline_columns(
    const LoadSpec& load, const Particles& particles, const std::vector<char>& occupied) const {
  const Grid& grid = grid_;
  const double h = grid.cell_size;
  const int degree = degree_;
  // 4-point Gauss-Legendre on [-1, 1]: exact on the pieces (degree <= 3) between half cells.
  const double xg[4] = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563,
                        0.8611363115940526};
  const double wg[4] = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461,
                        0.3478548451374538};
  std::vector<TopColumn> columns;
  for (int c = 0; c < grid.n_cells_x; ++c) {
    const int top_row = top_edge_row(grid, occupied, c);
    const double left = grid.origin.x() + c * h;
    const double a = std::max(left, load.x0), b = std::min(left + h, load.x1);
    if (top_row < 0 || b <= a) continue;
    TopColumn column;
    column.y0 = grid.origin.y() + top_row * h;
    for (std::size_t p = 0; p < particles.size(); ++p) {
      const Vec2& x = particles.position[p];
      if (grid.cell_i(x.x()) == c && grid.cell_j(x.y()) == top_row - 1 &&
          x.y() + particles.half_length[p].y() >= column.y0 - 1e-9 * h) {
        column.particles.push_back(static_cast<int>(p));
      }
    }
    // int N_i dx over [a, b], the piece split at the cell's midline.
    std::vector<double> integral(static_cast<std::size_t>(grid.n_nodes_x()), 0.0);
    const double mid = left + 0.5 * h;
    for (const auto& [lo, hi] : {std::pair(a, std::min(b, mid)), std::pair(std::max(a, mid), b)}) {
      if (hi <= lo) continue;
      for (int g = 0; g < 4; ++g) {
        const double x = 0.5 * (lo + hi) + 0.5 * (hi - lo) * xg[g];
        double value[4], derivative[4];
        const int base =
            bspline_1d(degree, grid.n_cells_x, (x - grid.origin.x()) / h, value, derivative);
        for (int i = 0; i <= degree; ++i) {
          integral[static_cast<std::size_t>(base + i)] += 0.5 * (hi - lo) * wg[g] * value[i];
        }
      }
    }
    for (int i = 0; i < grid.n_nodes_x(); ++i) {
      if (integral[static_cast<std::size_t>(i)] != 0.0)
        column.x_integral.emplace_back(i, integral[static_cast<std::size_t>(i)]);
    }
    columns.push_back(std::move(column));
  }
  return columns;
}

}  // namespace pfm

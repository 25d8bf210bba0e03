#include "mpm/core/wall_mirror.hpp"

#include <algorithm>
#include <array>
#include <cstdlib>
#include <map>
#include <utility>

namespace pfm {

namespace {

// The 1D function of node `node` at node `at` on a line of n cells (0 outside the window).
double bspline_at_node(int degree, int n_cells, int at, int node) {
  double value[4], derivative[4];
  const int base = bspline_1d(degree, n_cells, static_cast<double>(at), value, derivative);
  const int offset = node - base;
  return offset >= 0 && offset <= degree ? value[offset] : 0.0;
}

// -N_front(x_wall) / N_behind(x_wall) along one axis; 0 if the node behind reaches no point in
// front of the wall.
double mirror_weight(int degree, int n_cells, int wall, int behind, int front) {
  const double n_behind = bspline_at_node(degree, n_cells, wall, behind);
  return n_behind > 0.0 ? -bspline_at_node(degree, n_cells, wall, front) / n_behind : 0.0;
}

}  // namespace

WallMirror::WallMirror(const Grid& grid, ShapeFunctionKind kind,
                       std::span<const unsigned> fixed_at_zero) {
  const int p = shape_degree(kind);
  if (p < 2) return;
  const int nx = grid.n_nodes_x(), ny = grid.n_nodes_y();
  const auto inside = [&](int i, int j) { return i >= 0 && i < nx && j >= 0 && j < ny; };
  const auto fixed_in = [&](int i, int j, int d) {
    const unsigned bit = d == 0 ? kFixX : kFixY;
    return (fixed_at_zero[static_cast<std::size_t>(grid.node_index(i, j))] & bit) != 0;
  };
  // Pass 1: each held component's step (sx, sy) across a wall, straight (one axis) where
  // exactly one direction has the wall node next and a free node after it.
  std::vector<std::array<int, 2>> step(static_cast<std::size_t>(2 * grid.n_nodes()), {0, 0});
  const auto step_of = [&](int i, int j, int d) -> std::array<int, 2>& {
    return step[static_cast<std::size_t>(2 * grid.node_index(i, j) + d)];
  };
  constexpr std::array<std::array<int, 2>, 4> kAxes = {{{1, 0}, {-1, 0}, {0, 1}, {0, -1}}};
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      for (int d = 0; d < 2; ++d) {
        if (!fixed_in(i, j, d)) continue;
        int found = 0;
        for (const auto& [sx, sy] : kAxes) {
          // Behind the wall: the node on I's far side is held too, or beyond the grid (a held
          // region two nodes thick inside the body is a wall on both of its sides).
          const bool behind = !inside(i - sx, j - sy) || fixed_in(i - sx, j - sy, d);
          if (behind && inside(i + 2 * sx, j + 2 * sy) && fixed_in(i + sx, j + sy, d) &&
              !fixed_in(i + 2 * sx, j + 2 * sy, d)) {
            ++found;
            step_of(i, j, d) = {sx, sy};
          }
        }
        if (found != 1) step_of(i, j, d) = {0, 0};
      }
    }
  }
  // Pass 2: behind the inside corner of two walls that both hold d, the image is across both:
  // the node two along each axis is a straight mirror across the other wall.
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      for (int d = 0; d < 2; ++d) {
        if (!fixed_in(i, j, d) || step_of(i, j, d) != std::array<int, 2>{0, 0}) continue;
        int found = 0;
        std::array<int, 2> corner = {0, 0};
        for (const int cx : {1, -1}) {
          for (const int cy : {1, -1}) {
            if (!inside(i + 2 * cx, j + 2 * cy) || fixed_in(i + 2 * cx, j + 2 * cy, d)) continue;
            if (step_of(i + 2 * cx, j, d) == std::array<int, 2>{0, cy} &&
                step_of(i, j + 2 * cy, d) == std::array<int, 2>{cx, 0}) {
              ++found;
              corner = {cx, cy};
            }
          }
        }
        // Marked apart from the straight steps (pass 2 reads those).
        if (found == 1) step_of(i, j, d) = {2 * corner[0], 2 * corner[1]};
      }
    }
  }
  // The images and their sources' weights, along each axis crossed -N_J(x_W) / N_I(x_W).
  std::map<std::pair<int, int>, std::size_t> image_of;  // (node, component) -> images_ index
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      for (int d = 0; d < 2; ++d) {
        auto [sx, sy] = step_of(i, j, d);
        if (sx == 0 && sy == 0) continue;
        if (std::abs(sx) == 2 || std::abs(sy) == 2) {
          sx /= 2;
          sy /= 2;
        }
        const double wx = sx == 0 ? 1.0 : mirror_weight(p, grid.n_cells_x, i + sx, i, i + 2 * sx);
        const double wy = sy == 0 ? 1.0 : mirror_weight(p, grid.n_cells_y, j + sy, j, j + 2 * sy);
        if (wx == 0.0 || wy == 0.0) continue;  // I reaches no point in front of the wall
        const int image = grid.node_index(i + 2 * sx, j + 2 * sy);
        const auto [entry, added] = image_of.try_emplace({image, d}, images_.size());
        if (added) images_.push_back({image, d, {}});
        images_[entry->second].sources.push_back({grid.node_index(i, j), wx * wy});
      }
    }
  }
  scale_.assign(images_.size(), 0.0);
  held_.assign(images_.size(), 0.0);
  if (images_.empty()) return;
  const auto slots = static_cast<std::size_t>(2 * grid.n_nodes());
  image_at_.assign(slots, -1);
  source_at_.assign(slots, -1);
  source_weight_.assign(slots, 0.0);
  for (std::size_t k = 0; k < images_.size(); ++k) {
    const Image& image = images_[k];
    image_at_[static_cast<std::size_t>(2 * image.node + image.component)] = static_cast<int>(k);
    for (const Source& s : image.sources) {
      const auto slot = static_cast<std::size_t>(2 * s.behind + image.component);
      source_at_[slot] = static_cast<int>(k);
      source_weight_[slot] = s.weight;
    }
  }
}

void WallMirror::prepare(std::span<const double> mass, const BasisExtension* ties) {
  for (std::size_t k = 0; k < images_.size(); ++k) {
    const Image& image = images_[k];
    const double m = mass[static_cast<std::size_t>(image.node)];
    double gathered = m;
    for (const Source& s : image.sources) {
      gathered += s.weight * mass[static_cast<std::size_t>(s.behind)];
    }
    const bool outer = ties && ties->tie_of(image.node) >= 0;
    scale_[k] = m > 0.0 && !outer && gathered >= 0.5 * m ? m / gathered : 0.0;
  }
}

void WallMirror::gather(std::span<Vec2> values) const {
  gather_onto(values, false);
}

void WallMirror::hold(std::span<const Vec2> values) {
  for (std::size_t k = 0; k < images_.size(); ++k) {
    held_[k] = values[static_cast<std::size_t>(images_[k].node)][images_[k].component];
  }
}

void WallMirror::gather_added(std::span<Vec2> values) const {
  gather_onto(values, true);
}

void WallMirror::gather_onto(std::span<Vec2> values, bool from_held) const {
  for (std::size_t k = 0; k < images_.size(); ++k) {
    if (!active(k)) continue;
    const Image& image = images_[k];
    const int d = image.component;
    double& x = values[static_cast<std::size_t>(image.node)][d];
    const double base = from_held ? held_[k] : 0.0;
    double added = x - base;
    for (const Source& s : image.sources) {
      double& behind = values[static_cast<std::size_t>(s.behind)][d];
      added += s.weight * behind;
      behind = 0.0;
    }
    x = base + scale_[k] * added;
  }
}

void WallMirror::extrapolate(std::span<Vec2> values) const {
  for (std::size_t k = 0; k < images_.size(); ++k) {
    if (!active(k)) continue;
    const Image& image = images_[k];
    const int d = image.component;
    const double x = values[static_cast<std::size_t>(image.node)][d];
    for (const Source& s : image.sources) {
      values[static_cast<std::size_t>(s.behind)][d] = s.weight * x;
    }
  }
}

}  // namespace pfm

#include "mpm/core/basis_extension.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

namespace pfm {

namespace {

// int N_k du over [0, n] for each node k = 0 .. n of a line of n cells (in cells): 4-point
// Gauss on every half cell, exact for the pieces of degree <= 3 (quadratic B-splines break at
// the cell midpoints, the others at the nodes).
std::vector<double> line_supports(ShapeFunctionKind kind, int n) {
  std::vector<double> s(static_cast<std::size_t>(n) + 1, 0.0);
  const int p = shape_degree(kind);
  if (p == 1) {
    std::fill(s.begin(), s.end(), 1.0);
    s.front() = s.back() = 0.5;
    return s;
  }
  const std::array<double, 4> xg = {-0.8611363115940526, -0.3399810435848563, 0.3399810435848563,
                                    0.8611363115940526};
  const std::array<double, 4> wg = {0.3478548451374538, 0.6521451548625461, 0.6521451548625461,
                                    0.3478548451374538};
  double value[4], derivative[4];
  for (int half = 0; half < 2 * n; ++half) {
    for (int g = 0; g < 4; ++g) {
      const double u = 0.5 * half + 0.25 * (1.0 + xg[static_cast<std::size_t>(g)]);
      const int base = bspline_1d(p, n, u, value, derivative);
      for (int a = 0; a <= p; ++a) {
        s[static_cast<std::size_t>(base + a)] += 0.25 * wg[static_cast<std::size_t>(g)] * value[a];
      }
    }
  }
  return s;
}

// Lagrange weight of index i among lo .. lo + q at the index j.
double lagrange(int lo, int q, int i, int j) {
  double w = 1.0;
  for (int m = lo; m <= lo + q; ++m) {
    if (m != i) w *= static_cast<double>(j - m) / static_cast<double>(i - m);
  }
  return w;
}

// Nodes between j and the index range [lo, lo + q] (0 inside it).
int box_distance(int lo, int q, int j) {
  return std::max({0, lo - j, j - (lo + q)});
}

}  // namespace

void NodeTies::clear() {
  outer.clear();
  start.assign(1, 0);
  inner.clear();
  weight.clear();
}

BasisExtension::BasisExtension(const Grid& grid, ShapeFunctionKind kind, double fraction)
    : grid_(grid), degree_(shape_degree(kind)), fraction_(fraction) {
  support_x_ = line_supports(kind, grid.n_cells_x);
  support_y_ = line_supports(kind, grid.n_cells_y);
  for (double& s : support_x_) s *= grid.cell_size;
  for (double& s : support_y_) s *= grid.cell_size;
  inner_.assign(static_cast<std::size_t>(grid.n_nodes()), 0);
  tie_of_.assign(static_cast<std::size_t>(grid.n_nodes()), -1);
}

double BasisExtension::support(int node) const {
  const int nx = grid_.n_nodes_x();
  return support_x_[static_cast<std::size_t>(node % nx)] *
         support_y_[static_cast<std::size_t>(node / nx)];
}

void BasisExtension::classify(std::span<const double> mass, double density,
                              std::span<const unsigned> fixed, std::span<const Vec2> start,
                              std::span<const Vec2> end) {
  for (const int j : ties_.outer) tie_of_[static_cast<std::size_t>(j)] = -1;
  ties_.clear();
  if (!enabled()) return;
  const int n_nodes = grid_.n_nodes();
  const int nx = grid_.n_nodes_x();
  std::vector<int>& outer = outer_;
  outer.clear();
  for (int node = 0; node < n_nodes; ++node) {
    const double m = mass[static_cast<std::size_t>(node)];
    const bool inner = m >= fraction_ * density * support(node);
    inner_[static_cast<std::size_t>(node)] = inner;
    if (!inner && m > 0.0) outer.push_back(node);
  }
  if (outer.empty()) return;
  // Ties of the highest degree that fits; a tie that would leave an inner node with less than
  // half its own mass (its negative weights) drops a degree, until none does (degree 0 ties
  // have the weight 1 alone).
  degree_cap_.assign(outer.size(), degree_);
  // Each round lowers some cap, none below 0: at most degree_ + 2 rounds.
  for (;;) {
    ties_.clear();
    tied_.clear();
    for (std::size_t k = 0; k < outer.size(); ++k) {
      const int j = outer[k];
      if (tie(j % nx, j / nx, degree_cap_[k], fixed, start, end)) tied_.push_back(k);
    }
    gathered_.assign(mass.begin(), mass.end());
    gather(std::span<double>(gathered_));
    bool demoted = false;
    for (std::size_t t = 0; t < ties_.size(); ++t) {
      for (int e = ties_.start[t]; e < ties_.start[t + 1]; ++e) {
        const auto i = static_cast<std::size_t>(ties_.inner[static_cast<std::size_t>(e)]);
        if (ties_.weight[static_cast<std::size_t>(e)] < 0.0 && gathered_[i] < 0.5 * mass[i] &&
            degree_cap_[tied_[t]] > 0) {
          --degree_cap_[tied_[t]];
          demoted = true;
          break;
        }
      }
    }
    if (!demoted) break;
  }
  for (std::size_t t = 0; t < ties_.size(); ++t) {
    tie_of_[static_cast<std::size_t>(ties_.outer[t])] = static_cast<int>(t);
  }
}

void BasisExtension::tie_massless(std::span<const int> nodes, std::span<const unsigned> fixed,
                                  std::span<const Vec2> start, std::span<const Vec2> end) {
  const int nx = grid_.n_nodes_x();
  for (const int j : nodes) {
    if (tie_of_[static_cast<std::size_t>(j)] >= 0 || inner_[static_cast<std::size_t>(j)]) continue;
    if (tie(j % nx, j / nx, degree_, fixed, start, end)) {
      tie_of_[static_cast<std::size_t>(j)] = static_cast<int>(ties_.size()) - 1;
    }
  }
}

NodeTies BasisExtension::light_arrays(std::span<const double> mass, double density, double upto,
                                      std::span<const unsigned> fixed, std::span<const Vec2> start,
                                      std::span<const Vec2> end) {
  NodeTies arrays;
  if (!enabled()) return arrays;
  const int nx = grid_.n_nodes_x();
  std::vector<char> classified = inner_;
  std::vector<int> light;
  for (int node = 0; node < grid_.n_nodes(); ++node) {
    const auto n = static_cast<std::size_t>(node);
    inner_[n] = mass[n] >= upto * density * support(node);
    if (classified[n] && !inner_[n] && fixed[n] == kFixNone && tie_of_[n] < 0)
      light.push_back(node);
  }
  std::swap(ties_, arrays);
  for (const int j : light) tie(j % nx, j / nx, degree_, fixed, start, end, 1);
  std::swap(ties_, arrays);
  inner_ = std::move(classified);
  return arrays;
}

bool BasisExtension::tie(int jx, int jy, int max_degree, std::span<const unsigned> fixed,
                         std::span<const Vec2> start, std::span<const Vec2> end, int min_degree) {
  constexpr int kReach = 2;  // nodes between j and its array, at most
  const int nx = grid_.n_nodes_x(), ny = grid_.n_nodes_y();
  const auto j = static_cast<std::size_t>(grid_.node_index(jx, jy));
  for (int q = max_degree; q >= min_degree; --q) {
    int best_x = -1, best_y = -1;
    long best_box = std::numeric_limits<long>::max(), best_centre = best_box;
    for (int ly = std::max(0, jy - q - kReach); ly <= std::min(ny - 1 - q, jy + kReach); ++ly) {
      const int dy = box_distance(ly, q, jy);
      if (dy > kReach) continue;
      for (int lx = std::max(0, jx - q - kReach); lx <= std::min(nx - 1 - q, jx + kReach); ++lx) {
        const int dx = box_distance(lx, q, jx);
        if (dx > kReach) continue;
        // Twice the centre's offset, so that the distances stay integers.
        const long cx = 2L * lx + q - 2L * jx, cy = 2L * ly + q - 2L * jy;
        const long box = static_cast<long>(dx) * dx + static_cast<long>(dy) * dy;
        const long centre = cx * cx + cy * cy;
        if (box > best_box || (box == best_box && centre >= best_centre)) continue;
        bool usable = true;
        for (int b = 0; b <= q && usable; ++b) {
          for (int a = 0; a <= q && usable; ++a) {
            const auto i = static_cast<std::size_t>(grid_.node_index(lx + a, ly + b));
            usable = inner_[i] && (fixed[i] & fixed[j]) == fixed[j];
            if (usable && fixed[j] & kFixX) {
              usable = start[i].x() == start[j].x() && end[i].x() == end[j].x();
            }
            if (usable && fixed[j] & kFixY) {
              usable = start[i].y() == start[j].y() && end[i].y() == end[j].y();
            }
          }
        }
        if (!usable) continue;
        best_x = lx;
        best_y = ly;
        best_box = box;
        best_centre = centre;
      }
    }
    if (best_x < 0) continue;
    ties_.outer.push_back(static_cast<int>(j));
    for (int b = 0; b <= q; ++b) {
      const double wy = lagrange(best_y, q, best_y + b, jy);
      for (int a = 0; a <= q; ++a) {
        const double w = lagrange(best_x, q, best_x + a, jx) * wy;
        if (w == 0.0) continue;
        ties_.inner.push_back(grid_.node_index(best_x + a, best_y + b));
        ties_.weight.push_back(w);
      }
    }
    ties_.start.push_back(static_cast<int>(ties_.inner.size()));
    return true;
  }
  return false;
}

}  // namespace pfm

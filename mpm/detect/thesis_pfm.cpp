// The Proximity Field Method as the thesis defines it (4.4, 5): Epanechnikov kernels with shape
// matrices, the proximity field K on 9-node cells, edge points by bisection or shape functions,
// the Triangle Connection Algorithm, removal of straight vertex holes, Gaussian and median
// filters.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>
#include <vector>

#include "mpm/detect/detect_internal.hpp"
#include "mpm/detect/improved_field.hpp"

namespace pfm::detail {

namespace {

using Clock = std::chrono::steady_clock;

Mat2 rotation(double angle) {
  Mat2 r;
  r << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle);  // eq. 4.13 / 4.15
  return r;
}

// Eq. 5.11: the strain applied to a kernel axis fades out linearly as the axis approaches its
// maximum (stretching) or minimum (compression) size.
double clamped_strain(double strain, double size, double initial, const ThesisPfmConfig& c) {
  if (strain > 0.0 && c.max_size_factor > 0.0) {
    const double s_max = c.max_size_factor * initial;
    return strain * std::clamp((s_max - size) / (s_max - initial), 0.0, 1.0);
  }
  if (strain < 0.0 && c.min_size_factor > 0.0) {
    const double s_min = c.min_size_factor * initial;
    return strain * std::clamp((size - s_min) / (initial - s_min), 0.0, 1.0);
  }
  return strain;
}

// Principal-axis form of an arbitrary shape matrix (4.4.3, large strain): S S^T = Q L Q^T, the
// ellipse {S u : |u| <= 1} has axes Q sqrt(L). Columns are matched to the previous axes so the
// clamp of eq. 5.11 keeps acting on the axis "originally along x".
Mat2 principal_axes(const Mat2& s, const Mat2& previous) {
  const Mat2 m = s * s.transpose();
  const double mean = 0.5 * (m(0, 0) + m(1, 1));
  const double radius = std::hypot(0.5 * (m(0, 0) - m(1, 1)), m(0, 1));
  const double l1 = mean + radius, l2 = std::max(mean - radius, 0.0);
  Vec2 e1;
  if (radius <= 1e-15 * std::max(mean, 1e-300)) {
    e1 = previous.col(0).normalized();
  } else {
    const double angle = 0.5 * std::atan2(2.0 * m(0, 1), m(0, 0) - m(1, 1));
    e1 = Vec2(std::cos(angle), std::sin(angle));
  }
  Vec2 e2(-e1.y(), e1.x());
  Vec2 c1 = std::sqrt(l1) * e1, c2 = std::sqrt(l2) * e2;
  const Vec2 p1 = previous.col(0).normalized();
  if (std::abs(c2.normalized().dot(p1)) > std::abs(c1.normalized().dot(p1))) std::swap(c1, c2);
  if (c1.dot(previous.col(0)) < 0.0) c1 = -c1;
  if (c2.dot(previous.col(1)) < 0.0) c2 = -c2;
  Mat2 out;
  out.col(0) = c1;
  out.col(1) = c2;
  return out;
}

void update_shapes(const ParticleCloud& cloud, const ThesisPfmConfig& c, DetectorState& state) {
  const std::size_t n = cloud.position.size();
  const double s0 = c.kernel_factor * 0.5 * cloud.initial_spacing;
  if (state.shape.size() != n) {
    state.shape.assign(n, s0 * Mat2::Identity());
    state.previous_deformation.assign(n, Mat2::Identity());
    state.n_calls = 0;
  }
  for (std::size_t p = 0; p < n; ++p) {
    const Mat2 f =
        cloud.deformation_gradient.empty() ? Mat2::Identity() : cloud.deformation_gradient[p];
    Mat2& s = state.shape[p];
    switch (c.deformation) {
      case KernelDeformation::kNone:
        s = s0 * Mat2::Identity();
        break;
      case KernelDeformation::kSmallStrain: {
        // Eq. 4.17: total strains on the initial shape. The clamp is a hard limit here because
        // eq. 5.11 needs increments (documented deviation).
        const double ex = f(0, 0) - 1.0, ey = f(1, 1) - 1.0, exy = 0.5 * (f(0, 1) + f(1, 0));
        const double lo = c.min_size_factor > 0.0 ? c.min_size_factor * s0 : 0.0;
        const double hi = c.max_size_factor > 0.0 ? c.max_size_factor * s0
                                                  : std::numeric_limits<double>::infinity();
        const double sx = std::clamp(s0 * (1.0 + ex), lo, hi);
        const double sy = std::clamp(s0 * (1.0 + ey), lo, hi);
        s = rotation(exy) * Vec2(sx, sy).asDiagonal();
        break;
      }
      case KernelDeformation::kLargeStrain: {
        // Eq. 4.16: S_t = R_t A_t S_(t-1) with the increment dF = F F_prev^-1, then back to
        // principal axes (the thesis left this untested; Fig. 4.15).
        const Mat2 df = f * state.previous_deformation[p].inverse();
        const double ex = df(0, 0) - 1.0, ey = df(1, 1) - 1.0, exy = 0.5 * (df(0, 1) + df(1, 0));
        const double ax = clamped_strain(ex, s.col(0).norm(), s0, c);
        const double ay = clamped_strain(ey, s.col(1).norm(), s0, c);
        const Mat2 stretched = rotation(exy) * Vec2(1.0 + ax, 1.0 + ay).asDiagonal() * s;
        s = principal_axes(stretched, s);
        break;
      }
    }
    state.previous_deformation[p] = f;
  }
  ++state.n_calls;
}

// The thesis field K (eq. 4.9-4.11, 4.19) with the closest-point negative extension (5.2.2).
class ProximityField {
 public:
  ProximityField(const ParticleCloud& cloud, const std::vector<Mat2>& shapes, bool negative)
      : position_(cloud.position.begin(), cloud.position.end()), negative_(negative) {
    const std::size_t n = position_.size();
    inverse_.resize(n);
    constant_.resize(n);
    reach_.resize(n);
    double max_reach = 0.0;
    for (std::size_t p = 0; p < n; ++p) {
      inverse_[p] = shapes[p].inverse();
      constant_[p] = 2.0 / (std::numbers::pi * std::abs(shapes[p].determinant()));  // eq. 4.19
      double largest = 0.0, smallest = 0.0;
      singular_values(shapes[p], largest, smallest);
      reach_[p] = largest;
      max_reach = std::max(max_reach, largest);
    }
    bins_ = ParticleBins(position_, max_reach > 0.0 ? max_reach : 1.0);
  }
  double kernel(std::size_t p, const Vec2& x) const {
    const Vec2 u = inverse_[p] * (position_[p] - x);  // eq. 4.11
    return constant_[p] * (1.0 - u.squaredNorm());    // eq. 4.9, negative outside the baseline
  }
  // Exact K(x) (eq. 4.10), gathered over the particles near x.
  double operator()(const Vec2& x) const {
    double sum = 0.0;
    bool covered = false;
    bins_.for_each_near(x, [&](int p) {
      const double k = kernel(p, x);
      if (k > 0.0) {
        sum += k;
        covered = true;
      }
    });
    if (covered || !negative_) return sum;
    return closest_value(x);
  }
  // Outside every kernel: the (negative) kernel value of the closest material point (5.2.2).
  double closest_value(const Vec2& x) const {
    const int p = bins_.nearest(x, position_);
    return p < 0 ? 0.0 : kernel(static_cast<std::size_t>(p), x);
  }
  std::span<const Vec2> positions() const { return position_; }
  double reach(std::size_t p) const { return reach_[p]; }

 private:
  std::vector<Vec2> position_;
  std::vector<Mat2> inverse_;
  std::vector<double> constant_;
  std::vector<double> reach_;
  bool negative_;
  ParticleBins bins_;
};

}  // namespace
}  // namespace pfm::detail

namespace pfm {

std::vector<double> thesis_gaussian_weights(double sigma, int size) {
  const int m = size > 0 ? (size - 1) / 2 : static_cast<int>(std::ceil(3.0 * sigma - 0.5));  // 5.7
  std::vector<double> w(2 * m + 1);
  const double scale = 1.0 / (std::sqrt(2.0) * sigma);
  for (int k = -m; k <= m; ++k) {
    w[k + m] = 0.5 * (std::erf((k + 0.5) * scale) - std::erf((k - 0.5) * scale));  // eq. 5.8
  }
  return w;
}

}  // namespace pfm

namespace pfm::detail {
namespace {

// Missing nodes beyond the field edge take the value of the central node (5.3.2).
void gaussian_filter(std::vector<double>& v, int nx, int ny, const std::vector<double>& w) {
  const int m = static_cast<int>(w.size() / 2);
  std::vector<double> tmp(v.size());
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      double s = 0.0;
      for (int k = -m; k <= m; ++k) {
        const int ii = i + k;
        s += w[k + m] * ((ii >= 0 && ii < nx) ? v[j * nx + ii] : v[j * nx + i]);
      }
      tmp[j * nx + i] = s;
    }
  }
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      double s = 0.0;
      for (int k = -m; k <= m; ++k) {
        const int jj = j + k;
        s += w[k + m] * ((jj >= 0 && jj < ny) ? tmp[jj * nx + i] : tmp[j * nx + i]);
      }
      v[j * nx + i] = s;
    }
  }
}

// Eq. 5.10: each of the 3 x 3 nodes enters the median a (centre), b (edge) or c (corner) times.
void median_filter(std::vector<double>& v, int nx, int ny, const int weights[3]) {
  std::vector<double> out(v.size()), bag;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      bag.clear();
      for (int dj = -1; dj <= 1; ++dj) {
        for (int di = -1; di <= 1; ++di) {
          const int ii = i + di, jj = j + dj;
          const double value =
              (ii >= 0 && jj >= 0 && ii < nx && jj < ny) ? v[jj * nx + ii] : v[j * nx + i];
          const int times = (di == 0 && dj == 0)   ? weights[0]
                            : (di == 0 || dj == 0) ? weights[1]
                                                   : weights[2];
          for (int t = 0; t < times; ++t) bag.push_back(value);
        }
      }
      if (bag.empty()) {
        out[j * nx + i] = v[j * nx + i];
        continue;
      }
      const auto middle = bag.begin() + static_cast<long>(bag.size() / 2);
      std::nth_element(bag.begin(), middle, bag.end());
      out[j * nx + i] = *middle;
    }
  }
  v = std::move(out);
}

}  // namespace

namespace {

/// The nodes of the 9-node cells' lattice (spacing half a field cell) from `origin`, m.
Vec2 lattice_node(const Vec2& origin, double spacing, int i, int j) {
  return Vec2(origin.x() + i * spacing, origin.y() + j * spacing);
}

/// Adds each particle's kernel to the lattice nodes it reaches (k_value, nx x ny, row by row),
/// marking them `covered`.
void scatter_kernels(const ProximityField& field, const Vec2& origin, double spacing, int nx,
                     int ny, std::vector<double>& k_value, std::vector<char>& covered) {
  const auto node_pos = [&](int i, int j) { return lattice_node(origin, spacing, i, j); };
  const auto positions = field.positions();
  for (std::size_t p = 0; p < positions.size(); ++p) {
    const double reach = field.reach(p);
    const int i0 =
        std::max(static_cast<int>(std::ceil((positions[p].x() - reach - origin.x()) / spacing)), 0);
    const int i1 = std::min(
        static_cast<int>(std::floor((positions[p].x() + reach - origin.x()) / spacing)), nx - 1);
    const int j0 =
        std::max(static_cast<int>(std::ceil((positions[p].y() - reach - origin.y()) / spacing)), 0);
    const int j1 = std::min(
        static_cast<int>(std::floor((positions[p].y() + reach - origin.y()) / spacing)), ny - 1);
    for (int j = j0; j <= j1; ++j) {
      for (int i = i0; i <= i1; ++i) {
        const double k = field.kernel(p, node_pos(i, j));
        if (k > 0.0) {
          k_value[static_cast<std::size_t>(j) * nx + i] += k;
          covered[static_cast<std::size_t>(j) * nx + i] = 1;
        }
      }
    }
  }
}

/// negative_outside: each node no kernel reaches takes the kernel of its closest material point
/// (negative there), found by vector propagation (two raster passes over the node lattice,
/// Danielsson 1980): O(nodes) instead of a search per node.
void fill_uncovered_nodes(const ProximityField& field, const Vec2& origin, double spacing, int nx,
                          int ny, const std::vector<char>& covered, std::vector<double>& k_value) {
  const auto node_pos = [&](int i, int j) { return lattice_node(origin, spacing, i, j); };
  const auto positions = field.positions();
  // Closest material point of every node by vector propagation (two raster passes over the
  // node grid, Danielsson 1980): O(nodes) instead of a search per node.
  std::vector<int> nearest(k_value.size(), -1);
  std::vector<double> best(k_value.size(), std::numeric_limits<double>::infinity());
  const auto offer = [&](std::size_t n, int p, const Vec2& x) {
    const double d = (positions[p] - x).squaredNorm();
    if (d < best[n] || (d == best[n] && p < nearest[n])) {
      best[n] = d;
      nearest[n] = p;
    }
  };
  for (std::size_t p = 0; p < positions.size(); ++p) {
    const int ic = static_cast<int>(std::floor((positions[p].x() - origin.x()) / spacing));
    const int jc = static_cast<int>(std::floor((positions[p].y() - origin.y()) / spacing));
    for (int j = std::max(jc - 1, 0); j <= std::min(jc + 2, ny - 1); ++j) {
      for (int i = std::max(ic - 1, 0); i <= std::min(ic + 2, nx - 1); ++i) {
        offer(static_cast<std::size_t>(j) * nx + i, static_cast<int>(p), node_pos(i, j));
      }
    }
  }
  if (std::all_of(nearest.begin(), nearest.end(), [](int p) { return p < 0; })) {
    nearest[0] = 0;  // every particle off the grid: seed one node
    best[0] = (positions[0] - node_pos(0, 0)).squaredNorm();
  }
  for (int pass = 0; pass < 2; ++pass) {
    const int step = pass == 0 ? 1 : -1;
    for (int j = pass == 0 ? 0 : ny - 1; j >= 0 && j < ny; j += step) {
      for (int i = pass == 0 ? 0 : nx - 1; i >= 0 && i < nx; i += step) {
        const std::size_t n = static_cast<std::size_t>(j) * nx + i;
        const Vec2 x = node_pos(i, j);
        for (const auto& [di, dj] : {std::pair{-step, 0}, std::pair{0, -step},
                                     std::pair{-step, -step}, std::pair{step, -step}}) {
          const int ii = i + di, jj = j + dj;
          if (ii < 0 || jj < 0 || ii >= nx || jj >= ny) continue;
          const int p = nearest[static_cast<std::size_t>(jj) * nx + ii];
          if (p >= 0) offer(n, p, x);
        }
      }
      // Same row, the other way, so values also travel against the raster direction.
      for (int i = pass == 0 ? nx - 2 : 1; i >= 0 && i < nx; i -= step) {
        const std::size_t n = static_cast<std::size_t>(j) * nx + i;
        const int p = nearest[n + step];
        if (p >= 0) offer(n, p, node_pos(i, j));
      }
    }
  }
  for (std::size_t n = 0; n < k_value.size(); ++n) {
    if (!covered[n]) {
      const int i = static_cast<int>(n % nx), j = static_cast<int>(n / nx);
      k_value[n] = field.kernel(nearest[n], node_pos(i, j));
    }
  }
}

/// A piece of the Triangle Connection Algorithm's contours, and whether both its ends lie on one
/// cell edge.
struct TcaSegment {
  int from, to;
  bool along_cell_edge;
};

/// The segments without the straight holes along vertices (5.3.4): a segment along a cell edge
/// whose reverse is also present (from the neighbouring cell) encloses nothing; both go.
std::vector<DirectedSegment> without_vertex_holes(const std::vector<TcaSegment>& segments,
                                                  std::size_t n_points) {
  std::vector<DirectedSegment> kept;
  kept.reserve(segments.size());
  std::vector<int> along_from(n_points, -1);  // along-edge segment starting at a point
  for (const auto& s : segments) {
    if (s.along_cell_edge) along_from[s.from] = s.to;
  }
  for (const auto& s : segments) {
    if (s.along_cell_edge && along_from[s.to] == s.from) continue;
    kept.push_back({s.from, s.to});
  }
  return kept;
}

/// Bisection for the sign change of g on [0, 1] (4.4.5, Fig. 4.18), `a_in` whether g > 0 at 0:
/// at most `steps` halvings, ending where |g| < tolerance or the bracket is below 1e-15; counts
/// the evaluations.
template <class G>
double bisect(const G& g, bool a_in, int steps, double tolerance, long& evaluations) {
  double lo = 0.0, hi = 1.0, t = 0.5;
  for (int step = 0; step < steps; ++step) {
    t = 0.5 * (lo + hi);
    const double ht = g(t);
    ++evaluations;
    if (std::abs(ht) < tolerance || hi - lo < 1e-15) break;
    ((ht > 0.0) == a_in ? lo : hi) = t;
  }
  return t;
}

/// The thesis's filters on the node values (nx x ny), the Gaussian then the median one, as
/// configured; whether any ran.
bool apply_filters(const ThesisPfmConfig& config, int nx, int ny, std::vector<double>& k_value) {
  const bool median =
      config.median_weights[0] > 0 || config.median_weights[1] > 0 || config.median_weights[2] > 0;
  if (config.gaussian_sigma > 0.0) {
    gaussian_filter(k_value, nx, ny,
                    thesis_gaussian_weights(config.gaussian_sigma, config.gaussian_size));
  }
  if (median) median_filter(k_value, nx, ny, config.median_weights);
  return config.gaussian_sigma > 0.0 || median;
}

}  // namespace

DetectedBoundary detect_thesis_pfm(const ParticleCloud& cloud, const Grid& grid,
                                   const ThesisPfmConfig& config, DetectorState& state,
                                   DetectionTimings& timings) {
  auto start = Clock::now();
  update_shapes(cloud, config, state);
  const ProximityField field(cloud, state.shape, config.negative_outside);
  const int r = config.refinement;
  timings.refinement = r;
  // Node grid of the 9-node cells: spacing half a field cell.
  const double spacing = grid.cell_size / r / 2.0;
  const int nx = 2 * r * grid.n_cells_x + 1, ny = 2 * r * grid.n_cells_y + 1;
  const auto node_pos = [&](int i, int j) {
    return Vec2(grid.origin.x() + i * spacing, grid.origin.y() + j * spacing);
  };
  // Particle-loop scatter to the nodes each kernel reaches (5.2.3).
  std::vector<double> k_value(static_cast<std::size_t>(nx) * ny, 0.0);
  std::vector<char> covered(k_value.size(), 0);
  scatter_kernels(field, grid.origin, spacing, nx, ny, k_value, covered);
  if (config.negative_outside && !field.positions().empty()) {
    fill_uncovered_nodes(field, grid.origin, spacing, nx, ny, covered, k_value);
  }
  timings.field = seconds_since(start);
  timings.field_evaluations = static_cast<long>(k_value.size());

  start = Clock::now();
  const bool filtered = apply_filters(config, nx, ny, k_value);
  timings.filters = seconds_since(start);

  // H = K - z (eq. 4.20); material where H > 0.
  const double z = config.contour_level;
  const auto h_at = [&](int i, int j) { return k_value[static_cast<std::size_t>(j) * nx + i] - z; };
  // A filtered field exists only at the nodes: edge points then come from the shape functions.
  const bool use_shape_functions =
      filtered || config.edge_location == EdgeLocation::kShapeFunctions;

  // Edge points on half edges of the node grid; ids as in marching squares.
  const int n_horizontal = (nx - 1) * ny;
  std::vector<int> point_of_edge(static_cast<std::size_t>(n_horizontal) + nx * (ny - 1), -1);
  std::vector<Vec2> points;
  std::vector<int> point_cell_edge;  // id of the cell edge (full edge) each point lies on
  long root_evaluations = 0;
  start = Clock::now();
  const auto locate = [&](int ia, int ja, int ib, int jb) -> int {
    // (ia, ja) -> (ib, jb) is a half edge with increasing index.
    const bool horizontal = jb == ja;
    const int id = horizontal ? ja * (nx - 1) + ia : n_horizontal + ja * nx + ia;
    int& slot = point_of_edge[id];
    if (slot >= 0) return slot;
    const Vec2 a = node_pos(ia, ja), b = node_pos(ib, jb);
    const double ha = h_at(ia, ja);
    const bool a_in = ha > 0.0;
    double t = 0.5;
    if (use_shape_functions) {
      // Quadratic through the three nodes of the full cell edge (8-node cell, 5.2.2), in the
      // half-edge parameter: the edge runs from node e0 to e0 + 2 along the same line.
      const int offset = horizontal ? ia % 2 : ja % 2;  // 0: a is a corner, 1: a is the mid node
      const int e0i = horizontal ? ia - offset : ia, e0j = horizontal ? ja : ja - offset;
      const int di = horizontal ? 1 : 0, dj = horizontal ? 0 : 1;
      const double h0 = h_at(e0i, e0j), h1 = h_at(e0i + di, e0j + dj),
                   h2 = h_at(e0i + 2 * di, e0j + 2 * dj);
      const auto quadratic = [&](double s) {
        const double xi = offset - 1.0 + s;  // position on [-1, 1] of the full edge
        return 0.5 * xi * (xi - 1.0) * h0 + (1.0 - xi * xi) * h1 + 0.5 * xi * (xi + 1.0) * h2;
      };
      t = bisect(quadratic, a_in, config.bisection_steps, config.bisection_tolerance,
                 root_evaluations);
    } else {
      const auto along = [&](double s) { return field(a + s * (b - a)) - z; };
      t = bisect(along, a_in, config.bisection_steps, config.bisection_tolerance, root_evaluations);
    }
    slot = static_cast<int>(points.size());
    points.push_back(a + t * (b - a));
    // Cell-edge id: the full edge containing this half edge.
    const int e0i = horizontal ? ia - ia % 2 : ia, e0j = horizontal ? ja : ja - ja % 2;
    point_cell_edge.push_back(horizontal ? 2 * (e0j * nx + e0i) : 2 * (e0j * nx + e0i) + 1);
    return slot;
  };

  // Triangle Connection Algorithm (5.1.3) per field cell.
  std::vector<TcaSegment> segments;
  double edge_seconds = 0.0;
  const int n_cells_x = r * grid.n_cells_x, n_cells_y = r * grid.n_cells_y;
  // Boundary nodes counter-clockwise from the lower-left corner, in half-node offsets.
  static constexpr int kBi[8] = {0, 1, 2, 2, 2, 1, 0, 0};
  static constexpr int kBj[8] = {0, 0, 0, 1, 2, 2, 2, 1};
  const auto connection_start = Clock::now();
  for (int cj = 0; cj < n_cells_y; ++cj) {
    for (int ci = 0; ci < n_cells_x; ++ci) {
      const int bi = 2 * ci, bj = 2 * cj;
      bool in[8];
      int n_in = 0;
      for (int k = 0; k < 8; ++k) {
        in[k] = h_at(bi + kBi[k], bj + kBj[k]) > 0.0;
        n_in += in[k] ? 1 : 0;
      }
      if (n_in == 0 || n_in == 8) continue;
      const bool centre_in = h_at(bi + 1, bj + 1) > 0.0;  // the 9th node
      int point[8], half_edge[8];
      bool leaving[8];
      int n_cross = 0;
      const auto edge_start = Clock::now();
      for (int k = 0; k < 8; ++k) {
        const int k1 = (k + 1) % 8;
        if (in[k] == in[k1]) continue;
        const int ai = bi + kBi[k], aj = bj + kBj[k], b1 = bi + kBi[k1], b2 = bj + kBj[k1];
        const bool forward = ai + aj * nx < b1 + b2 * nx;
        point[n_cross] = forward ? locate(ai, aj, b1, b2) : locate(b1, b2, ai, aj);
        leaving[n_cross] = in[k];
        half_edge[n_cross] = k;
        ++n_cross;
      }
      edge_seconds += seconds_since(edge_start);
      for (int c = 0; c < n_cross; ++c) {
        if (!leaving[c]) continue;
        // Crossing c lies on the boundary piece from node k to node k + 1. When node k + 1 has
        // the sign of the 9th node, the triangle path turns back towards the previous crossing,
        // otherwise forward to the next (eq. 5.3, stated for counter-clockwise numbering).
        const int k_next = (half_edge[c] + 1) % 8;
        const bool same = in[k_next] == centre_in;
        const int partner = same ? (c - 1 + n_cross) % n_cross : (c + 1) % n_cross;
        // Both ends on the same cell edge: a straight piece along the edge (5.3.4).
        const bool along = point_cell_edge[point[c]] == point_cell_edge[point[partner]];
        segments.push_back({point[c], point[partner], along});
      }
    }
  }
  // Removal of straight holes along vertices (5.3.4).
  std::vector<DirectedSegment> kept;
  if (config.remove_vertex_holes) {
    kept = without_vertex_holes(segments, points.size());
  } else {
    kept.reserve(segments.size());
    for (const auto& s : segments) kept.push_back({s.from, s.to});
  }
  DetectedBoundary boundary = assemble_contours(points, kept);
  timings.edge_points = edge_seconds;
  timings.connection = seconds_since(connection_start) - edge_seconds;
  timings.edge_point_count = static_cast<long>(points.size());
  timings.root_evaluations = root_evaluations;
  timings.field_evaluations += use_shape_functions ? 0 : root_evaluations;
  timings.processed_cells = static_cast<long>(n_cells_x) * n_cells_y;
  return boundary;
}

}  // namespace pfm::detail

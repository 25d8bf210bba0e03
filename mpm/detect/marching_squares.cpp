#include "mpm/detect/marching_squares.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <numeric>
#include <stdexcept>
#include <string>

namespace pfm {

namespace {

bool lower_left_less(const Vec2& a, const Vec2& b) {
  return a.y() < b.y() || (a.y() == b.y() && a.x() < b.x());
}

void check_geometry(const NodalField& f) {
  if (f.n_x < 2 || f.n_y < 2) {
    throw std::invalid_argument("marching_squares: need at least 2 x 2 nodes, got " +
                                std::to_string(f.n_x) + " x " + std::to_string(f.n_y));
  }
  if (!(f.spacing > 0.0) || !std::isfinite(f.spacing)) {
    throw std::invalid_argument("marching_squares: spacing must be finite and > 0");
  }
  if (!f.origin.allFinite()) throw std::invalid_argument("marching_squares: non-finite origin");
}

// Edge numbering: horizontal edge (i, j)-(i+1, j) -> j (n_x - 1) + i; vertical edge
// (i, j)-(i, j+1) -> n_h + j n_x + i.
struct EdgeNumbering {
  long n_x, n_y;
  long n_horizontal() const { return (n_x - 1) * n_y; }
  long horizontal(long i, long j) const { return j * (n_x - 1) + i; }
  long vertical(long i, long j) const { return n_horizontal() + j * n_x + i; }
  long count() const { return n_horizontal() + n_x * (n_y - 1); }
};

// The point of each crossed edge of a narrow band on a large field: open addressing with linear
// probing, doubled whenever it is half full. It starts with two slots per cell: a contour
// crosses about one edge per cell it passes, so most detections never grow it.
class SparseEdgePoints {
 public:
  explicit SparseEdgePoints(std::size_t cells) { resize(std::max<std::size_t>(2 * cells, 16)); }
  /// The point of `edge` (-1 while it has none).
  int& operator[](long edge) {
    if (2 * (used_ + 1) > key_.size()) resize(2 * key_.size());
    std::size_t k = slot(edge);
    if (key_[k] == -1) {
      key_[k] = edge;
      ++used_;
    }
    return point_[k];
  }

 private:
  // The slot that holds `edge` or the empty one where it goes.
  std::size_t slot(long edge) const {
    const std::size_t mask = key_.size() - 1;
    std::size_t k = (static_cast<std::uint64_t>(edge) * 0x9E3779B97F4A7C15ULL) >> shift_;
    while (key_[k] != edge && key_[k] != -1) k = (k + 1) & mask;
    return k;
  }
  // At least `slots` slots (a power of two), the entries kept.
  void resize(std::size_t slots) {
    int bits = 4;
    while ((std::size_t{1} << bits) < slots) ++bits;
    std::vector<long> key = std::move(key_);
    std::vector<int> point = std::move(point_);
    shift_ = 64 - bits;
    key_.assign(std::size_t{1} << bits, -1);
    point_.assign(key_.size(), -1);
    for (std::size_t k = 0; k < key.size(); ++k) {
      if (key[k] == -1) continue;
      const std::size_t to = slot(key[k]);
      key_[to] = key[k];
      point_[to] = point[k];
    }
  }

  int shift_ = 60;
  std::size_t used_ = 0;
  std::vector<long> key_;
  std::vector<int> point_;
};

}  // namespace

DetectedBoundary marching_squares(const NodalField& field, double level, SaddleRule rule,
                                  const EdgeRefiner& refine,
                                  const std::function<double(const Vec2&)>& exact_sample) {
  check_geometry(field);
  if (field.values.size() != static_cast<std::size_t>(field.n_x) * field.n_y) {
    throw std::invalid_argument("marching_squares: values.size() != n_x * n_y");
  }
  for (const double v : field.values) {
    if (!std::isfinite(v)) throw std::invalid_argument("marching_squares: non-finite value");
  }
  if (!std::isfinite(level)) throw std::invalid_argument("marching_squares: non-finite level");
  std::vector<int> cells((field.n_x - 1) * (field.n_y - 1));
  std::iota(cells.begin(), cells.end(), 0);
  const auto node_value = [&field](int i, int j) { return field.values[j * field.n_x + i]; };
  BatchEdgeRefiner each;  // the crossings one after the other, in the order they were found
  if (refine) {
    each = [&refine](std::span<const EdgeCrossing> crossing, std::span<Vec2> point) {
      for (std::size_t k = 0; k < crossing.size(); ++k) {
        const EdgeCrossing& c = crossing[k];
        point[k] = refine(c.a, c.value_a, c.b, c.value_b);
      }
    };
  }
  return marching_squares_cells(field, node_value, cells, level, rule, each, exact_sample);
}

DetectedBoundary marching_squares_cells(const NodalField& geom,
                                        const std::function<double(int, int)>& node_value,
                                        std::span<const int> cells, double level, SaddleRule rule,
                                        const BatchEdgeRefiner& refine,
                                        const std::function<double(const Vec2&)>& exact_sample) {
  check_geometry(geom);
  const EdgeNumbering edges{geom.n_x, geom.n_y};
  // Point of each edge crossing: a dense table when the cells cover a good part of the field, a
  // hash table for a narrow band on a large field (lookups only, so the result does not depend
  // on the choice).
  const bool dense = static_cast<double>(edges.count()) <= 16.0 * cells.size() + 4096.0;
  std::vector<int> point_of_edge(dense ? edges.count() : 0, -1);
  SparseEdgePoints sparse_point_of_edge(dense ? 0 : cells.size());
  std::vector<EdgeCrossing> crossings;  // by point
  std::vector<DirectedSegment> segments;
  const auto node_pos = [&geom](int i, int j) {
    return Vec2(geom.origin.x() + i * geom.spacing, geom.origin.y() + j * geom.spacing);
  };
  // Crossing on the edge from node (ia, ja) to node (ib, jb), one point per edge so the two cells
  // sharing it use the identical point (found after the walk).
  const auto crossing = [&](long edge, int ia, int ja, double va, int ib, int jb, double vb) {
    int& slot = dense ? point_of_edge[edge] : sparse_point_of_edge[edge];
    if (slot >= 0) return slot;
    slot = static_cast<int>(crossings.size());
    crossings.push_back({node_pos(ia, ja), va, node_pos(ib, jb), vb});
    return slot;
  };

  for (const int cell : cells) {
    const int i = cell % (geom.n_x - 1), j = cell / (geom.n_x - 1);
    // Corners counter-clockwise: 0 (i,j), 1 (i+1,j), 2 (i+1,j+1), 3 (i,j+1); values - level.
    const int ci[4] = {i, i + 1, i + 1, i};
    const int cj[4] = {j, j, j + 1, j + 1};
    double v[4];
    bool in[4];
    int n_in = 0;
    for (int k = 0; k < 4; ++k) {
      v[k] = node_value(ci[k], cj[k]) - level;
      in[k] = v[k] > 0.0;
      n_in += in[k] ? 1 : 0;
    }
    if (n_in == 0 || n_in == 4) continue;
    // Edges walked counter-clockwise: k from corner k to corner k+1.
    const long edge_id[4] = {edges.horizontal(i, j), edges.vertical(i + 1, j),
                             edges.horizontal(i, j + 1), edges.vertical(i, j)};
    int point[4];
    bool leaving[4];  // true: the walk goes from material to void (a contour starts here)
    int n_cross = 0;
    for (int k = 0; k < 4; ++k) {
      const int k1 = (k + 1) % 4;
      if (in[k] == in[k1]) continue;
      // Compute every crossing with the lower-numbered node first so it is independent of the
      // cell that asks for it.
      const bool forward = (k == 0 || k == 1);  // edges 0 and 1 run with increasing index
      const int a = forward ? k : k1, b = forward ? k1 : k;
      point[n_cross] = crossing(edge_id[k], ci[a], cj[a], v[a], ci[b], cj[b], v[b]);
      leaving[n_cross] = in[k];
      ++n_cross;
    }
    if (n_cross == 2) {
      const int from = leaving[0] ? point[0] : point[1];
      const int to = leaving[0] ? point[1] : point[0];
      segments.push_back({from, to});
      continue;
    }
    // Saddle: two material corners on a diagonal. Material centre: each leaving crossing joins
    // the next entering one counter-clockwise (the corners in the void are cut off); void centre:
    // it joins the previous one (the material corners are cut off).
    bool centre_in = false;
    if (rule == SaddleRule::kAsymptoticDecider) {
      const double numerator = v[0] * v[2] - v[1] * v[3];
      const double denominator = v[0] + v[2] - v[1] - v[3];  // non-zero for a saddle
      centre_in = numerator / denominator > 0.0;
    } else if (exact_sample) {
      const Vec2 centre = node_pos(i, j) + Vec2(0.5 * geom.spacing, 0.5 * geom.spacing);
      centre_in = exact_sample(centre) - level > 0.0;
    } else {
      centre_in = 0.25 * (v[0] + v[1] + v[2] + v[3]) > 0.0;
    }
    for (int k = 0; k < 4; ++k) {
      if (!leaving[k]) continue;
      const int partner = centre_in ? (k + 1) % 4 : (k + 3) % 4;
      segments.push_back({point[k], point[partner]});
    }
  }
  std::vector<Vec2> points(crossings.size());
  if (refine) {
    refine(crossings, points);
  } else {
    for (std::size_t k = 0; k < crossings.size(); ++k) {
      const EdgeCrossing& c = crossings[k];
      const double t = c.value_a / (c.value_a - c.value_b);  // opposite signs (or value_b == 0)
      points[k] = c.a + t * (c.b - c.a);
    }
  }
  return assemble_contours(points, segments);
}

DetectedBoundary assemble_contours(const std::vector<Vec2>& points,
                                   const std::vector<DirectedSegment>& segments) {
  const int n = static_cast<int>(points.size());
  std::vector<int> next(n, -1);
  std::vector<char> has_incoming(n, 0);
  for (const auto& s : segments) {
    if (s.from < 0 || s.from >= n || s.to < 0 || s.to >= n || next[s.from] != -1 ||
        has_incoming[s.to]) {
      throw std::logic_error("assemble_contours: a point starts or ends two segments");
    }
    next[s.from] = s.to;
    has_incoming[s.to] = 1;
  }
  DetectedBoundary out;
  std::vector<char> used(n, 0);
  // Open chains first (start: outgoing but no incoming), then the closed loops, each in point
  // order, so the result is deterministic before canonicalize() sorts it.
  for (int start = 0; start < n; ++start) {
    if (next[start] < 0 || has_incoming[start]) continue;
    Contour c;
    c.closed = false;
    for (int p = start; p >= 0 && !used[p]; p = next[p]) {
      used[p] = 1;
      c.points.push_back(points[p]);
    }
    out.contours.push_back(std::move(c));
  }
  for (int start = 0; start < n; ++start) {
    if (used[start] || next[start] < 0) continue;
    Contour c;
    c.closed = true;
    for (int p = start; !used[p]; p = next[p]) {
      used[p] = 1;
      c.points.push_back(points[p]);
      if (next[p] < 0) throw std::logic_error("assemble_contours: broken loop");
    }
    out.contours.push_back(std::move(c));
  }
  canonicalize(out);
  return out;
}

void canonicalize(DetectedBoundary& boundary) {
  std::vector<Contour> kept;
  kept.reserve(boundary.contours.size());
  for (auto& c : boundary.contours) {
    std::vector<Vec2> merged;
    merged.reserve(c.points.size());
    for (const auto& p : c.points) {
      if (merged.empty() || p != merged.back()) merged.push_back(p);
    }
    if (c.closed) {
      while (merged.size() > 1 && merged.back() == merged.front()) merged.pop_back();
      if (merged.size() < 3) continue;
      const auto lowest = std::min_element(merged.begin(), merged.end(), lower_left_less);
      std::rotate(merged.begin(), lowest, merged.end());
    } else if (merged.size() < 2) {
      continue;
    }
    c.points = std::move(merged);
    kept.push_back(std::move(c));
  }
  const auto key = [](const Contour& c) {
    return *std::min_element(c.points.begin(), c.points.end(), lower_left_less);
  };
  std::stable_sort(kept.begin(), kept.end(), [&key](const Contour& a, const Contour& b) {
    return lower_left_less(key(a), key(b));
  });
  boundary.contours = std::move(kept);
}

}  // namespace pfm

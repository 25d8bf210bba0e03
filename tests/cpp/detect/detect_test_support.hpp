// Shared helpers of the detector tests: particle clouds of known bodies, distances to exact
// geometry and checks of the contour invariants.
#pragma once

#include <algorithm>
#include <cmath>
#include <functional>
#include <initializer_list>
#include <map>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include "mpm/core/grid.hpp"
#include "mpm/detect/contour.hpp"
#include "mpm/detect/detector.hpp"

namespace pfm::test {

enum class Placement { kEqualSpacing, kGaussPoints };

inline const char* placement_name(Placement p) {
  return p == Placement::kEqualSpacing ? "equal" : "gauss";
}

/// Owns the arrays a ParticleCloud views.
struct OwnedCloud {
  std::vector<Vec2> position;
  std::vector<double> volume;
  std::vector<Mat2> deformation_gradient;
  double initial_spacing = 0.0;
  ParticleCloud view() const {
    return ParticleCloud{position, volume, deformation_gradient, initial_spacing};
  }
};

/// 2 x 2 points in every cell of size h of the lattice covering [lo, hi] (reference
/// coordinates), kept when `inside(X)`; x = centre + F (X - centre).
inline OwnedCloud lattice_cloud(double h, Placement placement, Vec2 lo, Vec2 hi,
                                const std::function<bool(const Vec2&)>& inside,
                                const Mat2& f = Mat2::Identity(),
                                const Vec2& centre = Vec2::Zero()) {
  OwnedCloud c;
  c.initial_spacing = h / 2.0;
  const double g = placement == Placement::kEqualSpacing ? h / 4.0 : h / (2.0 * std::sqrt(3.0));
  const int i0 = static_cast<int>(std::floor(lo.x() / h)),
            i1 = static_cast<int>(std::ceil(hi.x() / h));
  const int j0 = static_cast<int>(std::floor(lo.y() / h)),
            j1 = static_cast<int>(std::ceil(hi.y() / h));
  const bool deformed = !f.isIdentity();
  for (int j = j0; j < j1; ++j) {
    for (int i = i0; i < i1; ++i) {
      const Vec2 cell_centre((i + 0.5) * h, (j + 0.5) * h);
      for (int b = 0; b < 2; ++b) {
        for (int a = 0; a < 2; ++a) {
          const Vec2 x = cell_centre + Vec2(a == 0 ? -g : g, b == 0 ? -g : g);
          if (!inside(x)) continue;
          c.position.push_back(centre + f * (x - centre));
          c.volume.push_back(h * h / 4.0 * f.determinant());
          if (deformed) c.deformation_gradient.push_back(f);
        }
      }
    }
  }
  return c;
}

/// Distance from p to segment a-b.
inline double segment_distance(const Vec2& p, const Vec2& a, const Vec2& b) {
  const Vec2 d = b - a;
  const double t = std::clamp((p - a).dot(d) / d.squaredNorm(), 0.0, 1.0);
  return (p - (a + t * d)).norm();
}

/// Mean and max of a set of distances.
struct Stats {
  double mean = 0.0, max = 0.0;
  int count = 0;
  void add(double d) {
    mean += d;
    max = std::max(max, d);
    ++count;
  }
  void finish() {
    if (count > 0) mean /= count;
  }
};

/// Vertices and segment midpoints of the detected boundary (the samples distances are taken at).
inline std::vector<Vec2> boundary_samples(const DetectedBoundary& b) {
  std::vector<Vec2> s;
  for (const auto& c : b.contours) {
    const std::size_t n = c.points.size();
    for (std::size_t k = 0; k < n; ++k) {
      s.push_back(c.points[k]);
      if (k + 1 < n || c.closed) s.push_back(0.5 * (c.points[k] + c.points[(k + 1) % n]));
    }
  }
  return s;
}

/// Bitwise the same contours, in the same order.
inline bool same_contours(const DetectedBoundary& a, const DetectedBoundary& b) {
  if (a.contours.size() != b.contours.size()) return false;
  for (std::size_t c = 0; c < a.contours.size(); ++c) {
    if (a.contours[c].closed != b.contours[c].closed ||
        a.contours[c].points != b.contours[c].points) {
      return false;
    }
  }
  return true;
}

/// Signed area (> 0 counter-clockwise) of a closed contour.
inline double signed_area(const Contour& c) {
  double a = 0.0;
  for (std::size_t k = 0; k < c.points.size(); ++k) {
    const Vec2& p = c.points[k];
    const Vec2& q = c.points[(k + 1) % c.points.size()];
    a += p.x() * q.y() - q.x() * p.y();
  }
  return 0.5 * a;
}

/// Winding number of closed contour c around x.
inline int winding_number(const Contour& c, const Vec2& x) {
  int w = 0;
  const std::size_t n = c.points.size();
  for (std::size_t k = 0; k < n; ++k) {
    const Vec2& a = c.points[k];
    const Vec2& b = c.points[(k + 1) % n];
    const double cross = (b.x() - a.x()) * (x.y() - a.y()) - (x.x() - a.x()) * (b.y() - a.y());
    if (a.y() <= x.y()) {
      if (b.y() > x.y() && cross > 0) ++w;
    } else if (b.y() <= x.y() && cross < 0) {
      --w;
    }
  }
  return w;
}

/// Total winding number of all closed contours around x (1 inside the material, 0 outside).
/// Open chains are left out: see close_along_grid_edge().
inline int material_winding(const DetectedBoundary& b, const Vec2& x) {
  int w = 0;
  for (const auto& c : b.contours) {
    if (c.closed) w += winding_number(c, x);
  }
  return w;
}

/// The boundary with its open chains (material on the left, ends on the edge of the box lo..hi)
/// closed along the box: from each chain's end, counter-clockwise along the box (corners
/// included) to the nearest chain start, then that chain, until the first chain comes round
/// again; closed loops are kept. Returns false (and leaves `out` partial) when a chain does not
/// end on the box or the next end point counter-clockwise is another chain's end (material on
/// both sides of the box edge: the chains contradict each other).
inline bool close_along_grid_edge(const DetectedBoundary& b, const Vec2& lo, const Vec2& hi,
                                  double eps, DetectedBoundary& out) {
  out.contours.clear();
  const double w = hi.x() - lo.x(), h = hi.y() - lo.y(), perimeter = 2.0 * (w + h);
  // Position along the box, counter-clockwise from its lower-left corner; -1 off the box.
  const auto along = [&](const Vec2& p) {
    if (std::abs(p.y() - lo.y()) < eps) return std::clamp(p.x() - lo.x(), 0.0, w);
    if (std::abs(p.x() - hi.x()) < eps) return w + std::clamp(p.y() - lo.y(), 0.0, h);
    if (std::abs(p.y() - hi.y()) < eps) return w + h + std::clamp(hi.x() - p.x(), 0.0, w);
    if (std::abs(p.x() - lo.x()) < eps) return 2.0 * w + h + std::clamp(hi.y() - p.y(), 0.0, h);
    return -1.0;
  };
  const Vec2 corners[4] = {Vec2(hi.x(), lo.y()), hi, Vec2(lo.x(), hi.y()), lo};
  const double corner_at[4] = {w, w + h, 2.0 * w + h, perimeter};
  struct End {
    double t;
    std::size_t chain;
    bool start;
  };
  std::vector<End> ends;
  std::vector<std::size_t> chains;
  for (std::size_t c = 0; c < b.contours.size(); ++c) {
    const Contour& contour = b.contours[c];
    if (contour.closed) {
      out.contours.push_back(contour);
      continue;
    }
    const double ts = along(contour.points.front()), te = along(contour.points.back());
    if (ts < 0.0 || te < 0.0) return false;
    ends.push_back({ts, c, true});
    ends.push_back({te, c, false});
    chains.push_back(c);
  }
  // Ends in counter-clockwise order; at equal positions a chain's end before a start.
  std::sort(ends.begin(), ends.end(), [](const End& e, const End& f) {
    return e.t < f.t || (e.t == f.t && !e.start && f.start);
  });
  std::map<std::size_t, std::size_t> next_start;  // chain -> index in ends of the start after it
  for (std::size_t k = 0; k < ends.size(); ++k) {
    if (ends[k].start) continue;
    const End& following = ends[(k + 1) % ends.size()];
    if (!following.start) return false;
    next_start[ends[k].chain] = (k + 1) % ends.size();
  }
  std::map<std::size_t, bool> used;
  for (const std::size_t first : chains) {
    if (used[first]) continue;
    Contour loop;
    loop.closed = true;
    std::size_t c = first;
    do {
      used[c] = true;
      const Contour& chain = b.contours[c];
      loop.points.insert(loop.points.end(), chain.points.begin(), chain.points.end());
      const End& start = ends[next_start[c]];
      const double from = along(chain.points.back());
      double to = start.t;
      if (to < from) to += perimeter;
      for (int turn = 0; turn < 2; ++turn) {
        for (int k = 0; k < 4; ++k) {
          const double at = corner_at[k] + turn * perimeter;
          if (at > from && at < to) loop.points.push_back(corners[k]);
        }
      }
      c = start.chain;
    } while (c != first && !used[c]);
    if (c != first) return false;
    out.contours.push_back(std::move(loop));
  }
  return true;
}

/// Counts of violated contour invariants.
struct Violations {
  long open_not_on_edge = 0;    ///< open contour with an end off the field-grid edge
  long shared_points = 0;       ///< a point used twice (joined to more than two segments)
  long self_intersections = 0;  ///< proper crossings between segments
  long orientation = 0;         ///< loop orientation disagreeing with its nesting depth
  long winding = 0;             ///< total winding number not in {0, 1} at a test point
  long particles_outside = 0;   ///< material points outside the detected region
  long total() const {
    return open_not_on_edge + shared_points + self_intersections + orientation + winding +
           particles_outside;
  }
  Violations& operator+=(const Violations& o) {
    open_not_on_edge += o.open_not_on_edge;
    shared_points += o.shared_points;
    self_intersections += o.self_intersections;
    orientation += o.orientation;
    winding += o.winding;
    particles_outside += o.particles_outside;
    return *this;
  }
};

inline bool segments_cross(const Vec2& a, const Vec2& b, const Vec2& c, const Vec2& d) {
  const auto orient = [](const Vec2& p, const Vec2& q, const Vec2& r) {
    return (q.x() - p.x()) * (r.y() - p.y()) - (q.y() - p.y()) * (r.x() - p.x());
  };
  const double o1 = orient(a, b, c), o2 = orient(a, b, d), o3 = orient(c, d, a),
               o4 = orient(c, d, b);
  return ((o1 > 0 && o2 < 0) || (o1 < 0 && o2 > 0)) && ((o3 > 0 && o4 < 0) || (o3 < 0 && o4 > 0));
}

/// Checks every invariant of contour.hpp plus particle containment.
inline Violations check_invariants(const DetectedBoundary& b, const Grid& field_grid,
                                   std::span<const Vec2> particles) {
  Violations v;
  const Vec2 lo = field_grid.origin, hi = field_grid.upper_corner();
  const double eps = 1e-9 * field_grid.cell_size;
  const auto on_edge = [&](const Vec2& p) {
    return std::abs(p.x() - lo.x()) < eps || std::abs(p.x() - hi.x()) < eps ||
           std::abs(p.y() - lo.y()) < eps || std::abs(p.y() - hi.y()) < eps;
  };
  std::map<std::pair<double, double>, int> uses;
  struct Seg {
    Vec2 a, b;
  };
  std::vector<Seg> segs;
  for (const auto& c : b.contours) {
    if (!c.closed && (!on_edge(c.points.front()) || !on_edge(c.points.back()))) {
      ++v.open_not_on_edge;
    }
    for (const auto& p : c.points) ++uses[{p.x(), p.y()}];
    const std::size_t n = c.points.size();
    for (std::size_t k = 0; k + 1 < n || (c.closed && k < n); ++k) {
      segs.push_back({c.points[k], c.points[(k + 1) % n]});
    }
  }
  for (const auto& [p, count] : uses) v.shared_points += count > 1 ? count - 1 : 0;
  // Segment crossings through a uniform hash of segment boxes.
  const double cell = field_grid.cell_size;
  std::map<std::pair<int, int>, std::vector<int>> buckets;
  for (int s = 0; s < static_cast<int>(segs.size()); ++s) {
    const Vec2 mn = segs[s].a.cwiseMin(segs[s].b), mx = segs[s].a.cwiseMax(segs[s].b);
    for (int j = static_cast<int>(std::floor(mn.y() / cell));
         j <= static_cast<int>(std::floor(mx.y() / cell)); ++j) {
      for (int i = static_cast<int>(std::floor(mn.x() / cell));
           i <= static_cast<int>(std::floor(mx.x() / cell)); ++i) {
        buckets[{i, j}].push_back(s);
      }
    }
  }
  std::map<std::pair<int, int>, char> counted;
  for (const auto& [key, list] : buckets) {
    for (std::size_t x = 0; x < list.size(); ++x) {
      for (std::size_t y = x + 1; y < list.size(); ++y) {
        const auto& s = segs[list[x]];
        const auto& t = segs[list[y]];
        if (segments_cross(s.a, s.b, t.a, t.b)) {
          auto& flag = counted[{std::min(list[x], list[y]), std::max(list[x], list[y])}];
          if (!flag) ++v.self_intersections;
          flag = 1;
        }
      }
    }
  }
  // The boundary with its open chains closed along the grid edge (the material region's).
  DetectedBoundary closed_boundary;
  if (!close_along_grid_edge(b, lo, hi, eps, closed_boundary)) {
    ++v.open_not_on_edge;
    closed_boundary = b;
  }
  // Orientation versus nesting depth (closed loops, in the loops and the closed chains): even
  // depth counter-clockwise.
  for (const auto& loop : b.contours) {
    if (!loop.closed) continue;
    const Vec2 probe = loop.points[0];
    int depth = 0;
    for (const auto& other : closed_boundary.contours) {
      if (!other.closed || other.points == loop.points) continue;
      depth += winding_number(other, probe) != 0 ? 1 : 0;
    }
    const bool ccw = signed_area(loop) > 0.0;
    if (ccw != (depth % 2 == 0)) ++v.orientation;
  }
  // Material points: the winding number of the closed boundary.
  for (const auto& p : particles) {
    const int w = material_winding(closed_boundary, p);
    if (w != 0 && w != 1) ++v.winding;
    if (w != 1) ++v.particles_outside;
  }
  return v;
}

/// Distances (in units of h) from the boundary samples to a polygon body: samples within
/// `corner_zone` (m) of a vertex count as corner samples, the others by their nearest face.
struct FaceReport {
  Stats faces;   ///< all face samples
  Stats corner;  ///< samples near a vertex
  std::vector<Stats> face;
};

inline FaceReport face_distances(const DetectedBoundary& b, const std::vector<Vec2>& vertices,
                                 double corner_zone, double h) {
  FaceReport r;
  r.face.resize(vertices.size());
  for (const auto& p : boundary_samples(b)) {
    double best = 1e300;
    std::size_t face = 0;
    for (std::size_t k = 0; k < vertices.size(); ++k) {
      const double d = segment_distance(p, vertices[k], vertices[(k + 1) % vertices.size()]);
      if (d < best) {
        best = d;
        face = k;
      }
    }
    bool near_corner = false;
    for (const auto& v : vertices) near_corner = near_corner || (p - v).norm() < corner_zone;
    if (near_corner) {
      r.corner.add(best / h);
    } else {
      r.face[face].add(best / h);
      r.faces.add(best / h);
    }
  }
  for (auto& s : r.face) s.finish();
  r.faces.finish();
  r.corner.finish();
  return r;
}

/// The samples of the faces listed (finished statistics of their union).
inline Stats faces_of(const FaceReport& r, std::initializer_list<std::size_t> faces) {
  Stats merged;
  for (const std::size_t f : faces) {
    merged.mean += r.face[f].mean * r.face[f].count;
    merged.count += r.face[f].count;
    merged.max = std::max(merged.max, r.face[f].max);
  }
  merged.finish();
  return merged;
}

/// Radial errors (in units of h) of the boundary samples against the circle (centre, radius):
/// bias = mean signed error (> 0 outside), mean and max of its absolute value.
struct CircleReport {
  double bias = 0.0;
  Stats absolute;
};

inline CircleReport circle_errors(const DetectedBoundary& b, const Vec2& centre, double radius,
                                  double h) {
  CircleReport r;
  for (const auto& p : boundary_samples(b)) {
    const double d = ((p - centre).norm() - radius) / h;
    r.bias += d;
    r.absolute.add(std::abs(d));
  }
  r.bias /= std::max(r.absolute.count, 1);
  r.absolute.finish();
  return r;
}

}  // namespace pfm::test

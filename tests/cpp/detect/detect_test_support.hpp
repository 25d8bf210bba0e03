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
inline int material_winding(const DetectedBoundary& b, const Vec2& x) {
  int w = 0;
  for (const auto& c : b.contours) {
    if (c.closed) w += winding_number(c, x);
  }
  return w;
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
  // Orientation versus nesting depth (closed loops): even depth counter-clockwise.
  for (std::size_t c = 0; c < b.contours.size(); ++c) {
    const auto& loop = b.contours[c];
    if (!loop.closed) continue;
    const Vec2 probe = loop.points[0];
    int depth = 0;
    for (std::size_t o = 0; o < b.contours.size(); ++o) {
      if (o == c || !b.contours[o].closed) continue;
      depth += winding_number(b.contours[o], probe) != 0 ? 1 : 0;
    }
    const bool ccw = signed_area(loop) > 0.0;
    if (ccw != (depth % 2 == 0)) ++v.orientation;
  }
  for (const auto& p : particles) {
    const int w = material_winding(b, p);
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

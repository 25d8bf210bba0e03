// Closed polygons (no repeated closing vertex): signed area, centroid, point containment and the
// segment test of the case reader's simplicity check, shared by the case reader, the body fill and
// the detector's loop classes.
#pragma once

#include <algorithm>
#include <vector>

#include "mpm/core/types.hpp"

namespace pfm {

/// Signed area of a closed polygon (positive when counter-clockwise), m^2.
inline double polygon_signed_area(const std::vector<Vec2>& polygon) {
  double twice = 0.0;
  for (std::size_t k = 0; k < polygon.size(); ++k) {
    const Vec2& a = polygon[k];
    const Vec2& b = polygon[(k + 1) % polygon.size()];
    twice += a.x() * b.y() - b.x() * a.y();
  }
  return 0.5 * twice;
}

/// Centroid of a closed polygon of non-zero area (shoelace), m.
inline Vec2 polygon_centroid(const std::vector<Vec2>& polygon) {
  Vec2 moment = Vec2::Zero();
  for (std::size_t k = 0; k < polygon.size(); ++k) {
    const Vec2& a = polygon[k];
    const Vec2& b = polygon[(k + 1) % polygon.size()];
    moment += (a.x() * b.y() - b.x() * a.y()) / 6.0 * (a + b);
  }
  return moment / polygon_signed_area(polygon);
}

/// Even-odd point-in-polygon test (points exactly on an edge count as inside the half-open
/// region below/left of it, consistently for neighbouring polygons).
inline bool point_in_polygon(const std::vector<Vec2>& polygon, const Vec2& x) {
  bool inside = false;
  const std::size_t n = polygon.size();
  for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
    const Vec2& a = polygon[i];
    const Vec2& b = polygon[j];
    if ((a.y() > x.y()) != (b.y() > x.y())) {
      const double cross_x = a.x() + (x.y() - a.y()) * (b.x() - a.x()) / (b.y() - a.y());
      if (x.x() < cross_x) inside = !inside;
    }
  }
  return inside;
}

/// (b - a) x (c - a): positive when c lies to the left of a -> b.
inline double orient(const Vec2& a, const Vec2& b, const Vec2& c) {
  return (b.x() - a.x()) * (c.y() - a.y()) - (b.y() - a.y()) * (c.x() - a.x());
}

/// Whether segments p1-p2 and q1-q2 share a point (crossing, touching or overlapping).
inline bool segments_intersect(const Vec2& p1, const Vec2& p2, const Vec2& q1, const Vec2& q2) {
  const auto in_box = [](const Vec2& a, const Vec2& b, const Vec2& p) {
    return std::min(a.x(), b.x()) <= p.x() && p.x() <= std::max(a.x(), b.x()) &&
           std::min(a.y(), b.y()) <= p.y() && p.y() <= std::max(a.y(), b.y());
  };
  const double d1 = orient(q1, q2, p1), d2 = orient(q1, q2, p2);
  const double d3 = orient(p1, p2, q1), d4 = orient(p1, p2, q2);
  if (((d1 > 0 && d2 < 0) || (d1 < 0 && d2 > 0)) && ((d3 > 0 && d4 < 0) || (d3 < 0 && d4 > 0)))
    return true;
  return (d1 == 0 && in_box(q1, q2, p1)) || (d2 == 0 && in_box(q1, q2, p2)) ||
         (d3 == 0 && in_box(p1, p2, q1)) || (d4 == 0 && in_box(p1, p2, q2));
}

}  // namespace pfm

// Closed polygons (no repeated closing vertex): signed area and point containment, shared by
// the case reader, the body fill and the detector's loop classes.
#pragma once

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

}  // namespace pfm

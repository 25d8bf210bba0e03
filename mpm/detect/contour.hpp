// The value every boundary detector returns: oriented contours.
//
// Conventions (like scikit-image's find_contours, stated so results can be compared exactly):
// * Material lies on the LEFT of every contour when walking along it: outer loops run
//   counter-clockwise, hole loops clockwise (positive signed area for outer loops).
// * A closed contour does not repeat its first point at the end.
// * An open contour starts and ends on the edge of the field grid.
// * Order: contours sorted by their lowest-then-leftmost point (y, then x); a closed contour
//   starts at its lowest-then-leftmost point. This order is stable for identical input.
#pragma once

#include <string>
#include <vector>

#include "mpm/core/exact_text.hpp"
#include "mpm/core/types.hpp"

namespace pfm {

struct Contour {
  std::vector<Vec2> points;  ///< m
  bool closed = true;
};

struct DetectedBoundary {
  std::vector<Contour> contours;
};

/// The boundary as CSV text, "loop,x,y" then one line per point (loop numbered from 0 in the
/// order above, coordinates by append_exact): pfm-mpm detect's boundary.csv and a run's
/// boundary_<step>.csv.
inline std::string boundary_csv(const DetectedBoundary& boundary) {
  std::string csv = "loop,x,y\n";
  for (std::size_t c = 0; c < boundary.contours.size(); ++c) {
    for (const Vec2& p : boundary.contours[c].points) {
      csv += std::to_string(c);
      csv += ',';
      append_exact(csv, p.x());
      csv += ',';
      append_exact(csv, p.y());
      csv += '\n';
    }
  }
  return csv;
}

}  // namespace pfm

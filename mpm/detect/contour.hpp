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

#include <vector>

#include "mpm/core/types.hpp"

namespace pfm {

struct Contour {
  std::vector<Vec2> points;  ///< m
  bool closed = true;
};

struct DetectedBoundary {
  std::vector<Contour> contours;
};

}  // namespace pfm

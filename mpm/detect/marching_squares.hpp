// Generic marching squares on a nodal field (used by the improved detector and the baselines).
//
// Conventions: see contour.hpp. Material is where value > level; a node whose value equals the
// level exactly counts as OUTSIDE (the thesis' H <= 0 / H > 0 split, eq. 4.20). With the default
// linear interpolation an edge whose outside end sits exactly on the level gets its crossing
// exactly at that node; consecutive identical points are merged and loops that collapse to fewer
// than three distinct points are dropped.
#pragma once

#include <functional>
#include <span>
#include <vector>

#include "mpm/core/types.hpp"
#include "mpm/detect/contour.hpp"

namespace pfm {

/// Values at the nodes of a structured square grid.
struct NodalField {
  Vec2 origin = Vec2::Zero();  ///< position of node (0, 0), m
  double spacing = 1.0;        ///< node spacing, m
  int n_x = 0;                 ///< nodes along x (>= 2)
  int n_y = 0;                 ///< nodes along y (>= 2)
  /// row-major, values[j * n_x + i], node (i, j) at origin + (i, j) * spacing
  std::vector<double> values;
};

enum class SaddleRule {
  /// Bilinear saddle value (f00 f11 - f10 f01) / (f00 + f11 - f10 - f01) decides whether the
  /// cell centre joins the material (asymptotic decider, Nielson & Hamann 1991).
  kAsymptoticDecider,
  /// The field sampled at the cell centre decides: exact_sample(centre) when given, else the
  /// mean of the four corner values (the bilinear centre value).
  kCentreSample,
};

/// Optional exact refinement of an edge crossing: given the two end points of a cell edge where
/// field - level changes sign, return the crossing point. value_a and value_b are field - level
/// (value_a > 0 >= value_b or value_a <= 0 < value_b). Default: linear interpolation.
using EdgeRefiner =
    std::function<Vec2(const Vec2& a, double value_a, const Vec2& b, double value_b)>;

/// A cell edge where field - level changes sign: its two end points and field - level there (the
/// arguments of EdgeRefiner).
struct EdgeCrossing {
  Vec2 a;
  double value_a;
  Vec2 b;
  double value_b;
};

/// Exact refinement of every crossing at once, after the cells are walked: point[k] for
/// crossing[k] (the refiner may share them among threads; spans of equal size).
using BatchEdgeRefiner =
    std::function<void(std::span<const EdgeCrossing> crossing, std::span<Vec2> point)>;

/// Contours of value == level; material (value > level) on the left. Oriented, closed loops or
/// open chains ending on the field edge, in the order of contour.hpp. Throws
/// std::invalid_argument for a malformed field (sizes, spacing, non-finite values).
DetectedBoundary marching_squares(const NodalField& field, double level,
                                  SaddleRule rule = SaddleRule::kAsymptoticDecider,
                                  const EdgeRefiner& refine = {},
                                  const std::function<double(const Vec2&)>& exact_sample = {});

/// Lower-level form used by the narrow-band detector: node values come from `node_value(i, j)`
/// (called only for the corners of processed cells, possibly more than once per node: it must be
/// deterministic) and only `cells` (cell index j * (n_x - 1) + i, any order, no duplicates) are
/// processed; every other cell is assumed to contain no crossing. `field.values` is ignored.
/// Give every cell with a sign change, and the result equals marching_squares() on the full field
/// (with `refine` doing for all crossings what the EdgeRefiner does for one).
DetectedBoundary marching_squares_cells(
    const NodalField& field_geometry, const std::function<double(int i, int j)>& node_value,
    std::span<const int> cells, double level, SaddleRule rule = SaddleRule::kAsymptoticDecider,
    const BatchEdgeRefiner& refine = {},
    const std::function<double(const Vec2&)>& exact_sample = {});

/// A directed segment between two points of a point table (material on its left).
struct DirectedSegment {
  int from = 0;
  int to = 0;
};

/// Joins directed segments into contours and puts them in the canonical order of contour.hpp.
/// Each point may start at most one segment and end at most one segment. Chains that start at a
/// point no segment ends at become open contours; the rest are closed loops.
DetectedBoundary assemble_contours(const std::vector<Vec2>& points,
                                   const std::vector<DirectedSegment>& segments);

/// Canonical order of contour.hpp: merges consecutive identical points, drops degenerate contours,
/// rotates closed loops to start at their lowest-then-leftmost point and sorts the contours by
/// that point (stable).
void canonicalize(DetectedBoundary& boundary);

}  // namespace pfm

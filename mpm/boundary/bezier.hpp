// Composite Bezier curves through the edge points of a detected boundary (thesis 4.1).
//
// Conventions (inherited from pfm::Contour, mpm/detect/contour.hpp):
// * Material lies on the LEFT of the curve when walking along increasing parameter, so the
//   outward normal is the tangent turned clockwise: n = (B'_y, -B'_x) / |B'|.
// * A closed composite curve of n edge points has n segments (the last one returns to the
//   first point); an open one has n - 1.
// * Every segment is parameterised over t in [0, 1] (uniform parameterisation of the composite
//   curve: segment j covers the global parameter [j, j + 1]).
// Lengths in m.
//
// Constructions (make_composite_bezier):
// * kLinear: the edge points joined by straight segments (C0).
// * kQuadratic: one middle control point per segment, local and stable (the thesis's global
//   C1 quadratic oscillates, 4.1.1). For the segment P_j -> P_j+1 the middle point is the
//   average of the two parabola predictions  P_j + (P_j+1 - P_j-1) / 4  (parabola through
//   P_j-1, P_j, P_j+1 at uniform parameters) and  P_j+1 - (P_j+2 - P_j) / 4  (parabola through
//   P_j, P_j+1, P_j+2); at an open end only the available one is used, a lone segment stays
//   straight. Exact (and then C1) for points sampled at uniform parameter steps from one
//   parabola, straight for collinear points; otherwise C0 with a small tangent jump.
// * kCubicC2: the C2 interpolating composite cubic, middle points Q from thesis eq. 4.3 with
//   eq. 4.4 (closed) or eq. 4.5 (open). ERRATUM: the second line of eq. 4.4 as printed,
//   2 Q_1 - Q_2 + 2 Q_2m - Q_2m-1 = 0, is not the C2 condition at P_0; the C2 condition (the
//   same as the i-odd line of eq. 4.3 wrapped around) is  Q_2m-1 - 2 Q_2m + 2 Q_1 - Q_2 = 0,
//   which we use. Eliminating Q_2j = 2 P_j - Q_2j+1 gives one unknown A_j = Q_2j-1 per segment
//   and the [1 4 1] system  A_j-1 + 4 A_j + A_j+1 = 4 P_j-1 + 2 P_j  (cyclic when closed,
//   Sherman-Morrison; open: A_1 and Q_2m fixed by eq. 4.5, Thomas algorithm).
// * kCatmullRom: the local C1 alternative, tangents (P_j+1 - P_j-1) / 2 (one-sided at open
//   ends), middle points P_j + T_j / 3 and P_j+1 - T_j+1 / 3.
#pragma once

#include <array>
#include <string_view>
#include <utility>
#include <vector>

#include "mpm/core/grid.hpp"
#include "mpm/core/types.hpp"
#include "mpm/detect/contour.hpp"

namespace pfm::boundary {

/// One Bezier curve of degree 1, 2 or 3 (thesis eq. 4.1-4.2); control[0..degree] are used.
struct BezierSegment {
  int degree = 1;
  std::array<Vec2, 4> control{Vec2::Zero(), Vec2::Zero(), Vec2::Zero(), Vec2::Zero()};

  static BezierSegment line(const Vec2& a, const Vec2& b);
  static BezierSegment quadratic(const Vec2& a, const Vec2& c, const Vec2& b);
  static BezierSegment cubic(const Vec2& a, const Vec2& c, const Vec2& d, const Vec2& b);

  const Vec2& start() const { return control[0]; }
  const Vec2& end() const { return control[degree]; }
  /// B(t), de Casteljau.
  Vec2 point(double t) const;
  /// B'(t), thesis eq. 6.7 (a Bezier curve of degree n - 1 with points n (P_i+1 - P_i)).
  Vec2 derivative(double t) const;
  /// B''(t).
  Vec2 second_derivative(double t) const;
  /// Outward unit normal (material on the left): the unit tangent turned clockwise.
  /// Zero where B'(t) = 0.
  Vec2 outward_normal(double t) const;
  /// Power-basis coefficients of coordinate `axis` (0 = x, 1 = y): c0 + c1 t + c2 t^2 + c3 t^3.
  std::array<double, 4> power_coefficients(int axis) const;
  /// The two halves at parameter t (de Casteljau), each reparameterised over [0, 1].
  std::pair<BezierSegment, BezierSegment> split(double t) const;
  /// The part over [t0, t1], reparameterised over [0, 1].
  BezierSegment sub_segment(double t0, double t1) const;
  /// Arc length over [t0, t1] (thesis eq. 6.10), adaptive Gauss-Legendre to ~1e-14 relative.
  double length(double t0 = 0.0, double t1 = 1.0) const;
  /// True when every control point lies on the chord (within 1e-14 of its length).
  bool is_straight() const;
};

enum class CurveKind { kLinear, kQuadratic, kCubicC2, kCatmullRom };

/// "linear", "quadratic", "cubic", "catmull_rom".
CurveKind curve_kind_from_name(std::string_view name);
std::string_view curve_kind_name(CurveKind kind);

/// A composite Bezier curve (segment j covers the global parameter [j, j + 1]).
struct CompositeBezier {
  std::vector<BezierSegment> segments;
  bool closed = false;

  int n_segments() const { return static_cast<int>(segments.size()); }
  /// Point at global parameter s in [0, n_segments()].
  Vec2 point(double s) const;
  double length() const;
};

/// Composite curve of the given kind through the contour's points (see the header comment).
/// Fewer than 2 points give an empty curve.
CompositeBezier make_composite_bezier(const Contour& contour, CurveKind kind);
std::vector<CompositeBezier> make_composite_beziers(const std::vector<Contour>& contours,
                                                    CurveKind kind);

/// The middle control points Q_1 ... Q_2m of the C2 composite cubic through `points`
/// (thesis eq. 4.3 with 4.4 corrected, or 4.5), in the thesis's order: segment j (1-based)
/// has control points P_j-1, Q_2j-1, Q_2j, P_j. For a closed curve P_m = P_0 is not repeated
/// in `points` (m = points.size()); for an open one m = points.size() - 1.
std::vector<Vec2> c2_middle_points(const std::vector<Vec2>& points, bool closed);

/// Sorted parameters t in (0, 1) where coordinate `axis` of the segment equals `value`
/// (real roots of a cubic in t). Robust: the parameter range is cut at the roots of the
/// derivative into monotone parts, and each sign change is refined by safeguarded Newton
/// steps; a coordinate that is constant along the segment gives no crossings.
/// Appends to `roots` (no allocation once `roots` has capacity).
void coordinate_crossings(const BezierSegment& segment, int axis, double value,
                          std::vector<double>& roots);

/// Sorted, de-duplicated parameters in [t0, t1], including t0 and t1, that cut the segment
/// where it crosses grid lines (x = x0 + i h, y = y0 + j h), so each piece lies in one cell.
/// Writes into `breaks` (cleared first).
void grid_crossing_parameters(const BezierSegment& segment, const Grid& grid, double t0, double t1,
                              std::vector<double>& breaks);

/// The segment cut into pieces that each lie in one grid cell.
std::vector<BezierSegment> split_at_grid_lines(const BezierSegment& segment, const Grid& grid);

/// The parts of the segment with x in [x_min, x_max], each as a parameter interval of the
/// segment (sorted, adjacent parts merged).
std::vector<std::pair<double, double>> x_interval_parameters(const BezierSegment& segment,
                                                             double x_min, double x_max);
/// The same parts as segments reparameterised over [0, 1].
std::vector<BezierSegment> clip_to_x_interval(const BezierSegment& segment, double x_min,
                                              double x_max);

}  // namespace pfm::boundary

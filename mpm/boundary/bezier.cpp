#include "mpm/boundary/bezier.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "mpm/boundary/gauss_quadrature.hpp"
#include "mpm/boundary/tridiagonal.hpp"

namespace pfm::boundary {

namespace {

double coordinate(const Vec2& p, int axis) {
  return axis == 0 ? p.x() : p.y();
}

double horner(const std::array<double, 4>& c, double t) {
  return ((c[3] * t + c[2]) * t + c[1]) * t + c[0];
}
double horner_derivative(const std::array<double, 4>& c, double t) {
  return (3.0 * c[3] * t + 2.0 * c[2]) * t + c[1];
}

// Roots in (0, 1) of a + b t + c t^2 (numerically stable quadratic formula), appended sorted.
int quadratic_roots_in_unit_interval(double c0, double c1, double c2, std::array<double, 2>& out) {
  int n = 0;
  auto push = [&](double t) {
    if (t > 0.0 && t < 1.0) out[n++] = t;
  };
  const double scale = std::max({std::abs(c0), std::abs(c1), std::abs(c2)});
  if (scale == 0.0) return 0;
  if (std::abs(c2) <= 1e-14 * scale) {
    if (std::abs(c1) > 1e-14 * scale) push(-c0 / c1);
  } else {
    const double discriminant = c1 * c1 - 4.0 * c2 * c0;
    if (discriminant >= 0.0) {
      const double q = -0.5 * (c1 + std::copysign(std::sqrt(discriminant), c1));
      push(q / c2);
      if (q != 0.0) push(c0 / q);
    }
  }
  if (n == 2 && out[0] > out[1]) std::swap(out[0], out[1]);
  return n;
}

// Root of the monotone cubic c on [lo, hi] where c(lo) and c(hi) have opposite signs:
// Newton steps kept inside the bracket, bisection otherwise.
double refine_root(const std::array<double, 4>& c, double lo, double hi) {
  double f_lo = horner(c, lo);
  double t = 0.5 * (lo + hi);
  for (int iteration = 0; iteration < 200; ++iteration) {
    const double f = horner(c, t);
    if (f == 0.0) return t;
    if ((f < 0.0) == (f_lo < 0.0)) {
      lo = t;
      f_lo = f;
    } else {
      hi = t;
    }
    if (hi - lo <= 2e-16 * std::max(1.0, std::abs(t))) return 0.5 * (lo + hi);
    const double slope = horner_derivative(c, t);
    double next = slope != 0.0 ? t - f / slope : 0.5 * (lo + hi);
    if (!(next > lo && next < hi)) next = 0.5 * (lo + hi);
    if (std::abs(next - t) <= 1e-17) return next;
    t = next;
  }
  return t;
}

void sort_unique(std::vector<double>& values, double tolerance) {
  std::sort(values.begin(), values.end());
  std::size_t kept = 0;
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (kept == 0 || values[i] - values[kept - 1] > tolerance) values[kept++] = values[i];
  }
  values.resize(kept);
}

}  // namespace

BezierSegment BezierSegment::line(const Vec2& a, const Vec2& b) {
  BezierSegment s;
  s.degree = 1;
  s.control = {a, b, Vec2::Zero(), Vec2::Zero()};
  return s;
}
BezierSegment BezierSegment::quadratic(const Vec2& a, const Vec2& c, const Vec2& b) {
  BezierSegment s;
  s.degree = 2;
  s.control = {a, c, b, Vec2::Zero()};
  return s;
}
BezierSegment BezierSegment::cubic(const Vec2& a, const Vec2& c, const Vec2& d, const Vec2& b) {
  BezierSegment s;
  s.degree = 3;
  s.control = {a, c, d, b};
  return s;
}

Vec2 BezierSegment::point(double t) const {
  std::array<Vec2, 4> p = control;
  for (int level = degree; level > 0; --level) {
    for (int i = 0; i < level; ++i) p[i] = (1.0 - t) * p[i] + t * p[i + 1];
  }
  return p[0];
}

Vec2 BezierSegment::derivative(double t) const {
  // Thesis eq. 6.7: a Bezier curve of degree n - 1 with points n (P_i+1 - P_i).
  std::array<Vec2, 3> d;
  for (int i = 0; i < degree; ++i) d[i] = degree * (control[i + 1] - control[i]);
  for (int level = degree - 1; level > 0; --level) {
    for (int i = 0; i < level; ++i) d[i] = (1.0 - t) * d[i] + t * d[i + 1];
  }
  return d[0];
}

Vec2 BezierSegment::second_derivative(double t) const {
  if (degree < 2) return Vec2::Zero();
  std::array<Vec2, 2> d;
  for (int i = 0; i + 1 < degree; ++i) {
    d[i] = degree * (degree - 1) * (control[i + 2] - 2.0 * control[i + 1] + control[i]);
  }
  if (degree == 3) return (1.0 - t) * d[0] + t * d[1];
  return d[0];
}

Vec2 BezierSegment::outward_normal(double t) const {
  const Vec2 tangent = derivative(t);
  const double speed = tangent.norm();
  if (speed == 0.0) return Vec2::Zero();
  return Vec2(tangent.y(), -tangent.x()) / speed;
}

std::array<double, 4> BezierSegment::power_coefficients(int axis) const {
  const double p0 = coordinate(control[0], axis), p1 = coordinate(control[1], axis);
  switch (degree) {
    case 1:
      return {p0, p1 - p0, 0.0, 0.0};
    case 2: {
      const double p2 = coordinate(control[2], axis);
      return {p0, 2.0 * (p1 - p0), p0 - 2.0 * p1 + p2, 0.0};
    }
    default: {
      const double p2 = coordinate(control[2], axis), p3 = coordinate(control[3], axis);
      return {p0, 3.0 * (p1 - p0), 3.0 * (p0 - 2.0 * p1 + p2), p3 - p0 + 3.0 * (p1 - p2)};
    }
  }
}

std::pair<BezierSegment, BezierSegment> BezierSegment::split(double t) const {
  // de Casteljau: the left half takes the first point of every level, the right the last.
  BezierSegment left = *this, right = *this;
  std::array<Vec2, 4> p = control;
  left.control[0] = p[0];
  right.control[degree] = p[degree];
  for (int level = degree; level > 0; --level) {
    for (int i = 0; i < level; ++i) p[i] = (1.0 - t) * p[i] + t * p[i + 1];
    left.control[degree - level + 1] = p[0];
    right.control[level - 1] = p[level - 1];
  }
  return {left, right};
}

BezierSegment BezierSegment::sub_segment(double t0, double t1) const {
  if (t0 <= 0.0 && t1 >= 1.0) return *this;
  if (t1 <= 0.0 || t0 >= 1.0 || t1 <= t0) {
    // Degenerate request: the point at t0.
    BezierSegment s = *this;
    const Vec2 p = point(std::clamp(t0, 0.0, 1.0));
    for (int i = 0; i <= degree; ++i) s.control[i] = p;
    return s;
  }
  BezierSegment tail = t0 > 0.0 ? split(t0).second : *this;
  if (t1 >= 1.0) return tail;
  return tail.split((t1 - t0) / (1.0 - t0)).first;
}

double BezierSegment::length(double t0, double t1) const {
  if (degree == 1) return (t1 - t0) * (control[1] - control[0]).norm();
  double polygon = 0.0;
  for (int i = 0; i < degree; ++i) polygon += (control[i + 1] - control[i]).norm();
  if (polygon == 0.0) return 0.0;
  return adaptive_gauss([this](double t) { return derivative(t).norm(); }, t0, t1,
                        1e-14 * polygon * std::abs(t1 - t0));
}

bool BezierSegment::is_straight() const {
  const Vec2 chord = end() - start();
  const double chord_length = chord.norm();
  if (degree == 1) return true;
  if (chord_length == 0.0) return false;
  const Vec2 direction = chord / chord_length;
  double previous = 0.0;
  for (int i = 1; i <= degree; ++i) {
    const Vec2 offset = control[i] - start();
    const double along = offset.dot(direction);
    const double across = offset.x() * direction.y() - offset.y() * direction.x();
    if (std::abs(across) > 1e-14 * chord_length) return false;
    if (along < previous) return false;  // the parameter would run back along the line
    previous = along;
  }
  return true;
}

CurveKind curve_kind_from_name(std::string_view name) {
  if (name == "linear") return CurveKind::kLinear;
  if (name == "quadratic") return CurveKind::kQuadratic;
  if (name == "cubic") return CurveKind::kCubicC2;
  if (name == "catmull_rom") return CurveKind::kCatmullRom;
  throw std::invalid_argument("unknown curve kind \"" + std::string(name) + "\"");
}

std::string_view curve_kind_name(CurveKind kind) {
  switch (kind) {
    case CurveKind::kLinear:
      return "linear";
    case CurveKind::kQuadratic:
      return "quadratic";
    case CurveKind::kCubicC2:
      return "cubic";
    case CurveKind::kCatmullRom:
      return "catmull_rom";
  }
  return "linear";
}

Vec2 CompositeBezier::point(double s) const {
  const int n = n_segments();
  const int j = std::clamp(static_cast<int>(std::floor(s)), 0, n - 1);
  return segments[j].point(s - j);
}

double CompositeBezier::length() const {
  double total = 0.0;
  for (const auto& segment : segments) total += segment.length();
  return total;
}

std::vector<Vec2> c2_middle_points(const std::vector<Vec2>& points, bool closed) {
  const int n_points = static_cast<int>(points.size());
  const int m = closed ? n_points : n_points - 1;  // number of segments
  if (m < 1 || (closed && m < 2)) {
    throw std::invalid_argument("c2_middle_points: too few points");
  }
  auto P = [&](int j) -> const Vec2& { return points[((j % n_points) + n_points) % n_points]; };
  // first[j] = A_j+1 = Q_2j+1 (0-based segment j); Q_2j+2 = 2 P_j+1 - A_j+2 (C1, eq. 4.3).
  std::vector<Vec2> first(m);
  Vec2 last_second = Vec2::Zero();  // Q_2m for an open curve (eq. 4.5)
  if (closed) {
    // A_j-1 + 4 A_j + A_j+1 = 4 P_j-1 + 2 P_j, j = 1..m, indices modulo m.
    std::vector<Vec2> rhs(m);
    for (int j = 1; j <= m; ++j) rhs[j - 1] = 4.0 * P(j - 1) + 2.0 * P(j);
    if (m == 2) {
      // [[4, 2], [2, 4]] A = rhs.
      first[0] = (4.0 * rhs[0] - 2.0 * rhs[1]) / 12.0;
      first[1] = (4.0 * rhs[1] - 2.0 * rhs[0]) / 12.0;
    } else {
      first = solve_cyclic_tridiagonal(std::vector<double>(m, 1.0), std::vector<double>(m, 4.0),
                                       std::vector<double>(m, 1.0), rhs);
    }
  } else {
    first[0] = 0.75 * P(0) + 0.25 * P(1);         // eq. 4.5, Q_1
    last_second = 0.75 * P(m) + 0.25 * P(m - 1);  // eq. 4.5, Q_2m
    if (m >= 2) {
      // Unknowns A_2 .. A_m. Rows j = 1 .. m-2: A_j + 4 A_j+1 + A_j+2 = 4 P_j + 2 P_j+1;
      // last row (C2 at P_m-1 with Q_2m known): A_m-1 + 4 A_m = 4 P_m-1 + Q_2m.
      const int n = m - 1;
      std::vector<double> lower(n, 1.0), diag(n, 4.0), upper(n, 1.0);
      std::vector<Vec2> rhs(n);
      for (int r = 0; r < n; ++r) {
        const int j = r + 1;
        rhs[r] =
            (r == n - 1) ? Vec2(4.0 * P(m - 1) + last_second) : Vec2(4.0 * P(j) + 2.0 * P(j + 1));
      }
      rhs[0] -= first[0];  // A_1 is known
      if (n == 1) {
        first[1] = rhs[0] / 4.0;
      } else {
        const std::vector<Vec2> unknowns = solve_tridiagonal(lower, diag, upper, rhs);
        for (int r = 0; r < n; ++r) first[r + 1] = unknowns[r];
      }
    }
  }
  std::vector<Vec2> middle(2 * m);
  for (int j = 0; j < m; ++j) {
    middle[2 * j] = first[j];
    if (j + 1 < m) {
      middle[2 * j + 1] = 2.0 * P(j + 1) - first[j + 1];
    } else {
      middle[2 * j + 1] = closed ? Vec2(2.0 * P(0) - first[0]) : last_second;
    }
  }
  return middle;
}

CompositeBezier make_composite_bezier(const Contour& contour, CurveKind kind) {
  CompositeBezier curve;
  curve.closed = contour.closed;
  const auto& points = contour.points;
  const int n_points = static_cast<int>(points.size());
  if (n_points < 2) return curve;
  const bool closed = contour.closed;
  const int m = closed ? n_points : n_points - 1;
  auto P = [&](int j) -> const Vec2& { return points[((j % n_points) + n_points) % n_points]; };
  auto has = [&](int j) { return closed || (j >= 0 && j < n_points); };
  curve.segments.reserve(m);
  switch (kind) {
    case CurveKind::kLinear:
      for (int j = 0; j < m; ++j) curve.segments.push_back(BezierSegment::line(P(j), P(j + 1)));
      break;
    case CurveKind::kQuadratic:
      for (int j = 0; j < m; ++j) {
        Vec2 sum = Vec2::Zero();
        int count = 0;
        if (has(j - 1)) sum += P(j) + 0.25 * (P(j + 1) - P(j - 1)), ++count;
        if (has(j + 2)) sum += P(j + 1) - 0.25 * (P(j + 2) - P(j)), ++count;
        const Vec2 middle = count > 0 ? Vec2(sum / count) : Vec2(0.5 * (P(j) + P(j + 1)));
        curve.segments.push_back(BezierSegment::quadratic(P(j), middle, P(j + 1)));
      }
      break;
    case CurveKind::kCubicC2: {
      const std::vector<Vec2> middle = c2_middle_points(points, closed);
      for (int j = 0; j < m; ++j) {
        curve.segments.push_back(
            BezierSegment::cubic(P(j), middle[2 * j], middle[2 * j + 1], P(j + 1)));
      }
      break;
    }
    case CurveKind::kCatmullRom: {
      auto tangent = [&](int j) -> Vec2 {
        if (closed || (j > 0 && j < n_points - 1)) return 0.5 * (P(j + 1) - P(j - 1));
        return j == 0 ? Vec2(P(1) - P(0)) : Vec2(P(n_points - 1) - P(n_points - 2));
      };
      for (int j = 0; j < m; ++j) {
        curve.segments.push_back(BezierSegment::cubic(P(j), P(j) + tangent(j) / 3.0,
                                                      P(j + 1) - tangent(j + 1) / 3.0, P(j + 1)));
      }
      break;
    }
  }
  return curve;
}

std::vector<CompositeBezier> make_composite_beziers(const std::vector<Contour>& contours,
                                                    CurveKind kind) {
  std::vector<CompositeBezier> curves;
  curves.reserve(contours.size());
  for (const auto& contour : contours) curves.push_back(make_composite_bezier(contour, kind));
  return curves;
}

void coordinate_crossings(const BezierSegment& segment, int axis, double value,
                          std::vector<double>& roots) {
  std::array<double, 4> c = segment.power_coefficients(axis);
  c[0] -= value;
  double scale = 0.0;
  for (int i = 0; i <= segment.degree; ++i) {
    scale = std::max(scale, std::abs(coordinate(segment.control[i], axis) - value));
  }
  const double variation = std::max({std::abs(c[1]), std::abs(c[2]), std::abs(c[3])});
  if (variation <= 1e-15 * std::max(scale, std::abs(value))) return;  // constant coordinate
  // Monotone parts: cut at the roots of c1 + 2 c2 t + 3 c3 t^2 in (0, 1).
  std::array<double, 2> critical{};
  const int n_critical = quadratic_roots_in_unit_interval(c[1], 2.0 * c[2], 3.0 * c[3], critical);
  std::array<double, 4> cuts{0.0, 1.0, 1.0, 1.0};
  int n_cuts = 1;
  for (int i = 0; i < n_critical; ++i) cuts[n_cuts++] = critical[i];
  cuts[n_cuts++] = 1.0;
  for (int part = 0; part + 1 < n_cuts; ++part) {
    const double lo = cuts[part], hi = cuts[part + 1];
    if (hi <= lo) continue;
    const double f_lo = horner(c, lo), f_hi = horner(c, hi);
    if (f_lo == 0.0) {
      if (lo > 0.0) roots.push_back(lo);
    } else if ((f_lo < 0.0) != (f_hi < 0.0) && f_hi != 0.0) {
      roots.push_back(refine_root(c, lo, hi));
    }
  }
}

void grid_crossing_parameters(const BezierSegment& segment, const Grid& grid, double t0, double t1,
                              std::vector<double>& breaks) {
  breaks.clear();
  const double h = grid.cell_size;
  for (int axis = 0; axis < 2; ++axis) {
    double low = coordinate(segment.control[0], axis), high = low;
    for (int i = 1; i <= segment.degree; ++i) {
      low = std::min(low, coordinate(segment.control[i], axis));
      high = std::max(high, coordinate(segment.control[i], axis));
    }
    const double origin = coordinate(grid.origin, axis);
    const int first_line = static_cast<int>(std::ceil((low - origin) / h));
    const int last_line = static_cast<int>(std::floor((high - origin) / h));
    for (int line = first_line; line <= last_line; ++line) {
      coordinate_crossings(segment, axis, origin + line * h, breaks);
    }
  }
  std::size_t kept = 0;
  for (const double t : breaks) {
    if (t > t0 && t < t1) breaks[kept++] = t;
  }
  breaks.resize(kept);
  breaks.push_back(t0);
  breaks.push_back(t1);
  sort_unique(breaks, 1e-14);
  if (breaks.back() != t1) breaks.back() = t1;  // keep the exact end after de-duplication
}

std::vector<BezierSegment> split_at_grid_lines(const BezierSegment& segment, const Grid& grid) {
  std::vector<double> breaks;
  grid_crossing_parameters(segment, grid, 0.0, 1.0, breaks);
  std::vector<BezierSegment> pieces;
  for (std::size_t i = 0; i + 1 < breaks.size(); ++i) {
    pieces.push_back(segment.sub_segment(breaks[i], breaks[i + 1]));
  }
  return pieces;
}

std::vector<std::pair<double, double>> x_interval_parameters(const BezierSegment& segment,
                                                             double x_min, double x_max) {
  std::vector<double> breaks;
  coordinate_crossings(segment, 0, x_min, breaks);
  coordinate_crossings(segment, 0, x_max, breaks);
  breaks.push_back(0.0);
  breaks.push_back(1.0);
  sort_unique(breaks, 1e-14);
  breaks.back() = 1.0;
  std::vector<std::pair<double, double>> parts;
  for (std::size_t i = 0; i + 1 < breaks.size(); ++i) {
    const double x = segment.point(0.5 * (breaks[i] + breaks[i + 1])).x();
    if (x < x_min || x > x_max) continue;
    if (!parts.empty() && parts.back().second == breaks[i]) {
      parts.back().second = breaks[i + 1];
    } else {
      parts.emplace_back(breaks[i], breaks[i + 1]);
    }
  }
  return parts;
}

std::vector<BezierSegment> clip_to_x_interval(const BezierSegment& segment, double x_min,
                                              double x_max) {
  std::vector<BezierSegment> clipped;
  for (const auto& [t0, t1] : x_interval_parameters(segment, x_min, x_max)) {
    clipped.push_back(segment.sub_segment(t0, t1));
  }
  return clipped;
}

}  // namespace pfm::boundary

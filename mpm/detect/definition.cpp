// The pieces of the improved detector's definition that both detectors call (detect_internal.hpp
// declares them): the fast path (improved_detector.cpp) and the definition written plainly
// (reference_detector.cpp) include this file's declarations and neither calls the other. Here:
// the refinement of a pass, what the contours of a pass call for next and the removal of the
// loops the spacing cannot resolve, the containment check's geometry (fine cells, segments by
// cell, the nearest segment), the Chebyshev distance of the bridges, the stretch cap of the
// kernels and the optional curvature correction. Defined elsewhere: the kernel in kernel.hpp;
// the wall rule in ImprovedField; the loops' classes and the bridges' pairs in loop_classes.cpp.
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <optional>
#include <span>
#include <vector>

#include "mpm/detect/detect_internal.hpp"
#include "mpm/detect/improved_field.hpp"
#include "mpm/detect/kernel.hpp"
#include "mpm/detect/loop_classes.hpp"

namespace pfm::detail {

double chebyshev_distance(const Vec2& x, const Vec2& a, const Vec2& b) {
  // max(|e_x - t d_x|, |e_y - t d_y|) (e = x - a, d = b - a) is convex and piecewise linear in t:
  // least on [0, 1] at an end or where a term vanishes or the two are equal.
  const Vec2 e = x - a, d = b - a;
  const auto at = [&](double t) {
    t = std::clamp(t, 0.0, 1.0);
    return std::max(std::abs(e.x() - t * d.x()), std::abs(e.y() - t * d.y()));
  };
  double best = std::min(at(0.0), at(1.0));
  if (d.x() != 0.0) best = std::min(best, at(e.x() / d.x()));
  if (d.y() != 0.0) best = std::min(best, at(e.y() / d.y()));
  if (d.x() != d.y()) best = std::min(best, at((e.x() - e.y()) / (d.x() - d.y())));
  if (d.x() != -d.y()) best = std::min(best, at((e.x() + e.y()) / (d.x() + d.y())));
  return best;
}

int pass_refinement(const ImprovedConfig& config, int pass, double smallest_guard_axis, double h,
                    double spacing) {
  if (config.refinement > 0) return config.refinement;
  // Fine cells of at most half a spacing (the rounding's 1e-9 keeps 2 x 2 points per cell at 4;
  // capped before the conversion, as below: a spacing of nothing asks for any refinement).
  const int base = static_cast<int>(std::clamp(std::ceil(2.0 * h / spacing - 1e-9), 4.0, 1e6));
  // Joining the spurious loops, the second pass (the bridges) keeps the first's refinement.
  const int base_passes = config.join_spurious_loops ? 2 : 1;
  const double axis =
      pass < base_passes ? std::numeric_limits<double>::infinity() : smallest_guard_axis;
  // (Capped before the conversion: a guard squeezed to nothing asks for any refinement.)
  const int refinement = std::isfinite(axis)
                             ? static_cast<int>(std::min(std::ceil(h * std::sqrt(2.0) / axis), 1e6))
                             : base;
  // Kernels shaped by the neighbours narrow their guards by up to sqrt(1 - beta) across: the cap
  // grows as much, so that it covers the guards of F as it does without the option.
  const int cap = static_cast<int>(
      std::ceil(std::max(1, config.max_refinement) / std::sqrt(1.0 - config.neighbour_shape)));
  return std::clamp(std::max(refinement, base), 1, cap);
}

std::optional<NextPass> next_pass(const ImprovedConfig& config, int pass,
                                  const DetectedBoundary& boundary, std::span<const Vec2> positions,
                                  std::span<const std::size_t> left_out, double spacing,
                                  std::optional<LoopClasses>& classes, DetectionTimings& timings) {
  if (config.guard_factor <= 0.0) return std::nullopt;
  const bool join = config.join_spurious_loops && config.guard_factor > 0.0;
  NextPass next;
  next.bridging = pass == 0 && join;
  if (next.bridging) {
    if (boundary.contours.size() > 1) classes = classify_loops(boundary, positions, spacing);
    next.pairs = bridge_pairs(positions, left_out, classes.value_or(LoopClasses{}), spacing);
    if (left_out.empty() && next.pairs.empty()) return std::nullopt;
  } else if (left_out.empty() || pass == (join ? 2 : 1)) {
    return std::nullopt;
  } else {
    timings.guard_refinement_passes += 1;
  }
  if (pass == 0) timings.particles_outside_first_contours = static_cast<long>(left_out.size());
  return next;
}

void remove_unresolved_loops(const ImprovedConfig& config, DetectedBoundary& boundary,
                             std::span<const Vec2> positions, double spacing,
                             std::optional<LoopClasses>& classes, DetectionTimings& timings) {
  if (!config.join_spurious_loops || !(config.guard_factor > 0.0)) return;
  if (boundary.contours.size() <= 1) return;
  if (!classes) classes = classify_loops(boundary, positions, spacing);
  timings.spurious_loops_removed = remove_spurious_loops(boundary, *classes);
}

bool fine_cell(const NodalField& nodes, const Vec2& x, int& i, int& j) {
  const double u = std::floor((x.x() - nodes.origin.x()) / nodes.spacing);
  const double v = std::floor((x.y() - nodes.origin.y()) / nodes.spacing);
  i = static_cast<int>(std::clamp(u, 0.0, nodes.n_x - 2.0));
  j = static_cast<int>(std::clamp(v, 0.0, nodes.n_y - 2.0));
  return u >= 0.0 && v >= 0.0 && u < nodes.n_x - 1 && v < nodes.n_y - 1;
}

std::vector<CellSegment> segments_by_cell(const DetectedBoundary& boundary,
                                          const NodalField& nodes) {
  std::vector<CellSegment> segments;
  for (const Contour& c : boundary.contours) {
    const std::size_t n = c.points.size();
    for (std::size_t k = 0; k + 1 < n || (c.closed && k < n); ++k) {
      const Vec2& a = c.points[k];
      const Vec2& b = c.points[(k + 1) % n];
      int i = 0, j = 0;
      fine_cell(nodes, 0.5 * (a + b), i, j);
      segments.push_back({j * (nodes.n_x - 1) + i, a, b});
    }
  }
  std::stable_sort(segments.begin(), segments.end(),
                   [](const CellSegment& x, const CellSegment& y) { return x.cell < y.cell; });
  return segments;
}

std::span<const CellSegment> segments_in(const std::vector<CellSegment>& segments, int cell) {
  const auto by_cell = [](const CellSegment& x, const CellSegment& y) { return x.cell < y.cell; };
  const auto [first, last] =
      std::equal_range(segments.begin(), segments.end(), CellSegment{cell, {}, {}}, by_cell);
  return {first, last};
}

bool outside_nearest_segment(std::span<const CellSegment> segments, const Vec2& x) {
  const CellSegment* nearest = nullptr;
  double best = std::numeric_limits<double>::infinity();
  for (const CellSegment& s : segments) {
    const Vec2 d = s.b - s.a;
    const double t = std::clamp((x - s.a).dot(d) / std::max(d.squaredNorm(), 1e-300), 0.0, 1.0);
    const double distance = (s.a + t * d - x).squaredNorm();
    if (distance < best) {
      best = distance;
      nearest = &s;
    }
  }
  if (nearest == nullptr) return false;
  const Vec2 d = nearest->b - nearest->a, e = x - nearest->a;
  return d.x() * e.y() - d.y() * e.x() < 0.0;
}

void cap_stretch(std::vector<Mat2>& deformation, double cap, std::span<double> volume) {
  const double floor = 1.0 / cap;
  for (std::size_t p = 0; p < deformation.size(); ++p) {
    Mat2& f = deformation[p];
    double largest = 0.0, smallest = 0.0;
    singular_values(f, largest, smallest);
    if (largest <= cap && smallest >= floor) continue;
    // F' = F (k1 P1 + k2 P2), k the clamped singular values over the raw ones (not zero: det F
    // is checked to be > 0) and P the projectors on the right singular vectors: P1 + P2 = I and,
    // where the singular values differ, P1 = (F^T F - s2^2 I) / (s1^2 - s2^2) (where they do not,
    // k1 = k2). No angle, so no trigonometric function.
    const double k1 = std::clamp(largest, floor, cap) / largest;
    const double k2 = std::clamp(smallest, floor, cap) / smallest;
    Mat2 m = k2 * Mat2::Identity();
    if (k1 != k2) {
      m += (k1 - k2) / ((largest - smallest) * (largest + smallest)) *
           (f.transpose() * f - smallest * smallest * Mat2::Identity());
    }
    f = f * m;
    if (!volume.empty()) volume[p] *= k1 * k2;
  }
}

void correct_curvature(DetectedBoundary& boundary, double moment, double arc) {
  for (auto& contour : boundary.contours) {
    const int n = static_cast<int>(contour.points.size());
    if (n < 3) continue;
    const auto& pts = contour.points;
    std::vector<Vec2> moved = pts;
    for (int k = 0; k < n; ++k) {
      if (!contour.closed && (k == 0 || k == n - 1)) continue;
      // Walk back and forth until the chord length reaches `arc` (or the walk runs out).
      int back = k, ahead = k;
      double length = 0.0;
      for (int step = 0; step < n - 1 && length < arc; ++step) {
        const int next = contour.closed ? (back - 1 + n) % n : back - 1;
        if (next < 0) break;
        length += (pts[back] - pts[next]).norm();
        back = next;
      }
      length = 0.0;
      for (int step = 0; step < n - 1 && length < arc; ++step) {
        const int next = contour.closed ? (ahead + 1) % n : ahead + 1;
        if (next >= n) break;
        length += (pts[next] - pts[ahead]).norm();
        ahead = next;
      }
      if (back == k || ahead == k || back == ahead) continue;
      const Vec2 u = pts[k] - pts[back], v = pts[ahead] - pts[k], w = pts[ahead] - pts[back];
      const double denominator = u.norm() * v.norm() * w.norm();
      if (denominator <= 0.0) continue;
      const double kappa = 2.0 * (u.x() * v.y() - u.y() * v.x()) / denominator;  // left turn > 0
      const Vec2 tangent = w.normalized();
      const Vec2 left_normal(-tangent.y(), tangent.x());  // points into the material
      moved[k] = pts[k] - 0.5 * kappa * moment * left_normal;
    }
    contour.points = std::move(moved);
  }
}

}  // namespace pfm::detail

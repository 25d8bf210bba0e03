// Gauss-Legendre rules on [-1, 1] (thesis Table 6.1 is the k = 5 rule) and an adaptive
// Gauss-Legendre integrator used for arc lengths, the traction-per-length term and the
// high-order reference of the quadrature study.
#pragma once

#include <array>
#include <cmath>

namespace pfm::boundary {

inline constexpr int kMaxGaussPoints = 20;

/// k-point Gauss-Legendre rule on [-1, 1]: exact for polynomials of degree <= 2k - 1.
struct GaussRule {
  int n_points = 0;
  std::array<double, kMaxGaussPoints> node{};
  std::array<double, kMaxGaussPoints> weight{};
};

/// Nodes by Newton iteration on the Legendre polynomial P_k (to machine precision), weights
/// 2 / ((1 - x^2) P_k'(x)^2). Requires 1 <= k <= kMaxGaussPoints.
GaussRule gauss_legendre(int k);

/// Adaptive integration of a scalar function over [a, b]: a 10-point Gauss rule on an
/// interval is compared with the same rule on its two halves; the halves are accepted when
/// they differ by at most absolute_tolerance * (b - a) / (b0 - a0) (b0 - a0 the whole range)
/// and the depth is >= 2, else
/// each half is refined (depth <= max_depth). Recursion on the stack; no allocation.
template <class Function>
double adaptive_gauss(const Function& f, double a, double b, double absolute_tolerance,
                      int max_depth = 40);

namespace detail {
template <class Function>
double gauss_on(const Function& f, const GaussRule& rule, double a, double b) {
  const double half = 0.5 * (b - a), mid = 0.5 * (a + b);
  double sum = 0.0;
  for (int i = 0; i < rule.n_points; ++i) sum += rule.weight[i] * f(mid + half * rule.node[i]);
  return half * sum;
}
template <class Function>
double adaptive_step(const Function& f, const GaussRule& rule, double a, double b, double whole,
                     double tolerance_per_length, int depth, int max_depth) {
  const double mid = 0.5 * (a + b);
  const double left = gauss_on(f, rule, a, mid);
  const double right = gauss_on(f, rule, mid, b);
  const double halves = left + right;
  if (depth >= max_depth ||
      (depth >= 2 && std::abs(halves - whole) <= tolerance_per_length * (b - a))) {
    return halves;
  }
  return adaptive_step(f, rule, a, mid, left, tolerance_per_length, depth + 1, max_depth) +
         adaptive_step(f, rule, mid, b, right, tolerance_per_length, depth + 1, max_depth);
}
}  // namespace detail

template <class Function>
double adaptive_gauss(const Function& f, double a, double b, double absolute_tolerance,
                      int max_depth) {
  if (b == a) return 0.0;
  static const GaussRule rule = gauss_legendre(10);  // an immutable table
  const double whole = detail::gauss_on(f, rule, a, b);
  return detail::adaptive_step(f, rule, a, b, whole, absolute_tolerance / std::abs(b - a), 0,
                               max_depth);
}

}  // namespace pfm::boundary

// The improved detector's kernel, in one place: the field phi(x) = sum_p V_p W_p(x) takes one
// kernel per particle (and per mirror image),
//
//   W_p(x) = C_p (1 - |S_p^-1 (x - x_p)|^2)_+^k,   S_p = a0 F_p,   C_p det S_p = (k + 1) / pi,
//
// which has unit integral, so phi is a volume fraction (1 deep in a body, 1/2 on a flat face).
// k is the profile (detector.hpp, KernelProfile), a0 = radius_factor x the initial spacing. Its
// normalisation, its moments and the weight V_p C_p of a particle are defined here; the reference
// detector (reference_detector.cpp), the field (improved_field.cpp), the vector sums
// (vector_loops.cpp) and the kernel shapes from the neighbours (neighbour_shape.cpp) read them.
#pragma once

#include <algorithm>
#include <cmath>
#include <numbers>

#include "mpm/core/types.hpp"
#include "mpm/detect/detector.hpp"

namespace pfm::detail {

/// k of the profile (1 Epanechnikov, 2 biweight, 3 triweight).
inline int kernel_exponent(KernelProfile profile) {
  return static_cast<int>(profile);
}

/// C det S = (k + 1) / pi: the constant that gives the kernel unit integral.
inline double kernel_mass_constant(KernelProfile profile) {
  return (kernel_exponent(profile) + 1.0) / std::numbers::pi;
}

/// E[t^2 | n = 0] = a0^2 / (2k + 3) of the undeformed kernel, m^2: the field's level set lies
/// kappa x this / 2 inside a boundary of curvature kappa.
inline double kernel_curvature_moment(KernelProfile profile, double a0) {
  return a0 * a0 / (2.0 * kernel_exponent(profile) + 3.0);
}

/// E[u_x^2] under the weight (1 - |u|^2)^k on the unit disk: 1 / (2 (k + 2)) (the full window's
/// second moment of the kernel shapes from the neighbours).
inline double kernel_window_moment(KernelProfile profile) {
  return 1.0 / (2.0 * (kernel_exponent(profile) + 2.0));
}

/// One kernel as the sums read it: centre (m), S^-1 = [k00 k01; k10 k11] (1/m), the weight
/// V_p C_p (volume fraction) and the half widths of the box around its ellipse {a0 F u : |u| < 1}
/// (m; a0 |row of F|).
struct KernelSlot {
  double x, y, k00, k01, k10, k11, weight, half_x, half_y;
};

/// The kernel of a particle at `x` of volume `volume` (m^2) and deformation gradient `f`
/// (nullptr: undeformed, S = a0 I), a0 in m.
inline KernelSlot kernel_slot(const Vec2& x, double volume, const Mat2* f, double a0,
                              KernelProfile profile) {
  KernelSlot slot{x.x(),
                  x.y(),
                  1.0 / a0,
                  0.0,
                  0.0,
                  1.0 / a0,
                  volume * kernel_mass_constant(profile) / (a0 * a0),
                  a0,
                  a0};
  if (f == nullptr) return slot;
  const Mat2& m = *f;
  const double det_f = m.determinant();
  // S^-1 = F^-1 / a0; C_p = (k + 1) / (pi a0^2 det F).
  const double inverse_scale = 1.0 / (det_f * a0);
  slot.k00 = m(1, 1) * inverse_scale;
  slot.k01 = -m(0, 1) * inverse_scale;
  slot.k10 = -m(1, 0) * inverse_scale;
  slot.k11 = m(0, 0) * inverse_scale;
  slot.weight /= det_f;
  slot.half_x = a0 * std::sqrt(m(0, 0) * m(0, 0) + m(0, 1) * m(0, 1));
  slot.half_y = a0 * std::sqrt(m(1, 0) * m(1, 0) + m(1, 1) * m(1, 1));
  return slot;
}

/// The largest kernel weight V_p C_p of particles with volume <= largest_volume and
/// det F >= smallest_det: what sets the fixed-point unit of the sums (fixed_point_bits()).
inline double kernel_weight_bound(KernelProfile profile, double a0, double largest_volume,
                                  double smallest_det) {
  return largest_volume * kernel_mass_constant(profile) / (a0 * a0) / smallest_det;
}

/// s of the unit 2^-s of the kernel sums: each term of a sum is rounded to a multiple of 2^-s
/// and the integers are added, so that a sum does not depend on the order of its terms. A term
/// of the largest weight (`weight_bound`) stays below 2^45 units and the weights of all `slots`
/// together below 2^63, so that no sum overflows.
inline int fixed_point_bits(double weight_bound, double slots) {
  const double bound = weight_bound > 0.0 ? weight_bound : 1.0;
  int exponent_of_bound = 0, exponent_of_total = 0;
  std::frexp(bound, &exponent_of_bound);  // bound < 2^exponent_of_bound
  std::frexp(bound * std::max(slots, 1.0), &exponent_of_total);
  return std::min(44 - exponent_of_bound, 62 - exponent_of_total);
}

}  // namespace pfm::detail

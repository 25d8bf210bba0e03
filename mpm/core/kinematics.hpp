// Kinematics shared by the MPM and the updated-Lagrangian FEM: from a velocity gradient over a
// time step to the objective strain increment, the spin, and the Jaumann stress rotation.
#pragma once

#include "mpm/core/types.hpp"

namespace pfm {

/// Velocity gradient L = grad v, L(i, j) = d v_i / d x_j, 1/s.
/// Strain increment d = sym(L) dt in (xx, yy, gamma_xy, zz) order, zz = 0 (plane strain).
inline Strain strain_increment(const Mat2& velocity_gradient, double dt) {
  return Strain(velocity_gradient(0, 0) * dt, velocity_gradient(1, 1) * dt,
                (velocity_gradient(0, 1) + velocity_gradient(1, 0)) * dt, 0.0);
}

/// Jaumann rotation of the stress over a step: sigma += (W sigma - sigma W) dt with the spin
/// W = skew(L). In plane strain W has one component w = W(0, 1) = (L01 - L10) / 2, so
///   sxx += 2 w sxy dt,  syy -= 2 w sxy dt,  sxy += w (syy - sxx) dt,  szz unchanged.
/// Applied with the stress at the start of the step (first order, like cb-geo/mpm and Anura3D).
inline void jaumann_rotate(const Mat2& velocity_gradient, double dt, Stress& stress) {
  const double w_dt = 0.5 * (velocity_gradient(0, 1) - velocity_gradient(1, 0)) * dt;
  const double sxx = stress[kXX], syy = stress[kYY], sxy = stress[kXY];
  stress[kXX] = sxx + 2.0 * w_dt * sxy;
  stress[kYY] = syy - 2.0 * w_dt * sxy;
  stress[kXY] = sxy + w_dt * (syy - sxx);
}

/// Deformation gradient update F_{n+1} = (I + L dt) F_n.
inline Mat2 update_deformation_gradient(const Mat2& velocity_gradient, double dt, const Mat2& f) {
  return (Mat2::Identity() + velocity_gradient * dt) * f;
}

}  // namespace pfm

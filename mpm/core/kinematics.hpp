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

/// Anti-locking by the mean dilatation (B-bar) in rate form, plane strain: the velocity gradient
/// of a point with its in-plane dilatation tr L replaced by `mean_trace`, the volume-weighted mean
/// of tr L over the point's cell (MPM) or element (UL-FEM):
///   L_bar = L + (mean_trace - tr L) / 2 I.
/// Spin and deviatoric part are kept, zz stays zero. A cell then enforces one incompressibility
/// constraint, not one per point, which is what locks isochoric plastic flow (Hughes 1980; in
/// the MPM, the cell-based F-bar of Coombs, Charlton, Cortis and Augarde, CMAME 2018).
inline Mat2 mean_dilatation_gradient(const Mat2& velocity_gradient, double mean_trace) {
  const double shift = 0.5 * (mean_trace - velocity_gradient.trace());
  return velocity_gradient + shift * Mat2::Identity();
}

/// The stress whose work with the grid velocities is its work with L_bar: with L_bar of
/// mean_dilatation_gradient, sum_p V_p sigma_p : L_bar,p = sum_p V_p sigma_tilde,p : L_p over a
/// cell, where sigma_tilde has the in-plane mean (sxx + syy) / 2 replaced by the cell's
/// volume-weighted mean `mean_in_plane_trace` / 2 (the internal force of B-bar, B_bar^T sigma).
inline Stress mean_dilatation_stress(const Stress& stress, double mean_in_plane_trace) {
  Stress s = stress;
  const double shift = 0.5 * (mean_in_plane_trace - (stress[kXX] + stress[kYY]));
  s[kXX] += shift;
  s[kYY] += shift;
  return s;
}

/// Deformation gradient update F_{n+1} = (I + L dt) F_n.
inline Mat2 update_deformation_gradient(const Mat2& velocity_gradient, double dt, const Mat2& f) {
  return (Mat2::Identity() + velocity_gradient * dt) * f;
}

}  // namespace pfm

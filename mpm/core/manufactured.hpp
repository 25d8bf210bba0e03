// A manufactured solution of small-strain plane-strain elastodynamics for verification (the
// method of manufactured solutions as Wallstedt and Guilkey 2008 use it for the MPM): a chosen
// displacement field u(X, t) on a rectangle, and the body force b that makes it exact,
//   rho u_tt = div sigma(u) + rho b,  sigma = lambda tr(eps) I + 2 mu eps,  eps = sym grad u.
//
// The field: u(X, t) = A g(t) Phi(X) (1, 1), g = (1 - cos(omega t))^2 / 4 (g(T / 2) = 1),
// Phi = sin(kx (x - x0)) sin(ky (y - y0)), kx = pi / Lx, ky = pi / Ly, omega = 2 pi / T, on the
// rectangle [x0, x0 + Lx] x [y0, y0 + Ly]. It is zero on the rectangle's edges (walls fixed in x
// and y) and starts from rest with zero displacement and stress, so a run needs no special
// initial state. Its acceleration is zero at t = 0 too (g''(0) = 0): the explicit step's first
// velocity is v_0 + dt a_0, not the half step of a centred start, an error of order dt that a
// field starting with an acceleration would carry through the run and that would then dominate
// the spatial error being measured. With Phi_xx = -kx^2 Phi, Phi_yy = -ky^2 Phi,
// Phi_xy = kx ky cos(kx (x - x0)) cos(ky (y - y0)):
//   div sigma = A g [ (lambda + mu) grad(Phi_x + Phi_y) + mu lap(Phi) (1, 1) ],
//   b = A g'' Phi (1, 1) - div sigma / rho,  g'' = omega^2 (sin^2 + (1 - cos) cos)(omega t) / 2.
// Units: m, s, t/m^3, kPa (kN/m^2), b in m/s^2.
#pragma once

#include <cmath>
#include <numbers>

#include "mpm/core/types.hpp"

namespace pfm {

struct ManufacturedSolution {
  double amplitude = 0.0;      ///< A, m
  double period = 0.0;         ///< T, s
  Vec2 origin = Vec2::Zero();  ///< (x0, y0), m
  Vec2 size = Vec2::Ones();    ///< (Lx, Ly), m
  double lambda = 0.0;         ///< Lame's first parameter, kPa
  double mu = 0.0;             ///< shear modulus, kPa
  double density = 1.0;        ///< t/m^3

  double omega() const { return 2.0 * std::numbers::pi / period; }
  /// g(t) = (1 - cos(omega t))^2 / 4.
  double time_factor(double t) const {
    const double c = 1.0 - std::cos(omega() * t);
    return 0.25 * c * c;
  }
  Vec2 wave_numbers() const { return {std::numbers::pi / size.x(), std::numbers::pi / size.y()}; }

  /// u(X, t), m.
  Vec2 displacement(const Vec2& x, double t) const {
    const Vec2 k = wave_numbers();
    const Vec2 s = x - origin;
    const double phi = std::sin(k.x() * s.x()) * std::sin(k.y() * s.y());
    const double u = amplitude * time_factor(t) * phi;
    return {u, u};
  }

  /// The small-strain stress of u(X, t) (xx, yy, xy, zz), kPa.
  Stress stress(const Vec2& x, double t) const {
    const Vec2 k = wave_numbers();
    const Vec2 s = x - origin;
    const double g = amplitude * time_factor(t);
    const double phi_x = k.x() * std::cos(k.x() * s.x()) * std::sin(k.y() * s.y());
    const double phi_y = k.y() * std::sin(k.x() * s.x()) * std::cos(k.y() * s.y());
    // u_x = u_y = g Phi: eps_xx = g Phi_x, eps_yy = g Phi_y, eps_xy = g (Phi_x + Phi_y) / 2.
    const double exx = g * phi_x, eyy = g * phi_y, exy = 0.5 * g * (phi_x + phi_y);
    const double trace = exx + eyy;
    return {lambda * trace + 2.0 * mu * exx, lambda * trace + 2.0 * mu * eyy, 2.0 * mu * exy,
            lambda * trace};
  }

  /// b(X, t), m/s^2 (per unit mass: the nodal force is sum_p N_I m_p b(X_p, t)).
  Vec2 body_force(const Vec2& x, double t) const {
    const Vec2 k = wave_numbers();
    const Vec2 s = x - origin;
    const double sx = std::sin(k.x() * s.x()), cx = std::cos(k.x() * s.x());
    const double sy = std::sin(k.y() * s.y()), cy = std::cos(k.y() * s.y());
    const double phi = sx * sy;
    const double phi_xx = -k.x() * k.x() * phi, phi_yy = -k.y() * k.y() * phi;
    const double phi_xy = k.x() * k.y() * cx * cy;
    const double w = omega();
    const double g = amplitude * time_factor(t);
    // grad(div u) / g = (Phi_xx + Phi_xy, Phi_xy + Phi_yy); lap u / g = (Phi_xx + Phi_yy)(1, 1).
    const Vec2 div_sigma = g * ((lambda + mu) * Vec2(phi_xx + phi_xy, phi_xy + phi_yy) +
                                mu * (phi_xx + phi_yy) * Vec2::Ones());
    const double sine = std::sin(w * t), cosine = std::cos(w * t);
    const double acceleration =
        amplitude * 0.5 * w * w * (sine * sine + (1.0 - cosine) * cosine) * phi;
    return Vec2(acceleration, acceleration) - div_sigma / density;
  }
};

}  // namespace pfm

// Manufactured solutions of plane-strain elastodynamics for verification (the method of
// manufactured solutions as Wallstedt and Guilkey 2008 use it for the MPM): a chosen motion
// x(X, t) of a body, and the body force b per unit mass that makes it exact,
//   rho x_tt = div sigma + rho b.
// Both start from rest, unstressed, with zero acceleration (their time factors have zero first
// and second derivatives at t = 0): the explicit step's first velocity is v_0 + dt a_0, not the
// half step of a centred start, an error of order dt that a motion starting with an
// acceleration would carry through the run and that would then hide the spatial error.
//
// kStandingWave, small strain, fixed edges: on the rectangle [x0, x0 + Lx] x [y0, y0 + Ly],
//   u(X, t) = A g(t) Phi(X) (1, 1),  g = (1 - cos(omega t))^2 / 4 (g(T / 2) = 1),
//   Phi = sin(kx (x - x0)) sin(ky (y - y0)), kx = pi / Lx, ky = pi / Ly, omega = 2 pi / T,
//   sigma = lambda tr(eps) I + 2 mu eps,  eps = sym grad u,
// zero on the rectangle's edges (walls fixed in x and y). With Phi_xx = -kx^2 Phi,
// Phi_yy = -ky^2 Phi, Phi_xy = kx ky cos(kx (x - x0)) cos(ky (y - y0)):
//   div sigma = A g [ (lambda + mu) grad(Phi_x + Phi_y) + mu lap(Phi) (1, 1) ],
//   b = A g'' Phi (1, 1) - div sigma / rho.
// Without inertia (the implicit solver's load steps) the same u(X, t) is the static answer to
// b = -div sigma / rho at every t.
//
// kUniformDilatation, finite strain, a moving loaded boundary: a free body of any shape squeezed
// by a follower pressure p0 f(t) on its boundary, f the smooth ramp (smooth_ramp_factor) over
// t_r. The exact motion of the Jaumann-rate elastic model is the uniform stretch about the
// body's centroid c,
//   x = c + s(t) (X - c),  s = exp(-p0 f / K),  K = 2 (lambda + mu),
// with the uniform Cauchy stress sxx = syy = K ln s = -p0 f, sxy = 0, szz = 2 lambda ln s (the
// rate sigma' = lambda tr(d) I + 2 mu d with d = (s' / s) I integrates to logarithms); the
// stress is uniform, so div sigma = 0, its traction on the current boundary is the pressure,
// and b = x_tt = s'' (X - c), s'' = s (a^2 f'^2 - a f''), a = p0 / K. With p0 = 0.1 K the
// boundary moves by 10 % of the body's size: it crosses cells, and the traction is applied on
// the boundary the detector finds.
// Units: m, s, t/m^3, kPa (kN/m^2), b in m/s^2.
#pragma once

#include <algorithm>
#include <cmath>
#include <numbers>

#include "mpm/core/types.hpp"

namespace pfm {

/// A time factor and its first two derivatives (1/s, 1/s^2).
struct TimeFactor {
  double value = 0.0;
  double rate = 0.0;
  double acceleration = 0.0;
};

/// The smooth ramp f(t) = 10 u^3 - 15 u^4 + 6 u^5, u = t / t_r, up to t_r, 1 after (the quintic
/// smoothstep): f' and f'' vanish at both ends, so a load or a motion that follows it starts and
/// stops without a jump in acceleration.
inline TimeFactor smooth_ramp_factor(double t, double ramp_time) {
  if (t >= ramp_time) return {1.0, 0.0, 0.0};
  if (t <= 0.0) return {0.0, 0.0, 0.0};
  const double u = t / ramp_time;
  return {u * u * u * (10.0 - 15.0 * u + 6.0 * u * u),
          30.0 * u * u * (1.0 - u) * (1.0 - u) / ramp_time,
          60.0 * u * (1.0 - u) * (1.0 - 2.0 * u) / (ramp_time * ramp_time)};
}

enum class ManufacturedKind { kStandingWave, kUniformDilatation };

struct ManufacturedSolution {
  ManufacturedKind kind = ManufacturedKind::kStandingWave;
  double lambda = 0.0;   ///< Lame's first parameter, kPa
  double mu = 0.0;       ///< shear modulus, kPa
  double density = 1.0;  ///< t/m^3
  // kStandingWave
  double amplitude = 0.0;      ///< A, m
  double period = 0.0;         ///< T, s
  Vec2 origin = Vec2::Zero();  ///< (x0, y0), m
  Vec2 size = Vec2::Ones();    ///< (Lx, Ly), m
  // kUniformDilatation
  double pressure = 0.0;       ///< p0, kPa (> 0 squeezes)
  double ramp_time = 0.0;      ///< t_r, s
  Vec2 centre = Vec2::Zero();  ///< c, m (the body's centroid)

  double omega() const { return 2.0 * std::numbers::pi / period; }
  Vec2 wave_numbers() const { return {std::numbers::pi / size.x(), std::numbers::pi / size.y()}; }
  /// Standing wave: g(t) = (1 - cos(omega t))^2 / 4 (periodic; the smooth ramp up to T / 2).
  double time_factor(double t) const {
    const double c = 1.0 - std::cos(omega() * t);
    return 0.25 * c * c;
  }
  /// Uniform dilatation: the stretch s(t) and its derivatives.
  TimeFactor stretch(double t) const {
    const double a = pressure / (2.0 * (lambda + mu));
    const TimeFactor f = smooth_ramp_factor(t, ramp_time);
    const double s = std::exp(-a * f.value);
    return {s, -a * f.rate * s, s * (a * a * f.rate * f.rate - a * f.acceleration)};
  }

  /// u(X, t) = x - X, m.
  Vec2 displacement(const Vec2& x, double t) const {
    if (kind == ManufacturedKind::kUniformDilatation)
      return (stretch(t).value - 1.0) * (x - centre);
    const Vec2 k = wave_numbers();
    const Vec2 s = x - origin;
    const double u = amplitude * time_factor(t) * std::sin(k.x() * s.x()) * std::sin(k.y() * s.y());
    return {u, u};
  }

  /// The Cauchy stress at the point that started at X (xx, yy, xy, zz), kPa.
  Stress stress(const Vec2& x, double t) const {
    if (kind == ManufacturedKind::kUniformDilatation) {
      const double log_stretch = std::log(stretch(t).value);
      const double in_plane = 2.0 * (lambda + mu) * log_stretch;
      return {in_plane, in_plane, 0.0, 2.0 * lambda * log_stretch};
    }
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
    if (kind == ManufacturedKind::kUniformDilatation) return stretch(t).acceleration * (x - centre);
    const Vec2 k = wave_numbers();
    const double phi =
        std::sin(k.x() * (x.x() - origin.x())) * std::sin(k.y() * (x.y() - origin.y()));
    const double w = omega();
    const double sine = std::sin(w * t), cosine = std::cos(w * t);
    const double acceleration =
        amplitude * 0.5 * w * w * (sine * sine + (1.0 - cosine) * cosine) * phi;
    return Vec2(acceleration, acceleration) - stress_divergence(x, t) / density;
  }

  /// The quasi-static body force, b = -div sigma / rho (m/s^2): the standing wave's field held
  /// in equilibrium without inertia, u(X, t) exact at every t (the implicit solver's load steps;
  /// the uniform dilatation's is zero, its stress being uniform).
  Vec2 static_body_force(const Vec2& x, double t) const {
    if (kind == ManufacturedKind::kUniformDilatation) return Vec2::Zero();
    return -stress_divergence(x, t) / density;
  }

 private:
  /// The standing wave's div sigma at the point that started at X, kPa/m.
  Vec2 stress_divergence(const Vec2& x, double t) const {
    const Vec2 k = wave_numbers();
    const Vec2 s = x - origin;
    const double sx = std::sin(k.x() * s.x()), cx = std::cos(k.x() * s.x());
    const double sy = std::sin(k.y() * s.y()), cy = std::cos(k.y() * s.y());
    const double phi = sx * sy;
    const double phi_xx = -k.x() * k.x() * phi, phi_yy = -k.y() * k.y() * phi;
    const double phi_xy = k.x() * k.y() * cx * cy;
    const double g = amplitude * time_factor(t);
    // grad(div u) / g = (Phi_xx + Phi_xy, Phi_xy + Phi_yy); lap u / g = (Phi_xx + Phi_yy)(1, 1).
    return g * ((lambda + mu) * Vec2(phi_xx + phi_xy, phi_xy + phi_yy) +
                mu * (phi_xx + phi_yy) * Vec2::Ones());
  }
};

}  // namespace pfm

// The manufactured solution's body force is the one that makes its displacement exact: at
// random points and times, rho u_tt - div sigma(u) = rho b with the derivatives taken by central
// differences of displacement() and stress() (truncation (omega dt)^2 / 12 = 3e-8 relative to
// the terms' size with dt = 1e-4 T, and as much in space; the limit 1e-6 leaves room for
// rounding, which the second difference in time amplifies to about 1e-16 / 1e-8 = 1e-8). And u
// vanishes on the rectangle's edges, and u and sigma at t = 0.
#include <gtest/gtest.h>

#include <random>

#include "mpm/core/manufactured.hpp"

namespace pfm {
namespace {

ManufacturedSolution solution() {
  ManufacturedSolution s;
  s.amplitude = 1e-3;
  s.period = 0.1;
  s.origin = Vec2(0.5, -1.0);
  s.size = Vec2(2.0, 1.5);
  s.lambda = 5769.2;
  s.mu = 3846.2;
  s.density = 2.04;
  return s;
}

TEST(Manufactured, BodyForceMakesTheDisplacementExact) {
  const ManufacturedSolution s = solution();
  std::mt19937 random(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const double dx = 1e-4 * s.size.minCoeff(), dt = 1e-4 * s.period;
  for (int k = 0; k < 200; ++k) {
    const Vec2 x = s.origin + Vec2(u(random) * s.size.x(), u(random) * s.size.y());
    const double t = u(random) * s.period;
    const Vec2 acceleration =
        (s.displacement(x, t + dt) - 2.0 * s.displacement(x, t) + s.displacement(x, t - dt)) /
        (dt * dt);
    const Vec2 ex(dx, 0.0), ey(0.0, dx);
    const Stress sx = (s.stress(x + ex, t) - s.stress(x - ex, t)) / (2.0 * dx);
    const Stress sy = (s.stress(x + ey, t) - s.stress(x - ey, t)) / (2.0 * dx);
    const Vec2 div_sigma(sx[kXX] + sy[kXY], sx[kXY] + sy[kYY]);
    const Vec2 b = s.body_force(x, t);
    const Vec2 residual = s.density * acceleration - div_sigma - s.density * b;
    // The size of the terms over the field: rho A omega^2 and (lambda + 3 mu) A k^2 (the
    // residual is not measured against their values at a point, which vanish as t^2 at t = 0).
    const double scale = s.amplitude * (s.density * s.omega() * s.omega() +
                                        (s.lambda + 3.0 * s.mu) * s.wave_numbers().squaredNorm());
    EXPECT_LE(residual.norm(), 1e-6 * scale) << "x = " << x.transpose() << ", t = " << t;
  }
}

TEST(Manufactured, ZeroOnTheEdgesAndAtRestAtTheStart) {
  const ManufacturedSolution s = solution();
  const Vec2 corner = s.origin + s.size;
  for (double f : {0.0, 0.3, 0.7, 1.0}) {
    const double t = 0.37 * s.period;
    EXPECT_LE(s.displacement(Vec2(s.origin.x() + f * s.size.x(), s.origin.y()), t).norm(), 1e-18);
    EXPECT_LE(s.displacement(Vec2(corner.x(), s.origin.y() + f * s.size.y()), t).norm(), 1e-18);
    EXPECT_LE(s.displacement(Vec2(s.origin.x() + f * s.size.x(), corner.y()), t).norm(), 1e-18);
  }
  const Vec2 inside = s.origin + 0.3 * s.size;
  EXPECT_EQ(s.displacement(inside, 0.0).norm(), 0.0);
  EXPECT_EQ(s.stress(inside, 0.0).norm(), 0.0);
}

}  // namespace
}  // namespace pfm

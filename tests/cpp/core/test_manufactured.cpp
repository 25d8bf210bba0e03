// The manufactured solution's body force is the one that makes its displacement exact: at
// random points and times, rho u_tt - div sigma(u) = rho b with the derivatives taken by central
// differences of displacement() and stress() (truncation (omega dt)^2 / 12 = 3e-8 relative to
// the terms' size with dt = 1e-4 T, and as much in space; the limit 1e-6 leaves room for
// rounding, which the second difference in time amplifies to about 1e-16 / 1e-8 = 1e-8). And u
// vanishes on the rectangle's edges, and u and sigma at t = 0.
#include <gtest/gtest.h>

#include <cmath>
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

// The uniform dilatation: the stretch's derivatives against central differences (and the body
// force x_tt), its stress uniform with sxx = -p0 f(t) (the follower pressure it is squeezed by),
// zero before the ramp and constant after it; the smooth ramp is C2 at both ends.
TEST(Manufactured, UniformDilatationIsTheStretchItsPressureMakes) {
  ManufacturedSolution s;
  s.kind = ManufacturedKind::kUniformDilatation;
  s.lambda = 5769.2;
  s.mu = 3846.2;
  s.density = 2.04;
  s.pressure = 2000.0;
  s.ramp_time = 0.2;
  s.centre = Vec2(1.0, 2.0);
  const double dt = 1e-5 * s.ramp_time;
  const Vec2 x(2.5, 1.25);
  for (double f : {0.05, 0.3, 0.5, 0.77, 0.99}) {
    const double t = f * s.ramp_time;
    const TimeFactor st = s.stretch(t);
    const double rate = (s.stretch(t + dt).value - s.stretch(t - dt).value) / (2.0 * dt);
    const double acceleration =
        (s.stretch(t + dt).value - 2.0 * st.value + s.stretch(t - dt).value) / (dt * dt);
    const double scale = s.pressure / (2.0 * (s.lambda + s.mu)) / (s.ramp_time * s.ramp_time);
    EXPECT_NEAR(st.rate, rate, 1e-6 * scale * s.ramp_time);
    EXPECT_NEAR(st.acceleration, acceleration, 1e-4 * scale);
    const Vec2 x_tt =
        (s.displacement(x, t + dt) - 2.0 * s.displacement(x, t) + s.displacement(x, t - dt)) /
        (dt * dt);
    EXPECT_LE((s.body_force(x, t) - x_tt).norm(), 1e-4 * scale * (x - s.centre).norm());
    const Stress sigma = s.stress(x, t);
    EXPECT_NEAR(sigma[kXX], -s.pressure * smooth_ramp_factor(t, s.ramp_time).value,
                1e-12 * s.pressure);
    EXPECT_EQ(sigma[kXX], sigma[kYY]);
    EXPECT_EQ(sigma[kXY], 0.0);
    EXPECT_EQ(sigma, s.stress(s.centre, t));  // uniform: div sigma = 0
  }
  EXPECT_EQ(s.displacement(x, 0.0).norm(), 0.0);
  EXPECT_EQ(s.body_force(x, 1.5 * s.ramp_time).norm(), 0.0);
  // C2 at both ends of the ramp.
  const TimeFactor start = smooth_ramp_factor(1e-9 * s.ramp_time, s.ramp_time);
  const TimeFactor end = smooth_ramp_factor((1.0 - 1e-9) * s.ramp_time, s.ramp_time);
  EXPECT_LE(start.acceleration * s.ramp_time * s.ramp_time, 1e-7);  // 60 u at u = 1e-9
  EXPECT_NEAR(end.value, 1.0, 1e-15);
  EXPECT_LE(std::abs(end.rate) * s.ramp_time, 1e-15);
  EXPECT_LE(std::abs(end.acceleration) * s.ramp_time * s.ramp_time, 1e-7);
}

}  // namespace
}  // namespace pfm

// Kinematics: the Jaumann update rotates a stress with a rigid spin (objectivity to first order,
// and exactly in the limit of many small steps).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <random>
#include <vector>

#include "mpm/core/kinematics.hpp"

namespace pfm {
namespace {

TEST(Kinematics, RigidRotationGivesNoStrainIncrement) {
  const double omega = 0.3;  // rad/s, counter-clockwise
  Mat2 l;
  l << 0.0, -omega, omega, 0.0;
  EXPECT_EQ(strain_increment(l, 0.1).norm(), 0.0);
}

TEST(Kinematics, JaumannRotatesUniaxialStressWithTheBody) {
  // Uniaxial stress along x rotated by a quarter turn in many small steps becomes uniaxial
  // along y: objectivity of the Jaumann rate.
  const double omega = std::numbers::pi / 2.0;  // quarter turn in 1 s
  Mat2 l;
  l << 0.0, -omega, omega, 0.0;
  Stress s(-100.0, 0.0, 0.0, -15.0);
  const int n = 200000;
  for (int k = 0; k < n; ++k) jaumann_rotate(l, 1.0 / n, s);
  EXPECT_NEAR(s[kXX], 0.0, 1e-2);
  EXPECT_NEAR(s[kYY], -100.0, 1e-2);
  EXPECT_NEAR(s[kXY], 0.0, 1e-2);
  EXPECT_EQ(s[kZZ], -15.0);
  // The invariants (trace and von Mises) drift by O(dt) per unit rotation only.
  EXPECT_NEAR(s[kXX] + s[kYY], -100.0, 1e-9);
}

TEST(Kinematics, DeformationGradientOfSimpleShear) {
  Mat2 l;
  l << 0.0, 2.0, 0.0, 0.0;  // v_x = 2 y
  const Mat2 f = update_deformation_gradient(l, 0.01, Mat2::Identity());
  EXPECT_DOUBLE_EQ(f(0, 1), 0.02);
  EXPECT_DOUBLE_EQ(f.determinant(), 1.0);
}

TEST(Kinematics, MeanDilatationKeepsSpinAndDeviatorAndTakesTheMeanTrace) {
  Mat2 l;
  l << 0.3, -1.1, 0.7, -0.9;
  const Mat2 bar = mean_dilatation_gradient(l, 0.25);
  EXPECT_DOUBLE_EQ(bar.trace(), 0.25);
  EXPECT_DOUBLE_EQ(bar(0, 1), l(0, 1));  // shear and spin
  EXPECT_DOUBLE_EQ(bar(1, 0), l(1, 0));
  EXPECT_NEAR(bar(0, 0) - bar(1, 1), l(0, 0) - l(1, 1), 1e-15);  // in-plane deviator
  EXPECT_EQ(strain_increment(bar, 1.0)[kZZ], 0.0);               // plane strain
}

TEST(Kinematics, MeanDilatationStressDoesTheWorkOfTheMeanDilatationGradient) {
  // Over a cell of points with random stresses, velocity gradients and volumes:
  // sum V sigma : L_bar = sum V sigma_tilde : L (B-bar: the internal force B_bar^T sigma is the
  // plain internal force of sigma_tilde), to rounding; and a uniform L is left unchanged.
  std::mt19937 random(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const int n = 9;
  std::vector<Mat2> l(n);
  std::vector<Stress> s(n);
  std::vector<double> v(n);
  double volume = 0.0, trace_l = 0.0, trace_s = 0.0;
  for (int p = 0; p < n; ++p) {
    l[p] << u(random), u(random), u(random), u(random);
    s[p] = Stress(100 * u(random), 100 * u(random), 100 * u(random), 100 * u(random));
    v[p] = 1.0 + u(random) * 0.5;
    volume += v[p];
    trace_l += v[p] * l[p].trace();
    trace_s += v[p] * (s[p][kXX] + s[p][kYY]);
  }
  auto power = [](const Stress& sig, const Mat2& g) {
    return sig[kXX] * g(0, 0) + sig[kYY] * g(1, 1) + sig[kXY] * (g(0, 1) + g(1, 0));
  };
  double with_bar_l = 0.0, with_tilde_s = 0.0, scale = 0.0;
  for (int p = 0; p < n; ++p) {
    with_bar_l += v[p] * power(s[p], mean_dilatation_gradient(l[p], trace_l / volume));
    with_tilde_s += v[p] * power(mean_dilatation_stress(s[p], trace_s / volume), l[p]);
    scale += v[p] * std::abs(power(s[p], l[p]));
  }
  EXPECT_NEAR(with_bar_l, with_tilde_s, 1e-14 * scale);
  EXPECT_TRUE(mean_dilatation_gradient(l[0], l[0].trace()) == l[0]);
}

}  // namespace
}  // namespace pfm

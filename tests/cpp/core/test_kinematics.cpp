// Kinematics: the Jaumann update rotates a stress with a rigid spin (objectivity to first order,
// and exactly in the limit of many small steps).
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

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

}  // namespace
}  // namespace pfm

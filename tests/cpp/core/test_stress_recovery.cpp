// Stress recovery next to a boundary with known tractions (mpm/core/stress_recovery.hpp): a
// linear stress field comes back exactly at the points next to the boundary whatever their own
// stresses, from the interior's points and the tractions; points away from every known traction
// keep theirs; a body without an interior keeps its stresses.
#include <gtest/gtest.h>

#include <vector>

#include "mpm/core/stress_recovery.hpp"

namespace pfm {
namespace {

// sigma(x) linear in x: sxx, syy, sxy, szz.
Stress field(const Vec2& x) {
  return Stress(-10.0 + 2.0 * x.x() - 1.0 * x.y(), -30.0 + 0.5 * x.x() + 18.0 * x.y(),
                3.0 - 1.5 * x.x() + 0.7 * x.y(), -12.0 + 1.0 * x.x() + 4.0 * x.y());
}

struct Block {
  std::vector<Vec2> position;
  std::vector<Stress> stress;
  std::vector<TractionSample> samples;
};

// Points at 2 per cell of h = 0.25 in [0, 3] x [0, 4]; the top (y = 4) and the right side
// (x = 3) carry the field's traction; the points in the band next to them carry garbage.
Block block(double h) {
  Block b;
  for (double y = h / 4; y < 4.0; y += h / 2) {
    for (double x = h / 4; x < 3.0; x += h / 2) {
      const Vec2 p(x, y);
      b.position.push_back(p);
      const double band = StressRecoveryOptions{}.band * h;
      const bool near = 4.0 - y < band || 3.0 - x < band;
      b.stress.push_back(near ? Stress(field(p) * 1.3 + Stress::Constant(7.0)) : field(p));
    }
  }
  const auto traction = [](const Vec2& x, const Vec2& n) {
    const Stress s = field(x);
    return Vec2(s[0] * n.x() + s[2] * n.y(), s[2] * n.x() + s[1] * n.y());
  };
  for (double x = h / 8; x < 3.0; x += h / 4) {
    const Vec2 p(x, 4.0), n(0.0, 1.0);
    b.samples.push_back({p, n, traction(p, n), h / 4});
  }
  for (double y = h / 8; y < 4.0; y += h / 4) {
    const Vec2 p(3.0, y), n(1.0, 0.0);
    b.samples.push_back({p, n, traction(p, n), h / 4});
  }
  return b;
}

TEST(StressRecovery, LinearFieldComesBackExactlyNextToTheLoadedBoundary) {
  const double h = 0.25;
  const Block b = block(h);
  const std::vector<Stress> r = recover_stress(b.position, b.stress, b.samples, h);
  int recovered = 0;
  for (std::size_t p = 0; p < b.position.size(); ++p) {
    const Stress exact = field(b.position[p]);
    for (int c = 0; c < 4; ++c) EXPECT_NEAR(r[p][c], exact[c], 1e-9) << p << " " << c;
    recovered += b.stress[p] != exact;
  }
  EXPECT_GT(recovered, 100);
}

TEST(StressRecovery, PointsAwayFromEveryKnownTractionKeepTheirStress) {
  const double h = 0.25;
  Block b = block(h);
  // Only the right side's samples: the points under the top (away from x = 3) keep theirs.
  std::erase_if(b.samples, [](const TractionSample& s) { return s.normal.y() > 0.5; });
  const std::vector<Stress> r = recover_stress(b.position, b.stress, b.samples, h);
  for (std::size_t p = 0; p < b.position.size(); ++p) {
    if (3.0 - b.position[p].x() > StressRecoveryOptions{}.band * h) EXPECT_EQ(r[p], b.stress[p]);
  }
}

TEST(StressRecovery, ABodyWithoutAnInteriorKeepsItsStress) {
  const double h = 0.25;
  Block b = block(h);
  for (TractionSample& s : b.samples) s.x.y() = std::min(s.x.y(), 0.3);  // all near y < 0.6
  std::vector<Vec2> strip;
  std::vector<Stress> stress;
  for (std::size_t p = 0; p < b.position.size(); ++p) {
    if (b.position[p].y() < 0.3) {
      strip.push_back(b.position[p]);
      stress.push_back(b.stress[p]);
    }
  }
  const std::vector<Stress> r = recover_stress(strip, stress, b.samples, h);
  for (std::size_t p = 0; p < strip.size(); ++p) EXPECT_EQ(r[p], stress[p]);
}

}  // namespace
}  // namespace pfm

// Surface Marker Method: marker placement, advection by the grid velocities (thesis eq.
// 4.6-4.7), nodes without mass, and the reporting of the markers as contours.
#include <gtest/gtest.h>

#include <cstdio>

#include "../detect/detect_test_support.hpp"

namespace pfm::test {
namespace {

constexpr double kH = 0.5;

Grid test_grid() {
  Grid g;
  g.origin = Vec2(-1.0, -0.5);
  g.cell_size = kH;
  g.n_cells_x = 26;
  g.n_cells_y = 22;
  return g;
}

// Markers placed on the disk of radius 2 m about (6, 5).
DetectorState disk_markers(DetectedBoundary* placed = nullptr) {
  const Vec2 centre(6.0, 5.0);
  const auto cloud = lattice_cloud(kH, Placement::kEqualSpacing, Vec2(3, 2), Vec2(9, 8),
                                   [&](const Vec2& x) { return (x - centre).norm() < 2.0; });
  DetectorConfig config;
  config.method = DetectorMethod::kSmm;
  DetectorState state;
  const auto b = detect(cloud.view(), test_grid(), config, state);
  if (placed != nullptr) *placed = b;
  return state;
}

TEST(SurfaceMarkers, PlacedOnTheInitialContourAtTheConfiguredSpacing) {
  DetectedBoundary placed;
  const DetectorState state = disk_markers(&placed);
  ASSERT_TRUE(state.markers_placed);
  ASSERT_EQ(state.markers.size(), 1u);
  EXPECT_TRUE(state.markers_closed[0]);
  const auto& m = state.markers[0];
  // Spacing: h / 2 by default along a loop of length ~ 2 pi 2.03 m: 26 markers.
  double length = 0.0, shortest = 1e300, longest = 0.0;
  for (std::size_t k = 0; k < m.size(); ++k) {
    const double d = (m[(k + 1) % m.size()] - m[k]).norm();
    length += d;
    shortest = std::min(shortest, d);
    longest = std::max(longest, d);
  }
  std::printf("%zu markers, chords %.4f .. %.4f m (target %.4f m)\n", m.size(), shortest, longest,
              0.5 * kH);
  EXPECT_EQ(m.size(), static_cast<std::size_t>(std::ceil(length / (0.5 * kH) - 1e-9)));
  EXPECT_LE(longest, 0.5 * kH + 1e-12);
  EXPECT_GT(shortest, 0.45 * kH);
  // Reported as one closed counter-clockwise contour; a second call without advection returns
  // the same markers (the particles are not looked at again).
  ASSERT_EQ(placed.contours.size(), 1u);
  EXPECT_GT(signed_area(placed.contours[0]), 0.0);
  DetectorState again = state;
  DetectorConfig config;
  config.method = DetectorMethod::kSmm;
  const auto b = detect(ParticleCloud{{}, {}, {}, 0.25}, test_grid(), config, again);
  ASSERT_EQ(b.contours.size(), 1u);
  EXPECT_EQ(b.contours[0].points, placed.contours[0].points);
}

TEST(SurfaceMarkers, RigidTranslationMovesEveryMarkerByVelocityTimesDt) {
  DetectorState state = disk_markers();
  const auto before = state.markers;
  const Grid g = test_grid();
  const Vec2 v(0.37, -0.21);  // m/s
  const double dt = 0.013;    // s
  std::vector<Vec2> velocity(g.n_nodes(), v);
  std::vector<double> mass(g.n_nodes(), 1.0);
  // Nodes without mass far from the disk and around it: a uniform field stays uniform after the
  // weights are renormalised.
  for (int j = 0; j < g.n_nodes_y(); ++j) {
    for (int i = 0; i < g.n_nodes_x(); ++i) {
      const Vec2 x = g.node_position(i, j);
      if ((x - Vec2(6.0, 5.0)).norm() > 2.2) {
        mass[g.node_index(i, j)] = 0.0;
        velocity[g.node_index(i, j)] = Vec2(1e3, 1e3);  // never used
      }
    }
  }
  for (int step = 0; step < 5; ++step) advect_surface_markers(state, g, velocity, mass, dt);
  double worst = 0.0;
  for (std::size_t k = 0; k < before[0].size(); ++k) {
    worst = std::max(worst, (state.markers[0][k] - (before[0][k] + 5.0 * dt * v)).norm());
  }
  std::printf("translation: largest deviation from x0 + 5 v dt: %.3e m\n", worst);
  EXPECT_LE(worst, 1e-12);
}

// Rigid rotation v = omega x (x - c): bilinear interpolation reproduces the linear field
// exactly, so one explicit step (eq. 4.6) moves a marker along the tangent and its distance
// from c grows by r (sqrt(1 + (omega dt)^2) - 1) = r (omega dt)^2 / 2 + O(dt^4): the markers stay
// on the circle to O(dt^2) per step.
TEST(SurfaceMarkers, RigidRotationStaysOnTheCircleToSecondOrder) {
  const Grid g = test_grid();
  const Vec2 c(6.0, 5.0);
  const double omega = 0.8;  // rad/s
  std::vector<Vec2> velocity(g.n_nodes());
  std::vector<double> mass(g.n_nodes(), 2.0);
  for (int j = 0; j < g.n_nodes_y(); ++j) {
    for (int i = 0; i < g.n_nodes_x(); ++i) {
      const Vec2 d = g.node_position(i, j) - c;
      velocity[g.node_index(i, j)] = omega * Vec2(-d.y(), d.x());
    }
  }
  double drift[2] = {0.0, 0.0};
  int level = 0;
  for (const double dt : {0.02, 0.01}) {
    DetectorState state = disk_markers();
    const auto before = state.markers[0];
    advect_surface_markers(state, g, velocity, mass, dt);
    double worst_formula = 0.0, worst_drift = 0.0, worst_angle = 0.0;
    for (std::size_t k = 0; k < before.size(); ++k) {
      const double r0 = (before[k] - c).norm(), r1 = (state.markers[0][k] - c).norm();
      const double expected = r0 * (std::sqrt(1.0 + omega * omega * dt * dt) - 1.0);
      worst_formula = std::max(worst_formula, std::abs((r1 - r0) - expected));
      worst_drift = std::max(worst_drift, std::abs(r1 - r0));
      const Vec2 a = before[k] - c, b = state.markers[0][k] - c;
      worst_angle = std::max(
          worst_angle,
          std::abs(std::atan2(a.x() * b.y() - a.y() * b.x(), a.dot(b)) - std::atan(omega * dt)));
    }
    drift[level++] = worst_drift;
    std::printf(
        "rotation dt %.3f s: radial drift %.3e m (r (omega dt)^2 / 2 = %.3e m), "
        "formula residual %.1e m, angle residual %.1e\n",
        dt, worst_drift, 2.1 * omega * omega * dt * dt / 2.0, worst_formula, worst_angle);
    EXPECT_LE(worst_formula, 1e-12);
    EXPECT_LE(worst_angle, 1e-12);
    EXPECT_LE(worst_drift, 2.1 * omega * omega * dt * dt / 2.0 * 1.001);
  }
  EXPECT_NEAR(drift[0] / drift[1], 4.0, 1e-3);  // second order in dt
}

TEST(SurfaceMarkers, MasslessNodesRenormalisedOrTakenAsZero) {
  // One marker in cell (i, j) whose two upper nodes have no mass.
  const Grid g = test_grid();
  const Vec2 x = g.node_position(10, 10) + Vec2(0.25 * kH, 0.75 * kH);
  std::vector<Vec2> velocity(g.n_nodes(), Vec2(1.0, 0.0));
  std::vector<double> mass(g.n_nodes(), 1.0);
  for (const int i : {10, 11}) mass[g.node_index(i, 11)] = 0.0;
  for (const auto rule : {MasslessNodes::kRenormalise, MasslessNodes::kZero}) {
    DetectorState state;
    state.markers = {{x}};
    state.markers_closed = {false};
    state.markers_placed = true;
    state.massless_nodes = rule;
    advect_surface_markers(state, g, velocity, mass, 0.1);
    // Renormalised: the velocity of the nodes with mass; zero: weighted by their share 1 - 0.75.
    const double expected = rule == MasslessNodes::kRenormalise ? 0.1 : 0.1 * 0.25;
    EXPECT_NEAR(state.markers[0][0].x() - x.x(), expected, 1e-15);
    EXPECT_EQ(state.markers[0][0].y(), x.y());
  }
  // A marker in a cell without any node with mass, and one outside the grid, stay put.
  DetectorState state;
  state.markers = {{x, Vec2(-5.0, 0.0)}};
  state.markers_closed = {false};
  state.markers_placed = true;
  std::fill(mass.begin(), mass.end(), 0.0);
  advect_surface_markers(state, g, velocity, mass, 0.1);
  EXPECT_EQ(state.markers[0][0], x);
  EXPECT_EQ(state.markers[0][1], Vec2(-5.0, 0.0));
  // Wrong sizes are input errors.
  EXPECT_THROW(advect_surface_markers(state, g, std::vector<Vec2>(3), mass, 0.1), InputError);
}

TEST(SurfaceMarkers, ResamplePolylineKeepsEndsAndSpacing) {
  const std::vector<Vec2> open = {Vec2(0, 0), Vec2(1, 0), Vec2(1, 1)};
  const auto r = resample_polyline(open, false, 0.3);
  ASSERT_EQ(r.size(), 8u);  // length 2: ceil(2 / 0.3) = 7 intervals
  EXPECT_EQ(r.front(), open.front());
  EXPECT_EQ(r.back(), open.back());
  for (std::size_t k = 0; k + 1 < r.size(); ++k) {
    EXPECT_LE((r[k + 1] - r[k]).norm(), 2.0 / 7.0 + 1e-12);
  }
  const std::vector<Vec2> square = {Vec2(0, 0), Vec2(1, 0), Vec2(1, 1), Vec2(0, 1)};
  const auto s = resample_polyline(square, true, 0.5);
  ASSERT_EQ(s.size(), 8u);
  EXPECT_EQ(s[2], Vec2(1, 0));
  EXPECT_NEAR((s[5] - Vec2(0.5, 1.0)).norm(), 0.0, 1e-15);
}

}  // namespace
}  // namespace pfm::test

// The baseline detectors (Surface Marker Method, Volume of Fluid, cell-density threshold) on
// static bodies at h = 0.5 m with 2 x 2 points per cell, both placements: closed loops that
// honour the contour contract, and their distance to the exact geometry.
#include <gtest/gtest.h>

#include <cstdio>

#include "../detect/detect_test_support.hpp"

namespace pfm::test {
namespace {

constexpr double kH = 0.5;

Grid test_grid() {
  Grid g;
  g.cell_size = kH;
  g.n_cells_x = 24;
  g.n_cells_y = 20;
  return g;
}

DetectorConfig config_of(DetectorMethod method) {
  DetectorConfig c;
  c.method = method;
  return c;
}

constexpr DetectorMethod kBaselines[] = {DetectorMethod::kSmm, DetectorMethod::kVof,
                                         DetectorMethod::kDensity};

// Contract invariants of contour.hpp (particle containment is reported, not part of it).
void expect_contract(const DetectedBoundary& b, const Grid& g, const OwnedCloud& cloud,
                     const char* what) {
  const Violations v = check_invariants(b, g, cloud.position);
  EXPECT_EQ(v.open_not_on_edge + v.shared_points + v.self_intersections + v.orientation + v.winding,
            0)
      << what;
  for (const auto& c : b.contours) {
    EXPECT_TRUE(c.closed) << what;
    EXPECT_NE(c.points.front(), c.points.back()) << what << ": closing point repeated";
    const auto lowest =
        *std::min_element(c.points.begin(), c.points.end(), [](const Vec2& p, const Vec2& q) {
          return p.y() < q.y() || (p.y() == q.y() && p.x() < q.x());
        });
    EXPECT_EQ(c.points.front(), lowest) << what << ": loop does not start at its lowest point";
  }
  if (v.particles_outside > 0) {
    std::printf("  %s: %ld of %zu particles outside the detected region\n", what,
                v.particles_outside, cloud.position.size());
  }
}

// Flat faces: grid-aligned rectangle [2, 8] x [2, 6].
//  * SMM: the markers sit on the improved detector's contour (flat faces within 0.02 h, issue
//    3) and a chord between two markers on a straight face stays on it: bound 0.02 h.
//  * VOF: every cell is full (4 points of h^2 / 4) or empty, so the reconstruction is the union
//    of the full cells: exact (bound 1e-9 h, round-off).
//  * density: a node on a flat face collects exactly half of a full node's volume fraction
//    (both placements integrate the bilinear hat function exactly) and lies on the 0.5 level:
//    exact (bound 1e-9 h).
TEST(Baselines, RectangleClosedLoopOnTheFaces) {
  const std::vector<Vec2> rect = {Vec2(2, 2), Vec2(8, 2), Vec2(8, 6), Vec2(2, 6)};
  const double bound[3] = {0.02, 1e-9, 1e-9};
  for (const auto placement : {Placement::kEqualSpacing, Placement::kGaussPoints}) {
    const auto cloud =
        lattice_cloud(kH, placement, Vec2(2, 2), Vec2(8, 6), [](const Vec2&) { return true; });
    for (int m = 0; m < 3; ++m) {
      DetectorState state;
      DetectionTimings t;
      const auto b = detect(cloud.view(), test_grid(), config_of(kBaselines[m]), state, &t);
      ASSERT_EQ(b.contours.size(), 1u) << detector_method_name(kBaselines[m]);
      EXPECT_GT(signed_area(b.contours[0]), 0.0);
      expect_contract(b, test_grid(), cloud, detector_method_name(kBaselines[m]));
      const auto r = face_distances(b, rect, 1.5 * kH, kH);
      std::printf(
          "rectangle %-5s %-8s points %4zu  faces mean %.4f h max %.4f h  corners max %.4f h"
          "  (%.3f ms)\n",
          placement_name(placement), detector_method_name(kBaselines[m]),
          b.contours[0].points.size(), r.faces.mean, r.faces.max, r.corner.max,
          1e3 * (t.field + t.edge_points + t.connection + t.filters));
      EXPECT_GT(r.faces.count, 20);
      EXPECT_LE(r.faces.max, bound[m]) << detector_method_name(kBaselines[m]);
    }
  }
}

// Flat faces off the grid: the 4 m square rotated by 30 degrees (lattice rotated with it,
// F = R(30)). The rotated lattice puts 3 to 5 points into a cell, so VOF finds fractions below
// one inside the body and reconstructs small holes around some interior nodes (the thesis' "edge
// inside the soil body", 4.3.2): they are counted and reported; the faces are measured on the
// outer loop. Measured (both placements): SMM <= 0.009 h, VOF <= 0.33 h, density <= 0.04 h.
// Bounds: SMM inherits the improved detector's 0.02 h (a chord between markers on a straight
// face stays on it); VOF and density know the material only per cell (a cell's count, a node's
// hat-weighted volume within one cell) and cannot place a face better than the cell it crosses
// in the worst case: half a cell, 0.5 h (the brief's bound).
TEST(Baselines, RotatedSquareFacesWithinHalfACell) {
  const double angle = std::numbers::pi / 6.0;
  Mat2 rot;
  rot << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle);
  const Vec2 centre(6.0, 5.0);
  std::vector<Vec2> body;
  for (const Vec2& corner : {Vec2(4, 3), Vec2(8, 3), Vec2(8, 7), Vec2(4, 7)}) {
    body.push_back(centre + rot * (corner - centre));
  }
  const double bound[3] = {0.02, 0.5, 0.5};
  for (const auto placement : {Placement::kEqualSpacing, Placement::kGaussPoints}) {
    const auto cloud = lattice_cloud(
        kH, placement, Vec2(4, 3), Vec2(8, 7), [](const Vec2&) { return true; }, rot, centre);
    for (int m = 0; m < 3; ++m) {
      DetectorState state;
      const auto b = detect(cloud.view(), test_grid(), config_of(kBaselines[m]), state);
      expect_contract(b, test_grid(), cloud, detector_method_name(kBaselines[m]));
      DetectedBoundary outer;
      int holes = 0;
      for (const auto& c : b.contours) {
        if (signed_area(c) > 0.0) {
          outer.contours.push_back(c);
        } else {
          ++holes;
        }
      }
      ASSERT_EQ(outer.contours.size(), 1u) << detector_method_name(kBaselines[m]);
      if (kBaselines[m] != DetectorMethod::kVof) {
        EXPECT_EQ(holes, 0);
      }
      const auto r = face_distances(outer, body, 1.5 * kH, kH);
      std::printf(
          "square30  %-5s %-8s faces mean %.4f h max %.4f h  corners max %.4f h  holes %d\n",
          placement_name(placement), detector_method_name(kBaselines[m]), r.faces.mean, r.faces.max,
          r.corner.max, holes);
      EXPECT_LE(r.faces.max, bound[m]) << detector_method_name(kBaselines[m]);
    }
  }
}

// Disk of radius 2 m (exact body: the disk of the points' total volume, R = 2.034 m).
//  * SMM: the improved contour (|bias| <= kappa a^2 / 10 + 0.02 h = 0.057 h, max 0.08 h
//    measured) plus the chord sagitta s^2 / (8 R) = 0.008 h of markers s = h / 2 apart: bound
//    on the largest radial error 0.1 h.
//  * VOF and density: half a cell, as for flat faces (0.5 h). Measured: VOF bias +0.030 h, max
//    0.174 h; density bias -0.054 h, max 0.081 h (both placements alike).
TEST(Baselines, DiskClosedLoopWithinBounds) {
  const Vec2 centre(6.0, 5.0);
  const double bound[3] = {0.1, 0.5, 0.5};
  for (const auto placement : {Placement::kEqualSpacing, Placement::kGaussPoints}) {
    const auto cloud = lattice_cloud(kH, placement, Vec2(3, 2), Vec2(9, 8),
                                     [&](const Vec2& x) { return (x - centre).norm() < 2.0; });
    double volume = 0.0;
    for (const double v : cloud.volume) volume += v;
    const double radius = std::sqrt(volume / std::numbers::pi);
    for (int m = 0; m < 3; ++m) {
      DetectorState state;
      const auto b = detect(cloud.view(), test_grid(), config_of(kBaselines[m]), state);
      ASSERT_EQ(b.contours.size(), 1u) << detector_method_name(kBaselines[m]);
      EXPECT_GT(signed_area(b.contours[0]), 0.0);
      expect_contract(b, test_grid(), cloud, detector_method_name(kBaselines[m]));
      const auto r = circle_errors(b, centre, radius, kH);
      std::printf("disk      %-5s %-8s points %4zu  bias %+.4f h  mean %.4f h max %.4f h\n",
                  placement_name(placement), detector_method_name(kBaselines[m]),
                  b.contours[0].points.size(), r.bias, r.absolute.mean, r.absolute.max);
      EXPECT_LE(r.absolute.max, bound[m]) << detector_method_name(kBaselines[m]);
    }
  }
}

// A body resting on the grid's bottom-left corner (the MPM case: a fixed base and a roller side):
// the grid edges are walls, not boundaries. The improved detector mirrors the particles across
// them, the density field counts a node's share of the grid only, VOF drops the faces on the
// grid edge, SMM places its markers on the improved contour: one open chain from the bottom edge
// (x = 6) up, over the top and to the left edge (y = 4), nothing along the walls. The thesis
// PFM (no such treatment) is reported.
TEST(Baselines, BodyOnTheGridEdgesHasNoBoundaryAlongThem) {
  const auto cloud = lattice_cloud(kH, Placement::kEqualSpacing, Vec2(0, 0), Vec2(6, 4),
                                   [](const Vec2&) { return true; });
  const Grid g = test_grid();
  for (const auto method : {DetectorMethod::kImproved, DetectorMethod::kSmm, DetectorMethod::kVof,
                            DetectorMethod::kDensity, DetectorMethod::kPfm}) {
    DetectorState state;
    const auto b = detect(cloud.view(), g, config_of(method), state);
    std::size_t along_walls = 0;
    for (const auto& c : b.contours) {
      for (const auto& p : c.points) along_walls += (p.x() < 5.5 && p.y() < 3.5) ? 1 : 0;
    }
    std::printf("walls     %-8s contours %zu, points along the walls %zu",
                detector_method_name(method), b.contours.size(), along_walls);
    if (!b.contours.empty()) {
      const auto& c = b.contours[0];
      std::printf(", first (%.4f, %.4f) last (%.4f, %.4f)", c.points.front().x(),
                  c.points.front().y(), c.points.back().x(), c.points.back().y());
    }
    std::printf("\n");
    if (method == DetectorMethod::kPfm) continue;
    ASSERT_EQ(b.contours.size(), 1u) << detector_method_name(method);
    const auto& c = b.contours[0];
    EXPECT_FALSE(c.closed);
    EXPECT_EQ(along_walls, 0u) << detector_method_name(method);
    EXPECT_EQ(c.points.front().y(), 0.0);
    EXPECT_NEAR(c.points.front().x(), 6.0, 0.02 * kH);
    EXPECT_EQ(c.points.back().x(), 0.0);
    EXPECT_NEAR(c.points.back().y(), 4.0, 0.02 * kH);
    EXPECT_EQ(check_invariants(b, g, {}).total(), 0);
  }
}

// Reported, with the contract asserted: the 45-degree slope (the embankment of the static-shape
// tests) and the ring (outer loop counter-clockwise, hole clockwise).
TEST(Baselines, SlopeAndRingReported) {
  for (const auto placement : {Placement::kEqualSpacing, Placement::kGaussPoints}) {
    const double c = placement == Placement::kEqualSpacing ? 0.125 : 0.25;
    const std::vector<Vec2> body = {Vec2(1, 1),         Vec2(11, 1),        Vec2(11, 8),
                                    Vec2(c + 8.0, 8.0), Vec2(c + 3.0, 3.0), Vec2(1, 3)};
    const auto slope = lattice_cloud(kH, placement, Vec2(1, 1), Vec2(11, 8), [c](const Vec2& x) {
      return x.y() < 3.0 || x.x() - x.y() > c;
    });
    const Vec2 centre(6.0, 5.0);
    const auto ring = lattice_cloud(kH, placement, Vec2(3, 2), Vec2(9, 8), [&](const Vec2& x) {
      const double r = (x - centre).norm();
      return r < 2.0 && r > 1.0;
    });
    const double outer =
        std::sqrt(kH * kH / 4.0 *
                  lattice_cloud(kH, placement, Vec2(3, 2), Vec2(9, 8),
                                [&](const Vec2& x) { return (x - centre).norm() < 2.0; })
                      .position.size() /
                  std::numbers::pi);
    const double inner =
        std::sqrt(outer * outer - kH * kH / 4.0 * ring.position.size() / std::numbers::pi);
    for (int m = 0; m < 3; ++m) {
      DetectorState s1, s2;
      const auto b = detect(slope.view(), test_grid(), config_of(kBaselines[m]), s1);
      expect_contract(b, test_grid(), slope, detector_method_name(kBaselines[m]));
      const auto r = face_distances(b, body, 1.5 * kH, kH);
      const Stats flat = faces_of(r, {0, 1, 2, 4, 5});
      std::printf(
          "slope45   %-5s %-8s loops %zu  45deg mean %.4f h max %.4f h  flat max %.4f h"
          "  corners max %.4f h\n",
          placement_name(placement), detector_method_name(kBaselines[m]), b.contours.size(),
          r.face[3].mean, r.face[3].max, flat.max, r.corner.max);
      const auto rb = detect(ring.view(), test_grid(), config_of(kBaselines[m]), s2);
      expect_contract(rb, test_grid(), ring, detector_method_name(kBaselines[m]));
      ASSERT_EQ(rb.contours.size(), 2u) << detector_method_name(kBaselines[m]);
      EXPECT_GT(signed_area(rb.contours[0]), 0.0);
      EXPECT_LT(signed_area(rb.contours[1]), 0.0);
      const auto ro = circle_errors(DetectedBoundary{{rb.contours[0]}}, centre, outer, kH);
      const auto ri = circle_errors(DetectedBoundary{{rb.contours[1]}}, centre, inner, kH);
      std::printf(
          "ring      %-5s %-8s outer R=%.3f bias %+.4f h max %.4f h; inner R=%.3f bias %+.4f h "
          "max %.4f h\n",
          placement_name(placement), detector_method_name(kBaselines[m]), outer, ro.bias,
          ro.absolute.max, inner, ri.bias, ri.absolute.max);
    }
  }
}

// Clear of the walls (half a cell, more than a spacing): no mirroring; the improved contour is the
// one found on a grid that reaches far beyond the body (shifted by whole cells).
TEST(Baselines, BodyClearOfTheGridEdgesIsNotMirrored) {
  const auto cloud = lattice_cloud(kH, Placement::kEqualSpacing, Vec2(0.5, 0.5), Vec2(6, 4),
                                   [](const Vec2&) { return true; });
  Grid wide = test_grid();
  wide.origin = Vec2(-5.0, -5.0);
  wide.n_cells_x += 10;
  wide.n_cells_y += 10;
  DetectorState s1, s2;
  const auto near = detect(cloud.view(), test_grid(), config_of(DetectorMethod::kImproved), s1);
  const auto far = detect(cloud.view(), wide, config_of(DetectorMethod::kImproved), s2);
  ASSERT_EQ(near.contours.size(), 1u);
  ASSERT_EQ(far.contours.size(), 1u);
  EXPECT_TRUE(near.contours[0].closed);
  ASSERT_EQ(near.contours[0].points.size(), far.contours[0].points.size());
  // The same points up to round-off (a flat bottom face makes the "lowest" starting point a
  // round-off decision, so the loops are compared as point sets).
  double worst = 0.0;
  for (const Vec2& p : near.contours[0].points) {
    double nearest = 1e300;
    for (const Vec2& q : far.contours[0].points) nearest = std::min(nearest, (p - q).norm());
    worst = std::max(worst, nearest);
  }
  EXPECT_LE(worst, 1e-9 * kH);
}

}  // namespace
}  // namespace pfm::test

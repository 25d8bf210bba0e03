// Static bodies at h = 0.5 m with 2 x 2 material points per cell (equal spacing and Gauss
// points): distance from the detected boundary to the exact geometry in units of h. The thesis
// PFM is reported; the improved detector is asserted (targets from issue 3).
#include <gtest/gtest.h>

#include <cstdio>
#include <string>

#include "detect_test_support.hpp"

namespace pfm::test {
namespace {

constexpr double kH = 0.5;

Grid test_grid() {
  Grid g;
  g.origin = Vec2(0.0, 0.0);
  g.cell_size = kH;
  g.n_cells_x = 24;
  g.n_cells_y = 20;
  return g;
}

DetectorConfig improved_config() {
  DetectorConfig c;
  c.method = DetectorMethod::kImproved;
  return c;
}

DetectorConfig thesis_config() {
  DetectorConfig c;
  c.method = DetectorMethod::kPfm;
  return c;
}

// The detectors compared: the thesis PFM (reported), the improved detector and the improved
// detector with its kernels shaped by the neighbours (neighbour_shape 0.7; both asserted).
constexpr int kVariants[3] = {0, 1, 2};

DetectorConfig variant_config(int variant) {
  if (variant == 0) return thesis_config();
  DetectorConfig c = improved_config();
  if (variant == 2) c.improved.neighbour_shape = 0.7;
  return c;
}

const char* variant_name(int variant) {
  return variant == 0 ? "thesis" : (variant == 1 ? "improved" : "shaped");
}

DetectedBoundary run(const OwnedCloud& cloud, const DetectorConfig& config,
                     DetectionTimings* timings = nullptr) {
  DetectorState state;
  return detect(cloud.view(), test_grid(), config, state, timings);
}

double kernel_radius(const DetectorConfig& c) {
  return c.improved.radius_factor * kH / 2.0;
}

TEST(StaticShapes, RectangleFlatFaces) {
  const std::vector<Vec2> rect = {Vec2(2, 2), Vec2(8, 2), Vec2(8, 6), Vec2(2, 6)};
  for (const auto placement : {Placement::kEqualSpacing, Placement::kGaussPoints}) {
    const auto cloud =
        lattice_cloud(kH, placement, Vec2(2, 2), Vec2(8, 6), [](const Vec2&) { return true; });
    for (const int variant : kVariants) {
      const bool improved = variant > 0;
      const auto config = variant_config(variant);
      DetectionTimings t;
      const auto b = run(cloud, config, &t);
      ASSERT_GE(b.contours.size(), 1u);
      const auto r = face_distances(b, rect, 1.5 * kernel_radius(improved_config()) + kH, kH);
      const Stats& faces = r.faces;
      std::printf(
          "rectangle %-5s %-8s loops %zu  faces mean %.4f h max %.4f h  corners max %.4f h"
          "  (refinement %d, %.2f ms)\n",
          placement_name(placement), variant_name(variant), b.contours.size(), faces.mean,
          faces.max, r.corner.max, t.refinement,
          1e3 * (t.field + t.edge_points + t.connection + t.filters));
      if (improved) {
        EXPECT_EQ(b.contours.size(), 1u);
        EXPECT_LE(faces.max, 0.02);
      }
    }
  }
}

TEST(StaticShapes, RectangleCornersStayInsideAtEveryPointCount) {
  // The rectangle at n x n points per cell (equal spacing s = h / n): the contours keep every
  // point inside, and no sample lies outside the rectangle by more than the flat faces' bar,
  // corners included; the corners are cut by a fixed fraction of a spacing. With fine cells of
  // h / 4 at every n, the first contours would cut a corner off past its corner point at n >= 3,
  // and that point's bridge would stand out of the body (pass_refinement).
  const Vec2 lo(2, 2), hi(8, 6);
  const std::vector<Vec2> rect = {lo, Vec2(hi.x(), lo.y()), hi, Vec2(lo.x(), hi.y())};
  for (const int n : {2, 3, 4, 5}) {
    OwnedCloud cloud;
    const double s = kH / n;
    cloud.initial_spacing = s;
    for (double y = lo.y() + 0.5 * s; y < hi.y(); y += s) {
      for (double x = lo.x() + 0.5 * s; x < hi.x(); x += s) {
        cloud.position.emplace_back(x, y);
        cloud.volume.push_back(s * s);
      }
    }
    for (const int variant : {1, 2}) {
      SCOPED_TRACE(std::to_string(n) + " x " + std::to_string(n) + " " + variant_name(variant));
      const DetectedBoundary b = run(cloud, variant_config(variant));
      ASSERT_EQ(b.contours.size(), 1u);
      double outside = 0.0;  // the largest distance outside the rectangle, m
      for (const Vec2& p : boundary_samples(b)) {
        const Vec2 beyond = (lo - p).cwiseMax(p - hi).cwiseMax(0.0);
        outside = std::max(outside, beyond.norm());
      }
      const FaceReport r = face_distances(b, rect, 1.5 * kernel_radius(improved_config()) + kH, kH);
      EXPECT_LE(outside / kH, 0.02);
      EXPECT_LE(r.faces.max, 0.02);
      EXPECT_LE(r.corner.max * kH, 0.4 * s)
          << "corner cut " << r.corner.max * kH / s << " spacings";  // 0.35 s at every n
      int left_out = 0;
      for (const Vec2& x : cloud.position) left_out += material_winding(b, x) != 1;
      EXPECT_EQ(left_out, 0);
    }
  }
}

TEST(StaticShapes, FortyFiveDegreeSlope) {
  for (const auto placement : {Placement::kEqualSpacing, Placement::kGaussPoints}) {
    // An embankment: ground at y = 3 m left of the toe, a 45-degree slope x - y = c up to the
    // crest at y = 8 m. The line lies half way between the particle diagonals next to it, so the
    // particles represent exactly the polygon (equal spacing: c = (m + 1/2) h / 2; Gauss points:
    // c = (n + 1/2) h, where the mass of the 2 x 2 Gauss pattern balances).
    const double c = placement == Placement::kEqualSpacing ? 0.125 : 0.25;
    const std::vector<Vec2> body = {Vec2(1, 1),         Vec2(11, 1),        Vec2(11, 8),
                                    Vec2(c + 8.0, 8.0), Vec2(c + 3.0, 3.0), Vec2(1, 3)};
    const auto cloud = lattice_cloud(kH, placement, Vec2(1, 1), Vec2(11, 8), [c](const Vec2& x) {
      return x.y() < 3.0 || x.x() - x.y() > c;
    });
    for (const int variant : kVariants) {
      const bool improved = variant > 0;
      const auto config = variant_config(variant);
      const auto b = run(cloud, config);
      ASSERT_GE(b.contours.size(), 1u);
      const auto r = face_distances(b, body, 1.5 * kernel_radius(improved_config()) + kH, kH);
      const Stats& slope = r.face[3];
      const Stats flat = faces_of(r, {0, 1, 2, 4, 5});
      std::printf(
          "slope45   %-5s %-8s loops %zu  45deg mean %.4f h max %.4f h  flat max %.4f h"
          "  corners max %.4f h\n",
          placement_name(placement), variant_name(variant), b.contours.size(), slope.mean,
          slope.max, flat.max, r.corner.max);
      if (improved) {
        EXPECT_EQ(b.contours.size(), 1u);
        EXPECT_GT(slope.count, 10);
        EXPECT_LE(slope.mean, 0.01);
        EXPECT_LE(slope.max, 0.05);
        EXPECT_LE(flat.max, 0.02);
      }
    }
  }
}

TEST(StaticShapes, RotatedSquare) {
  // A 4 m square whose lattice is rotated rigidly by 30 degrees about (6, 5): F = R(30).
  const double angle = std::numbers::pi / 6.0;
  Mat2 rot;
  rot << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle);
  const Vec2 centre(6.0, 5.0);
  std::vector<Vec2> body;
  for (const Vec2& corner : {Vec2(4, 3), Vec2(8, 3), Vec2(8, 7), Vec2(4, 7)}) {
    body.push_back(centre + rot * (corner - centre));
  }
  for (const auto placement : {Placement::kEqualSpacing, Placement::kGaussPoints}) {
    const auto cloud = lattice_cloud(
        kH, placement, Vec2(4, 3), Vec2(8, 7), [](const Vec2&) { return true; }, rot, centre);
    for (const int variant : kVariants) {
      const bool improved = variant > 0;
      const auto config = variant_config(variant);
      const auto b = run(cloud, config);
      ASSERT_GE(b.contours.size(), 1u);
      const auto r = face_distances(b, body, 1.5 * kernel_radius(improved_config()) + kH, kH);
      const Stats& faces = r.faces;
      std::printf(
          "square30  %-5s %-8s loops %zu  faces mean %.4f h max %.4f h  corners max %.4f h\n",
          placement_name(placement), variant_name(variant), b.contours.size(), faces.mean,
          faces.max, r.corner.max);
      if (improved) {
        EXPECT_EQ(b.contours.size(), 1u);
        EXPECT_LE(faces.max, 0.02);
      }
    }
  }
}

// Radial distances to circles of radius `radii` about `centre`: signed mean (bias, > 0 outside)
// and mean/max of the absolute value, per circle, in units of h.
void circle_report(const char* name, const DetectedBoundary& b, const Vec2& centre,
                   const std::vector<double>& radii, int variant, Placement placement,
                   std::vector<double>* bias_out) {
  for (const double radius : radii) {
    Stats absolute;
    double bias = 0.0;
    for (const auto& p : boundary_samples(b)) {
      double best = 1e300, signed_distance = 0.0;
      for (const double r : radii) {
        const double d = (p - centre).norm() - r;
        if (std::abs(d) < best) {
          best = std::abs(d);
          signed_distance = d;
        }
      }
      if (std::abs((p - centre).norm() - radius) > best + 1e-12) continue;
      absolute.add(best / kH);
      bias += signed_distance / kH;
    }
    absolute.finish();
    bias /= std::max(absolute.count, 1);
    if (bias_out != nullptr) bias_out->push_back(bias);
    std::printf("%-9s %-5s %-8s R=%.3f  bias %+.4f h  mean %.4f h max %.4f h  loops %zu\n", name,
                placement_name(placement), variant_name(variant), radius, bias, absolute.mean,
                absolute.max, b.contours.size());
  }
}

TEST(StaticShapes, DiskBiasWithinCurvatureBound) {
  // Lattice points inside a circle of radius 2 m cover 13.0 m^2 instead of 4 pi: the exact body
  // is the disk of the particles' total volume (radius 2.034 m).
  const Vec2 centre(6.0, 5.0);
  for (const auto placement : {Placement::kEqualSpacing, Placement::kGaussPoints}) {
    const auto cloud = lattice_cloud(kH, placement, Vec2(3, 2), Vec2(9, 8),
                                     [&](const Vec2& x) { return (x - centre).norm() < 2.0; });
    double volume = 0.0;
    for (const double v : cloud.volume) volume += v;
    const double radius = std::sqrt(volume / std::numbers::pi);
    for (const int variant : kVariants) {
      const bool improved = variant > 0;
      auto config = variant_config(variant);
      const auto b = run(cloud, config);
      std::vector<double> bias;
      circle_report("disk", b, centre, {radius}, variant, placement, &bias);
      if (improved) {
        ASSERT_EQ(b.contours.size(), 1u);
        const double a = kernel_radius(config);
        const double bound = (1.0 / radius) * a * a / 10.0 / kH + 0.02;
        EXPECT_LE(std::abs(bias[0]), bound) << "bound " << bound << " h";
        config.improved.curvature_correction = true;
        const auto corrected = run(cloud, config);
        std::vector<double> corrected_bias;
        circle_report("disk+corr", corrected, centre, {radius}, variant, placement,
                      &corrected_bias);
      }
    }
  }
}

TEST(StaticShapes, Ring) {
  // Exact circles: radii of the disks with the volume of the particles inside each circle.
  const Vec2 centre(6.0, 5.0);
  for (const auto placement : {Placement::kEqualSpacing, Placement::kGaussPoints}) {
    const auto cloud = lattice_cloud(kH, placement, Vec2(3, 2), Vec2(9, 8), [&](const Vec2& x) {
      const double r = (x - centre).norm();
      return r < 2.0 && r > 1.0;
    });
    const auto disk_cloud = lattice_cloud(kH, placement, Vec2(3, 2), Vec2(9, 8),
                                          [&](const Vec2& x) { return (x - centre).norm() < 2.0; });
    const double outer = std::sqrt(kH * kH / 4.0 * disk_cloud.position.size() / std::numbers::pi);
    const double inner = std::sqrt(
        std::max(0.0, outer * outer - kH * kH / 4.0 * cloud.position.size() / std::numbers::pi));
    for (const int variant : kVariants) {
      const bool improved = variant > 0;
      const auto config = variant_config(variant);
      const auto b = run(cloud, config);
      circle_report("ring", b, centre, {inner, outer}, variant, placement, nullptr);
      if (improved) {
        ASSERT_EQ(b.contours.size(), 2u);
        EXPECT_GT(signed_area(b.contours[0]), 0.0);  // the outer loop starts lower
        EXPECT_LT(signed_area(b.contours[1]), 0.0);  // the hole runs clockwise
      }
    }
  }
}

}  // namespace
}  // namespace pfm::test

namespace pfm::test {
namespace {

TEST(StaticShapes, AffinelyDeformedRectangleKeepsFlatFaces) {
  // With S = F S0 and V = J V0 the improved field of an affinely deformed lattice is the
  // reference field mapped by F, so the parallelogram's faces are found as well as the
  // rectangle's (stretch 1.4 x 0.8 with shear 0.35, J = 1.12).
  Mat2 f;
  f << 1.4, 0.35, 0.0, 0.8;
  const Vec2 centre(5.0, 4.0);
  std::vector<Vec2> body;
  for (const Vec2& corner : {Vec2(2, 2), Vec2(8, 2), Vec2(8, 6), Vec2(2, 6)}) {
    body.push_back(centre + f * (corner - centre));
  }
  for (const auto placement : {Placement::kEqualSpacing, Placement::kGaussPoints}) {
    const auto cloud = lattice_cloud(
        kH, placement, Vec2(2, 2), Vec2(8, 6), [](const Vec2&) { return true; }, f, centre);
    for (const int variant : kVariants) {
      const bool improved = variant > 0;
      auto config = variant_config(variant);
      config.pfm.deformation = KernelDeformation::kSmallStrain;
      DetectorState state;
      const auto b = detect(cloud.view(), test_grid(), config, state);
      ASSERT_GE(b.contours.size(), 1u);
      const auto r = face_distances(b, body, 1.5 * 1.4 * kernel_radius(improved_config()) + kH, kH);
      const Stats& faces = r.faces;
      std::printf(
          "sheared   %-5s %-8s loops %zu  faces mean %.4f h max %.4f h  corners max %.4f h\n",
          placement_name(placement), variant_name(variant), b.contours.size(), faces.mean,
          faces.max, r.corner.max);
      if (improved) {
        EXPECT_EQ(b.contours.size(), 1u);
        EXPECT_GT(faces.count, 20);
        EXPECT_LE(faces.max, 0.02);
      }
    }
  }
}

}  // namespace
}  // namespace pfm::test

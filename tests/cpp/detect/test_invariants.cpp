// Contour invariants on 10,000 seeded random clouds (1,000 under the sanitizers): closed or ending
// on the field-grid edge, every point joined to exactly two segments (no point shared between
// contours), no crossings, orientation consistent with nesting, every material point inside the
// detected material. Asserted zero for the improved detector; the thesis PFM's counts are printed
// beside them. On every cloud the improved detector gives bitwise the contours of its reference
// (reference_detector.cpp, `narrow_band: false`).
#include <gtest/gtest.h>

#include <chrono>
#include <cstdio>

#include "random_clouds.hpp"

namespace pfm::test {
namespace {

// Under AddressSanitizer (the `make test` sanitizer pass, -O1 and instrumented) the first 1,000
// clouds, 200 of each kind, take the same code paths at a tenth of the cost.
#if defined(__SANITIZE_ADDRESS__)
constexpr int kClouds = 1000;
#else
constexpr int kClouds = 10000;
#endif

TEST(Invariants, ImprovedDetectorHasNoViolationsThesisCountsReported) {
  DetectorConfig improved;
  improved.method = DetectorMethod::kImproved;
  DetectorConfig reference = improved;
  reference.improved.narrow_band = false;
  DetectorConfig thesis;
  thesis.method = DetectorMethod::kPfm;
  thesis.pfm.deformation = KernelDeformation::kSmallStrain;
  const char* kinds[5] = {"perturbed lattice", "affine", "hole", "blobs", "filament"};
  Violations improved_by_kind[5], thesis_by_kind[5];
  long particles = 0, max_refinement = 0, second_passes = 0, differs_from_reference = 0;
  double improved_seconds = 0.0, thesis_seconds = 0.0;
  double improved_seconds_by_kind[5] = {0, 0, 0, 0, 0};
  long evaluations_by_kind[5] = {0, 0, 0, 0, 0};
  for (int seed = 0; seed < kClouds; ++seed) {
    const auto rc = random_case(static_cast<std::uint64_t>(seed));
    const int kind = seed % 5;
    particles += static_cast<long>(rc.cloud.position.size());
    DetectorState state;
    DetectionTimings t;
    const auto b = detect(rc.cloud.view(), rc.grid, improved, state, &t);
    improved_seconds += t.field + t.edge_points + t.connection + t.filters;
    improved_seconds_by_kind[kind] += t.field + t.edge_points + t.connection + t.filters;
    evaluations_by_kind[kind] += t.field_evaluations;
    max_refinement = std::max<long>(max_refinement, t.refinement);
    second_passes += t.particles_outside_first_contours > 0 ? 1 : 0;
    const auto v = check_invariants(b, rc.grid, rc.cloud.position);
    if (v.total() > 0 && improved_by_kind[kind].total() == 0) {
      std::printf("first improved violation: seed %d (%s), %zu particles, refinement %d\n", seed,
                  rc.kind, rc.cloud.position.size(), t.refinement);
    }
    improved_by_kind[kind] += v;
    DetectorState reference_state;
    if (!same_contours(b, detect(rc.cloud.view(), rc.grid, reference, reference_state))) {
      std::printf("differs from the reference: seed %d (%s)\n", seed, rc.kind);
      ++differs_from_reference;
    }
    DetectorState thesis_state;
    DetectionTimings tt;
    const auto bt = detect(rc.cloud.view(), rc.grid, thesis, thesis_state, &tt);
    thesis_seconds += tt.field + tt.edge_points + tt.connection + tt.filters;
    thesis_by_kind[kind] += check_invariants(bt, rc.grid, rc.cloud.position);
  }
  std::printf(
      "%d clouds, %ld particles; improved %.2f s (max refinement %ld, %ld clouds contoured "
      "twice), thesis %.2f s; %ld differ from the reference detector\n",
      kClouds, particles, improved_seconds, max_refinement, second_passes, thesis_seconds,
      differs_from_reference);
  std::printf("%-18s | %-44s | %-44s\n", "violations",
              "improved: open shared cross orient wind out",
              "thesis PFM: open shared cross orient wind out");
  Violations improved_total;
  for (int k = 0; k < 5; ++k) {
    const auto& a = improved_by_kind[k];
    const auto& b = thesis_by_kind[k];
    std::printf("%-18s | %6ld %6ld %6ld %6ld %6ld %6ld       | %6ld %6ld %6ld %6ld %6ld %6ld\n",
                kinds[k], a.open_not_on_edge, a.shared_points, a.self_intersections, a.orientation,
                a.winding, a.particles_outside, b.open_not_on_edge, b.shared_points,
                b.self_intersections, b.orientation, b.winding, b.particles_outside);
    improved_total += a;
  }
  for (int k = 0; k < 5; ++k) {
    std::printf("%-18s improved %.2f s, %.1f field evaluations per cloud\n", kinds[k],
                improved_seconds_by_kind[k], evaluations_by_kind[k] / (kClouds / 5.0));
  }
  EXPECT_EQ(improved_total.open_not_on_edge, 0);
  EXPECT_EQ(improved_total.shared_points, 0);
  EXPECT_EQ(improved_total.self_intersections, 0);
  EXPECT_EQ(improved_total.orientation, 0);
  EXPECT_EQ(improved_total.winding, 0);
  EXPECT_EQ(improved_total.particles_outside, 0);
  EXPECT_EQ(differs_from_reference, 0);
}

// The same clouds with the kernels shaped by the neighbours (neighbour_shape 0.7): zero
// violations again, and the narrow band gives bitwise the reference detector's contours; the
// filaments (one or two points wide, bent, jittered) found as one loop are counted with and
// without the option.
TEST(Invariants, NeighbourShapedDetectorHasNoViolations) {
  DetectorConfig plain;
  plain.method = DetectorMethod::kImproved;
  DetectorConfig shaped = plain;
  shaped.improved.neighbour_shape = 0.7;
  DetectorConfig shaped_full = shaped;
  shaped_full.improved.narrow_band = false;
  Violations total;
  long band_differs = 0;
  long filaments = 0, plain_one_loop = 0, shaped_one_loop = 0;
  double shape_seconds = 0.0, seconds = 0.0;
  for (int seed = 0; seed < kClouds; ++seed) {
    const auto rc = random_case(static_cast<std::uint64_t>(seed));
    DetectorState state;
    DetectionTimings t;
    const auto b = detect(rc.cloud.view(), rc.grid, shaped, state, &t);
    shape_seconds += t.field_parts.shape;
    seconds += t.field + t.edge_points + t.connection + t.filters;  // field holds the shapes
    const auto v = check_invariants(b, rc.grid, rc.cloud.position);
    if (v.total() > 0 && total.total() == 0) {
      std::printf("first violation: seed %d (%s), %zu particles\n", seed, rc.kind,
                  rc.cloud.position.size());
    }
    total += v;
    DetectorState full_state;
    band_differs +=
        same_contours(b, detect(rc.cloud.view(), rc.grid, shaped_full, full_state)) ? 0 : 1;
    if (seed % 5 == 4) {
      ++filaments;
      DetectorState plain_state;
      const auto bp = detect(rc.cloud.view(), rc.grid, plain, plain_state);
      plain_one_loop += bp.contours.size() == 1 ? 1 : 0;
      shaped_one_loop += b.contours.size() == 1 ? 1 : 0;
    }
  }
  std::printf(
      "%d clouds with neighbour_shape 0.7: %.2f s (shapes %.2f s); violations: open %ld "
      "shared %ld cross %ld orient %ld wind %ld out %ld; filaments found as one loop: "
      "%ld of %ld (without the option %ld); narrow band differs from the reference on "
      "%ld\n",
      kClouds, seconds, shape_seconds, total.open_not_on_edge, total.shared_points,
      total.self_intersections, total.orientation, total.winding, total.particles_outside,
      shaped_one_loop, filaments, plain_one_loop, band_differs);
  EXPECT_EQ(total.total(), 0);
  EXPECT_EQ(band_differs, 0);
}

}  // namespace
}  // namespace pfm::test

namespace pfm::test {
namespace {

// Four points stacked at a fine cell's centre (spacing 0.1 m, kernels of 1.5 spacings and a
// quarter of the volume of a spacing squared each, so phi = 0.566 there, above the guard margin)
// make an island of radius 0.03 m that no node of the 0.05 m fine cells (half a spacing) sees:
// the first contours miss it, the containment check guards the four points, and the second
// pass finds their island (fuzz_detect's finding, tests/fuzz/README.md).
TEST(Invariants, StackedPointsSmallerThanAFineCellAreGuardedInASecondPass) {
  OwnedCloud cloud;
  cloud.initial_spacing = 0.1;
  for (int k = 0; k < 4; ++k) {
    cloud.position.emplace_back(3.025, 2.425);
    cloud.volume.push_back(0.0025);
  }
  Grid g;
  g.cell_size = 0.5;
  g.n_cells_x = 12;
  g.n_cells_y = 10;
  DetectorConfig band, full;
  band.method = full.method = DetectorMethod::kImproved;
  band.improved.radius_factor = full.improved.radius_factor = 1.5;
  full.improved.narrow_band = false;
  for (const DetectorConfig* config : {&band, &full}) {
    DetectorState state;
    DetectionTimings t;
    const auto b = detect(cloud.view(), g, *config, state, &t);
    EXPECT_EQ(t.particles_guarded_after_contouring, 4);
    ASSERT_EQ(b.contours.size(), 1u);
    EXPECT_EQ(check_invariants(b, g, cloud.position).total(), 0);
  }
}

TEST(Invariants, BodyCutByTheFieldGridGivesOneOpenChainEndingOnItsEdge) {
  // The rectangle [2, 8] x [2, 6] on a grid starting at y = 3: one open chain from the grid's
  // bottom edge (x = 8 side) over the top back to the bottom edge (x = 2 side), material on the
  // left, i.e. the chain runs counter-clockwise: starts near x = 8, ends near x = 2.
  const auto cloud = lattice_cloud(0.5, Placement::kEqualSpacing, Vec2(2, 2), Vec2(8, 6),
                                   [](const Vec2&) { return true; });
  Grid g;
  g.origin = Vec2(0.0, 3.0);
  g.cell_size = 0.5;
  g.n_cells_x = 20;
  g.n_cells_y = 10;
  for (const auto method : {DetectorMethod::kImproved, DetectorMethod::kPfm}) {
    DetectorConfig config;
    config.method = method;
    DetectorState state;
    const auto b = detect(cloud.view(), g, config, state);
    ASSERT_EQ(b.contours.size(), 1u);
    const auto& c = b.contours[0];
    EXPECT_FALSE(c.closed);
    EXPECT_DOUBLE_EQ(c.points.front().y(), 3.0);
    EXPECT_DOUBLE_EQ(c.points.back().y(), 3.0);
    EXPECT_NEAR(c.points.front().x(), 8.0, 0.1);
    EXPECT_NEAR(c.points.back().x(), 2.0, 0.1);
    EXPECT_EQ(check_invariants(b, g, {}).total(), 0);
  }
}

}  // namespace
}  // namespace pfm::test

namespace pfm::test {
namespace {

// The baselines on the same seeded clouds (VOF and density on all of them, SMM, whose static
// result is the improved contour resampled, on the first 1000): contract violations counted and
// reported. Marching squares (density) and the PLIC union boundary (VOF) are closed, oriented
// and point-disjoint by construction: their contract counts are asserted zero; SMM's chords may
// cut corners and thin filaments, so its counts are reported only. Particles outside the region
// are reported for all three.
TEST(Invariants, BaselinesContractCountsReported) {
  const char* names[3] = {"smm", "vof", "density"};
  const DetectorMethod methods[3] = {DetectorMethod::kSmm, DetectorMethod::kVof,
                                     DetectorMethod::kDensity};
  Violations total[3];
  int clouds[3] = {0, 0, 0};
  for (int seed = 0; seed < kClouds; ++seed) {
    const auto rc = random_case(static_cast<std::uint64_t>(seed));
    for (int m = 0; m < 3; ++m) {
      if (methods[m] == DetectorMethod::kSmm && seed >= 1000) continue;
      DetectorConfig config;
      config.method = methods[m];
      DetectorState state;
      total[m] += check_invariants(detect(rc.cloud.view(), rc.grid, config, state), rc.grid,
                                   rc.cloud.position);
      ++clouds[m];
    }
  }
  std::printf("%-8s %6s | open shared  cross orient   wind     out\n", "baseline", "clouds");
  for (int m = 0; m < 3; ++m) {
    const auto& v = total[m];
    std::printf("%-8s %6d | %4ld %6ld %6ld %6ld %6ld %7ld\n", names[m], clouds[m],
                v.open_not_on_edge, v.shared_points, v.self_intersections, v.orientation, v.winding,
                v.particles_outside);
  }
  for (int m = 1; m < 3; ++m) {
    const auto& v = total[m];
    EXPECT_EQ(
        v.open_not_on_edge + v.shared_points + v.self_intersections + v.orientation + v.winding, 0)
        << names[m];
  }
}

}  // namespace
}  // namespace pfm::test

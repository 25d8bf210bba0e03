// The improved detector on the particle states of failing bodies (tests/data/failure_states:
// thesis bearing collapses at 100 and 150 kPa, the slope run-out, the quasi-static default), and
// the kernels' stretch cap that keeps its cost bounded there.
#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <string>

#include "detect_test_support.hpp"
#include "mpm/detect/detect_command.hpp"
#include "mpm/detect/detect_internal.hpp"
#include "mpm/detect/improved_field.hpp"
#include "mpm/detect/loop_classes.hpp"

namespace pfm::test {
namespace {

Mat2 rotation(double angle) {
  Mat2 r;
  r << std::cos(angle), -std::sin(angle), std::sin(angle), std::cos(angle);
  return r;
}

// F = R(a) diag(s1, s2) R(b)^T with singular values from 0.03 to 30: the cap gives
// R(a) diag(clamp(s1), clamp(s2)) R(b)^T, and leaves an F within [1 / cap, cap] bitwise as it was.
TEST(StretchCap, ClampsTheSingularValuesAndKeepsTheirAxes) {
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> angle(-3.2, 3.2),
      log_stretch(-1.5, 1.5);  // log10 of the singular values
  const double cap = 2.0;
  std::vector<Mat2> f, expected;
  for (int k = 0; k < 2000; ++k) {
    const double s1 = std::pow(10.0, log_stretch(rng)), s2 = std::pow(10.0, log_stretch(rng));
    const Mat2 a = rotation(angle(rng)), b = rotation(angle(rng));
    f.push_back(a * Vec2(s1, s2).asDiagonal() * b.transpose());
    expected.push_back(
        a * Vec2(std::clamp(s1, 1.0 / cap, cap), std::clamp(s2, 1.0 / cap, cap)).asDiagonal() *
        b.transpose());
  }
  const std::vector<Mat2> before = f;
  // Volumes V = V0 det F with V0 = 1: the capped ones must be det F'.
  std::vector<double> volume;
  for (const Mat2& m : f) volume.push_back(m.determinant());
  const std::vector<double> volume_before = volume;
  detail::cap_stretch(f, cap, volume);
  double worst = 0.0, worst_volume = 0.0;
  int unchanged = 0;
  for (std::size_t k = 0; k < f.size(); ++k) {
    worst = std::max(worst, (f[k] - expected[k]).norm() / expected[k].norm());
    const double v = expected[k].determinant();
    worst_volume = std::max(worst_volume, std::abs(volume[k] - v) / v);
    double largest = 0.0, smallest = 0.0;
    detail::singular_values(before[k], largest, smallest);
    if (largest <= cap && smallest >= 1.0 / cap) {
      EXPECT_EQ(f[k], before[k]);
      EXPECT_EQ(volume[k], volume_before[k]);
      ++unchanged;
    }
  }
  std::printf("2000 F: worst relative error %.2e (volumes %.2e), %d within the cap\n", worst,
              worst_volume, unchanged);
  EXPECT_LE(worst, 1e-12);
  EXPECT_LE(worst_volume, 1e-12);
  EXPECT_GT(unchanged, 40);  // 68 of them (3.4 %)
}

// The volumes follow the capped F both ways, so a body truly compacted beyond the cap (F =
// diag(1, 0.2) with its points 0.05 m apart in y, V = 0.2 V0) is overfilled by det F' / det F =
// 2.5: its top face lies 0.21 h and its sides 0.41 h outside (mpm/detect/README.md, max_stretch).
// A cap that covers its F (max_stretch 5 = 1 / 0.2) puts the faces back.
TEST(StretchCap, ACompactedBodyIsOverfilledUnlessTheCapCoversItsF) {
  Grid grid;
  grid.cell_size = 0.5;
  grid.n_cells_x = 16;
  grid.n_cells_y = 8;
  OwnedCloud c;
  c.initial_spacing = 0.25;
  const double sx = 0.25, sy = 0.05;  // the block [2, 6] x [1, 3] m
  for (int j = 0; j < 40; ++j) {
    for (int i = 0; i < 16; ++i) {
      c.position.emplace_back(2.0 + (i + 0.5) * sx, 1.0 + (j + 0.5) * sy);
      c.volume.push_back(sx * sy);
      c.deformation_gradient.push_back((Mat2() << 1.0, 0.0, 0.0, 0.2).finished());
    }
  }
  // Mean offset (in h) of the top face's points (x in (3, 5)) and of the right side's (y in
  // (1.5, 2.5)).
  const auto offsets = [&](double cap) {
    DetectorConfig config;
    config.method = DetectorMethod::kImproved;
    config.improved.max_stretch = cap;
    DetectorState state;
    const DetectedBoundary b = detect(c.view(), grid, config, state);
    double top = 0.0, side = 0.0;
    int n_top = 0, n_side = 0;
    for (const Contour& contour : b.contours) {
      for (const Vec2& x : contour.points) {
        if (x.x() > 3.0 && x.x() < 5.0 && x.y() > 2.5) top += x.y() - 3.0, ++n_top;
        if (x.y() > 1.5 && x.y() < 2.5 && x.x() > 5.0) side += x.x() - 6.0, ++n_side;
      }
    }
    EXPECT_GE(n_top, 15);  // a point per fine cell (h / 4) along 2 m
    EXPECT_GE(n_side, 7);  // and along 1 m
    return std::array<double, 2>{top / n_top / grid.cell_size, side / n_side / grid.cell_size};
  };
  const auto capped = offsets(2.0), covered = offsets(5.0);
  std::printf("compacted block, offsets in h: cap 2 top %.4f side %.4f, cap 5 top %.4f side %.4f\n",
              capped[0], capped[1], covered[0], covered[1]);
  EXPECT_GT(capped[0], 0.15);
  EXPECT_GT(capped[1], 0.3);
  EXPECT_LT(std::abs(covered[0]), 0.005);
  EXPECT_LT(std::abs(covered[1]), 0.005);
}

// The bridges of the second pass: every fine node within one fine cell (Chebyshev) of a bridged
// particle or of a bridge segment is inside, so the four corners of the fine cell holding any
// point of the segment are; nothing changes beyond 2.5 fine cells; the value does not depend on
// which end of the segment is named first.
TEST(Bridges, KeepTheCornersOfEveryFineCellTheSegmentCrossesInside) {
  const std::vector<Vec2> position = {{1.03, 1.11}, {1.31, 1.27}, {3.0, 3.0}};
  const std::vector<double> volume = {1e-6, 1e-6, 1e-6};  // phi next to nothing
  const ParticleCloud cloud{position, volume, {}, 0.25};
  ImprovedConfig config;
  const double cell = 0.125, level = config.level;
  ImprovedField forward(cloud, config), backward(cloud, config);
  const std::vector<std::size_t> points = {0};
  const std::vector<std::array<std::size_t, 2>> ab = {{0, 1}}, ba = {{1, 0}};
  forward.add_bridges(points, ab, cell);
  backward.add_bridges(points, ba, cell);
  long corners = 0, far = 0;
  for (int k = 0; k <= 200; ++k) {
    const Vec2 x = position[0] + (k / 200.0) * (position[1] - position[0]);
    const double i = std::floor(x.x() / cell), j = std::floor(x.y() / cell);
    for (int c = 0; c < 4; ++c) {
      const Vec2 node((i + (c & 1)) * cell, (j + (c >> 1)) * cell);
      EXPECT_GT(forward(node), level) << "corner of the fine cell at t = " << k / 200.0;
      EXPECT_EQ(forward(node), backward(node));
      ++corners;
    }
    // 2.6 fine cells off the segment, across it: phi alone.
    const Vec2 normal =
        Vec2(position[0].y() - position[1].y(), position[1].x() - position[0].x()).normalized();
    const Vec2 off = x + 2.6 * std::sqrt(2.0) * cell * normal;
    EXPECT_EQ(forward(off), forward.volume_fraction(off));
    ++far;
  }
  std::printf("%ld fine-cell corners inside, %ld points beyond the bridge unchanged\n", corners,
              far);
  EXPECT_EQ(forward.n_bridges(), 2u);
}

Contour polygon(std::vector<Vec2> points) {
  return Contour{std::move(points), true};
}

Contour circle(const Vec2& centre, double r, bool clockwise) {
  std::vector<Vec2> p;
  for (int k = 0; k < 64; ++k) {
    const double a = 2.0 * std::numbers::pi * k / 64 * (clockwise ? -1.0 : 1.0);
    p.push_back(centre + r * Vec2(std::cos(a), std::sin(a)));
  }
  return polygon(p);
}

// Hand-made loops about a 4 x 4 m block of points (spacing 0.25 m) with a cavity of radius 0.75
// m, and a second block 2 m to its right: each loop gets the class of its definition.
TEST(LoopClasses, EachLoopGetsTheClassOfItsDefinition) {
  const double s = 0.25;
  std::vector<Vec2> points;
  for (double y = 0.125; y < 4.0; y += s) {
    for (double x = 0.125; x < 4.0; x += s) {
      if ((Vec2(x, y) - Vec2(2.0, 2.0)).norm() > 0.75) points.emplace_back(x, y);
    }
  }
  for (double y = 0.125; y < 1.0; y += s) {
    for (double x = 6.125; x < 7.0; x += s) points.emplace_back(x, y);
  }
  DetectedBoundary b;
  b.contours.push_back(polygon({{0, 0}, {4, 0}, {4, 4}, {0, 4}}));                  // body
  b.contours.push_back(circle({2.0, 2.0}, 0.7, true));                              // real hole
  b.contours.push_back(polygon({{1.0, 1.0}, {1.0, 1.1}, {1.1, 1.0}}));              // spurious hole
  b.contours.push_back(polygon({{6, 0}, {7, 0}, {7, 1}, {6, 1}}));                  // island
  b.contours.push_back(polygon({{10, 10}, {11, 10}, {11, 11}, {10, 11}}));          // spurious loop
  b.contours.push_back(polygon({{0.5, 3.0}, {1.0, 3.0}, {1.0, 3.5}, {0.5, 3.5}}));  // in contact
  const LoopClasses c = classify_loops(b, points, s);
  const std::vector<LoopClass> expected = {LoopClass::kBody,         LoopClass::kRealHole,
                                           LoopClass::kSpuriousHole, LoopClass::kIsland,
                                           LoopClass::kSpuriousLoop, LoopClass::kSpuriousIsland};
  EXPECT_EQ(c.of_loop, expected);
  EXPECT_EQ(c.spurious(), 3);
}

// Rows of points one spacing apart, one particle thick (a filament): their volume fraction
// peaks at 0.39 < 0.5 across the row, so each point keeps only its guard island. With the default
// settings the second pass bridges the islands in contact: a straight row of 24 points and a
// curved one (a quarter circle of radius 2 m) are one loop each, with every point inside. With
// spurious_loops "keep" the straight row is 24 guard islands, 23 of them spurious (they touch).
TEST(LoopClasses, AStraightAndACurvedRowAreOneLoopEach) {
  Grid grid;
  grid.cell_size = 0.5;
  grid.n_cells_x = 20;
  grid.n_cells_y = 12;
  const double spacing = 0.25;
  std::vector<Vec2> straight, curved;
  for (int k = 0; k < 24; ++k) {
    straight.emplace_back(2.0 + spacing * k, 3.0);
    const double angle = 0.5 * std::numbers::pi * k / 23.0;  // 2 pi / 4 over 23 chords: 0.137 m
    curved.emplace_back(2.0 + 2.0 * std::cos(angle), 1.0 + 2.0 * std::sin(angle));
  }
  const std::vector<double> volume(24, spacing * spacing);
  DetectorConfig config;
  config.method = DetectorMethod::kImproved;
  for (const auto* row : {&straight, &curved}) {
    DetectorState state;
    const ParticleCloud cloud{*row, volume, {}, spacing};
    const DetectedBoundary b = detect(cloud, grid, config, state);
    const LoopClasses c = classify_loops(b, *row, spacing);
    std::printf("%s row: %zu loops, %ld spurious\n", row == &straight ? "straight" : "curved",
                c.of_loop.size(), c.spurious());
    EXPECT_EQ(b.contours.size(), 1u);
    EXPECT_EQ(c.spurious(), 0);
    EXPECT_EQ(check_invariants(b, grid, *row).total(), 0);
  }
  DetectorConfig keep = config;
  keep.improved.join_spurious_loops = false;
  DetectorState state;
  const ParticleCloud cloud{straight, volume, {}, spacing};
  const LoopClasses c = classify_loops(detect(cloud, grid, keep, state), straight, spacing);
  std::printf("straight row, spurious loops kept: %zu loops, %ld spurious\n", c.of_loop.size(),
              c.spurious());
  EXPECT_EQ(c.bodies, 1);
  EXPECT_EQ(c.spurious_islands, 23);
  EXPECT_EQ(c.bodies + c.spurious_islands, static_cast<long>(c.of_loop.size()));
}

// A 4 x 4 m block (2 x 2 points per 0.5 m cell) whose points in a disk hold a tenth or 0.3 of
// their volume, as a collapse's compacted points do (det F down to 1e-3): their volume fraction
// falls below the level between points one spacing apart. Kept, the contours hold spurious holes
// and spurious guard islands; joined (the default), one loop with every point inside: the islands
// are bridged and the holes no particle-free disk of one spacing fits in are filled.
TEST(SpuriousLoops, ACompactedPatchIsJoinedIntoTheBody) {
  Grid grid;
  grid.origin = Vec2(-1.0, -1.0);
  grid.cell_size = 0.5;
  grid.n_cells_x = 12;
  grid.n_cells_y = 12;
  const double spacing = 0.25;
  DetectorConfig join;
  join.method = DetectorMethod::kImproved;
  DetectorConfig keep = join;
  keep.improved.join_spurious_loops = false;
  for (const double radius : {0.4, 0.6, 0.8}) {
    for (const double fraction : {0.1, 0.3}) {
      std::vector<Vec2> position;
      std::vector<double> volume;
      for (double y = 0.125; y < 4.0; y += spacing) {
        for (double x = 0.125; x < 4.0; x += spacing) {
          position.emplace_back(x, y);
          const bool compacted = (Vec2(x, y) - Vec2(2.02, 1.97)).norm() < radius;
          volume.push_back((compacted ? fraction : 1.0) * spacing * spacing);
        }
      }
      const ParticleCloud cloud{position, volume, {}, spacing};
      DetectorState s1, s2;
      DetectionTimings t;
      const DetectedBoundary kept = detect(cloud, grid, keep, s1);
      const DetectedBoundary joined = detect(cloud, grid, join, s2, &t);
      const LoopClasses k = classify_loops(kept, position, spacing);
      const LoopClasses j = classify_loops(joined, position, spacing);
      std::printf(
          "radius %.1f m, volume x %.1f: kept %zu loops (%ld spurious), joined %zu loop(s) (%ld "
          "bridges, %ld loops removed)\n",
          radius, fraction, kept.contours.size(), k.spurious(), joined.contours.size(), t.bridges,
          t.spurious_loops_removed);
      EXPECT_GT(k.spurious(), 0);
      EXPECT_EQ(joined.contours.size(), 1u);
      EXPECT_EQ(j.spurious(), 0);
      EXPECT_EQ(check_invariants(joined, grid, position).total(), 0);
      EXPECT_EQ(t.guard_refinement_passes, 0);
    }
  }
}

struct State {
  std::string name;
  ParticleTable particles;
  Grid grid;
  double spacing = 0.0;
};

std::vector<State> failure_states() {
  const std::string folder = std::string(PFM_SOURCE_DIR) + "/tests/data/failure_states/";
  std::ifstream index(folder + "states.json");
  const nlohmann::json states = nlohmann::json::parse(index);
  std::vector<State> out;
  for (const auto& s : states) {
    State state;
    state.name = s.at("name").get<std::string>();
    state.particles = read_particle_csv(folder + state.name + ".csv");
    const auto& g = s.at("grid");
    state.grid.origin = Vec2(g.at("origin")[0].get<double>(), g.at("origin")[1].get<double>());
    state.grid.cell_size = g.at("cell_size").get<double>();
    state.grid.n_cells_x = g.at("n_cells")[0].get<int>();
    state.grid.n_cells_y = g.at("n_cells")[1].get<int>();
    state.spacing = s.at("initial_spacing").get<double>();
    out.push_back(std::move(state));
  }
  return out;
}

// Every state with the default settings keeps the contour invariants (closed or ending on the
// grid edge, no shared points, no crossings, orientation, every particle inside). Without the
// cap the collapses' F (singular values up to 2,250) make kernels that reach across the body
// and slivers that split it into hundreds of loops: in Release the uncapped detection runs too,
// and over the states the cap must cut the field evaluations to less than a third (measured:
// 37,115 against 425,558; each uncapped evaluation also searches a wider window, so the time
// falls further on the collapses, tests/data/failure_states/cost.py).
TEST(FailureStates, DefaultDetectionKeepsTheInvariantsAndTheCapCutsTheWork) {
  const std::vector<State> states = failure_states();
  ASSERT_EQ(states.size(), 14u);
  DetectorConfig capped;
  capped.method = DetectorMethod::kImproved;
  DetectorConfig uncapped = capped;
  uncapped.improved.max_stretch = 0.0;
  long capped_evaluations = 0, uncapped_evaluations = 0, spurious = 0, guard_passes = 0,
       differ_without_kept_nodes = 0;
  Violations total;
  for (const State& s : states) {
    const ParticleCloud cloud{s.particles.position, s.particles.volume,
                              s.particles.deformation_gradient, s.spacing};
    DetectorState state;
    DetectionTimings t;
    const auto b = detect(cloud, s.grid, capped, state, &t);
    const Violations v = check_invariants(b, s.grid, s.particles.position);
    const LoopClasses classes = classify_loops(b, s.particles.position, s.spacing);
    spurious += classes.spurious();
    total += v;
    capped_evaluations += t.field_evaluations;
    guard_passes += t.guard_refinement_passes;
    // The second pass keeps the first's fine nodes and edge roots where the field is as it was:
    // the contours must be bitwise those of a second pass that evaluates everything anew.
    detail::keep_nodes_between_passes(false);
    DetectorState fresh_state;
    DetectionTimings fresh;
    const auto anew = detect(cloud, s.grid, capped, fresh_state, &fresh);
    detail::keep_nodes_between_passes(true);
    if (!same_contours(b, anew)) ++differ_without_kept_nodes;
    if (t.bridges > 0) {
      std::printf("  second pass: %ld field evaluations, %ld when evaluated anew\n",
                  t.field_evaluations, fresh.field_evaluations);
    }
    long without = 0;
#if !defined(__SANITIZE_ADDRESS__)
    DetectorState state0;
    DetectionTimings t0;
    detect(cloud, s.grid, uncapped, state0, &t0);
    without = t0.field_evaluations;
    uncapped_evaluations += without;
#endif
    std::printf(
        "%-28s %5zu points: %3zu loops (%ld spurious), %7ld field evaluations (%ld "
        "uncapped), %ld violations\n",
        s.name.c_str(), s.particles.position.size(), b.contours.size(), classes.spurious(),
        t.field_evaluations, without, v.total());
  }
  EXPECT_EQ(total.total(), 0);
  EXPECT_EQ(differ_without_kept_nodes, 0);
  std::printf("spurious loops over the states: %ld, passes at the guards' refinement: %ld\n",
              spurious, guard_passes);
  EXPECT_EQ(spurious, 0);
  EXPECT_EQ(guard_passes, 0);
#if !defined(__SANITIZE_ADDRESS__)
  EXPECT_LT(3 * capped_evaluations, uncapped_evaluations);
#endif
}

}  // namespace
}  // namespace pfm::test

namespace pfm::test {
namespace {

// The narrow band against the reference detector (`narrow_band: false`) on pieces of the failure
// states: 200 windows of 4-11 x 4-9 cells in each state, each keeping the points at least 0.3 h
// inside it, half of them with every point moved at random by up to 0.3 spacings. The windows'
// edges cut torn and compacted bodies, with gaps of up to 0.8 spacings between the points and
// the edge. The band took the cells beyond a wall as the mirror images of those inside all along
// the wall and at any gap, where the field mirrors a point only where the wall is touched within
// its reach, and where gaps along two walls meet at a corner the field opens a hole the volumes
// do not show: 4 of these 2,579 windows lost a chain along the grid edge (38,387 windows, 3,000
// per state, give none now). The whole states too: the band's volumes must not raise a
// compacted point's (the field's do), or a cell its points leave partly empty passes for solid
// (bearing_150kPa_zero_t2.5 lost a guard and left a point in a hole that the reference does not
// have; no window showed it). The bits must be the same on every window and state.
TEST(Determinism, NarrowBandEqualsFullFieldOnWindowsOfFailureStates) {
  DetectorConfig band, full;
  band.method = full.method = DetectorMethod::kImproved;
  full.improved.narrow_band = false;
  std::mt19937_64 rng(12345);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  int mismatches = 0, windows = 0;
  for (const State& s : failure_states()) {
    const ParticleCloud whole{s.particles.position, s.particles.volume,
                              s.particles.deformation_gradient, s.spacing};
    DetectorState w1, w2;
    if (!same_contours(detect(whole, s.grid, band, w1), detect(whole, s.grid, full, w2))) {
      ++mismatches;
      std::printf("narrow band differs: %s, whole state\n", s.name.c_str());
    }
    for (int k = 0; k < 200; ++k) {
      const double h = s.grid.cell_size;
      const int w = 4 + static_cast<int>(u01(rng) * 8), hgt = 4 + static_cast<int>(u01(rng) * 6);
      const int i0 = static_cast<int>(u01(rng) * (s.grid.n_cells_x - w));
      const int j0 = static_cast<int>(u01(rng) * (s.grid.n_cells_y - hgt));
      Grid g;
      g.cell_size = h;
      g.origin = s.grid.origin + Vec2(i0 * h, j0 * h);
      g.n_cells_x = w;
      g.n_cells_y = hgt;
      const double jitter = u01(rng) < 0.5 ? 0.0 : 0.3 * s.spacing * u01(rng);
      OwnedCloud c;
      c.initial_spacing = s.spacing;
      for (std::size_t p = 0; p < s.particles.position.size(); ++p) {
        const Vec2 x =
            s.particles.position[p] + jitter * Vec2(2.0 * u01(rng) - 1.0, 2.0 * u01(rng) - 1.0);
        if (x.x() < g.origin.x() + 0.3 * h || x.y() < g.origin.y() + 0.3 * h ||
            x.x() > g.origin.x() + (w - 0.3) * h || x.y() > g.origin.y() + (hgt - 0.3) * h) {
          continue;
        }
        c.position.push_back(x);
        c.volume.push_back(s.particles.volume[p]);
        c.deformation_gradient.push_back(s.particles.deformation_gradient[p]);
      }
      if (c.position.size() < 3) continue;
      DetectorState s1, s2;
      const auto a = detect(c.view(), g, band, s1);
      const auto b = detect(c.view(), g, full, s2);
      ++windows;
      if (!same_contours(a, b)) {
        ++mismatches;
        std::printf("narrow band differs: %s, window %d\n", s.name.c_str(), k);
      }
    }
  }
  std::printf("%d windows of the failure states and the whole states: %d mismatches\n", windows,
              mismatches);
  EXPECT_GT(windows, 2500);
  EXPECT_EQ(mismatches, 0);
}

}  // namespace
}  // namespace pfm::test

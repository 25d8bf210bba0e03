// The improved detector's kernels shaped by the neighbours (ImprovedConfig::neighbour_shape):
// the window moments against lattice sums done here by hand, the shapes on an affine block and a
// filament one particle thick. The static shapes of issue 3 (test_static_shapes.cpp), the contour
// invariants on the random clouds (test_invariants.cpp) and the particle order
// (test_determinism.cpp) are checked with the option on too.
#include <gtest/gtest.h>
#include <omp.h>

#include <cstdio>

#include "mpm/detect/detect_internal.hpp"
#include "random_clouds.hpp"

namespace pfm::test {
namespace {

constexpr double kH = 0.5;
constexpr double kSpacing = kH / 2.0;
constexpr double kBeta = 0.7;  // the README's suggested value

DetectorConfig shaped_config(double beta = kBeta) {
  DetectorConfig c;
  c.method = DetectorMethod::kImproved;
  c.improved.neighbour_shape = beta;
  return c;
}

Grid grid_of(int nx, int ny) {
  Grid g;
  g.origin = Vec2(0.0, 0.0);
  g.cell_size = kH;
  g.n_cells_x = nx;
  g.n_cells_y = ny;
  return g;
}

DetectedBoundary run(const OwnedCloud& cloud, const Grid& grid, const DetectorConfig& config,
                     DetectionTimings* timings = nullptr) {
  DetectorState state;
  return detect(cloud.view(), grid, config, state, timings);
}

// Sum over the offsets (i, j) s of a square lattice (spacing s) in the window |(i, j) s| < a of
// (1 - |(i, j) s / a|^2)^3 x^2, over the same sum without x^2: the second moment along x in units
// of a^2. `right`: only i >= 0, the offsets with i = 0 counted half (one side of the window, as
// neighbour_window_moment() counts them); `below`: only j <= 0 (the window of a particle on a
// top face).
double lattice_moment(double s, double a, bool right, bool below) {
  double moment = 0.0, weight = 0.0;
  const int n = static_cast<int>(a / s) + 1;
  for (int j = -n; j <= n; ++j) {
    for (int i = -n; i <= n; ++i) {
      const double x = i * s / a, y = j * s / a;
      const double q = x * x + y * y;
      if (q >= 1.0 || (right && i < 0) || (below && j > 0)) continue;
      double w = (1.0 - q) * (1.0 - q) * (1.0 - q);
      if (right && i == 0) w *= 0.5;
      moment += w * x * x;
      weight += w;
    }
  }
  return moment / weight;
}

TEST(NeighbourShape, WindowMomentsAreTheLatticeSumsInsideAtAFaceAndZeroAcrossARow) {
  const ImprovedConfig config = shaped_config().improved;
  const double a0 = config.radius_factor * kSpacing;
  // A block of 24 x 16 points at spacing 0.25 m (equal spacing, 2 x 2 per cell).
  const auto block = lattice_cloud(kH, Placement::kEqualSpacing, Vec2(0, 0), Vec2(6, 4),
                                   [](const Vec2&) { return true; });
  const ParticleCloud cloud = block.view();
  const auto index_of = [&](const Vec2& x) {
    for (std::size_t p = 0; p < block.position.size(); ++p) {
      if ((block.position[p] - x).norm() < 1e-9) return p;
    }
    ADD_FAILURE() << "no particle at " << x.transpose();
    return std::size_t{0};
  };
  const detail::NeighbourSearch search(cloud, a0);
  const auto moment_at = [&](const Vec2& x) {
    return detail::neighbour_window_moment(search, config, block.position[index_of(x)],
                                           Mat2::Identity());
  };

  const double whole = lattice_moment(kSpacing, a0, false, false);
  const double one_side = lattice_moment(kSpacing, a0, true, false);
  // Deep inside: the whole window (its axes are any two: the moment is isotropic).
  const auto deep = moment_at(Vec2(3.125, 2.125));
  EXPECT_NEAR(deep.moment[0], whole, 1e-14);
  EXPECT_NEAR(deep.moment[1], whole, 1e-14);
  EXPECT_NEAR(whole, one_side, 1e-14);  // the lattice is symmetric: each side is the whole
  // The middle of the top face: across the face its inner side is as full as a side inside;
  // along it, the moment of the lower half window.
  const auto face = moment_at(Vec2(3.125, 3.875));
  EXPECT_NEAR(std::abs(face.axis[0].x()), 1.0, 1e-12);
  EXPECT_NEAR(std::abs(face.axis[1].y()), 1.0, 1e-12);
  EXPECT_NEAR(face.moment[1], one_side, 1e-14);
  const double face_along = lattice_moment(kSpacing, a0, true, true);
  EXPECT_NEAR(face.moment[0], face_along, 1e-14);
  EXPECT_GT(face_along, whole);  // (the face's own row weighs more in half a window)
  std::printf("lattice moment / unit window moment: %.6f (a0 = %.2f m, spacing %.2f m)\n",
              whole / detail::neighbour_moment_of_unit_window(config.profile), a0, kSpacing);
  // One row of points: nothing across it.
  OwnedCloud row;
  row.initial_spacing = kSpacing;
  for (int k = 0; k < 20; ++k) {
    row.position.emplace_back(1.0 + k * kSpacing, 1.0);
    row.volume.push_back(kSpacing * kSpacing);
  }
  const ParticleCloud row_cloud = row.view();
  const detail::NeighbourSearch row_search(row_cloud, a0);
  const auto across =
      detail::neighbour_window_moment(row_search, config, row.position[10], Mat2::Identity());
  EXPECT_EQ(across.moment[1], 0.0);
  EXPECT_GT(across.moment[0], whole);
}

TEST(NeighbourShape, AffineBlockKeepsItsDeformationAwayFromItsCorners) {
  // A block under F (J = 1.6, stretch ratio 3, rotated): pulled back by F its windows are those
  // of the square lattice, so every particle keeps the shape F S0 (F' F'^T = F F^T; F' is the
  // symmetric stretch V of F = V R) but near a corner, whose window may be less than half full
  // across the corner's diagonal: there the kernel narrows and never widens.
  const ImprovedConfig config = shaped_config().improved;
  const double a0 = config.radius_factor * kSpacing;
  const double j = 1.6, ratio = 3.0;
  const Mat2 f = rotation_matrix(0.4) *
                 Vec2(std::sqrt(j * ratio), std::sqrt(j / ratio)).asDiagonal() *
                 rotation_matrix(-1.1);
  const Mat2 b = f * f.transpose();
  const Vec2 centre(3.0, 2.0);
  const Mat2 f_inverse = f.inverse();
  for (const auto placement : {Placement::kEqualSpacing, Placement::kGaussPoints}) {
    const auto block = lattice_cloud(
        kH, placement, Vec2(0, 0), Vec2(6, 4), [](const Vec2&) { return true; }, f, centre);
    const auto shaped = detail::neighbour_shaped_deformation(block.view(), config);
    ASSERT_EQ(shaped.size(), block.position.size());
    double worst_kept = 0.0, most_narrowed = 0.0;
    int kept = 0, near_corners = 0;
    for (std::size_t p = 0; p < shaped.size(); ++p) {
      const Mat2& g = shaped[p];
      EXPECT_EQ(g(0, 1), g(1, 0));
      const Mat2 b_shaped = g * g.transpose();
      const double difference = (b_shaped - b).norm() / b.norm();
      // The reference position's distance to the nearest corner of the block.
      const Vec2 x0 = centre + f_inverse * (block.position[p] - centre);
      double corner = 1e300;
      for (const Vec2& c : {Vec2(0, 0), Vec2(6, 0), Vec2(6, 4), Vec2(0, 4)}) {
        corner = std::min(corner, (x0 - c).norm());
      }
      if (corner >= a0) {
        worst_kept = std::max(worst_kept, difference);
        ++kept;
        continue;
      }
      ++near_corners;
      most_narrowed = std::max(most_narrowed, difference);
      // Narrowed, never widened: B - B' positive semi-definite.
      const Mat2 gap = b - b_shaped;
      EXPECT_GE(gap.trace(), -1e-13 * b.norm());
      EXPECT_GE(gap.determinant(), -1e-13 * b.squaredNorm());
    }
    std::printf(
        "affine block (%s): %d particles a kernel radius from the corners keep F F^T "
        "(largest relative difference %.1e); %d near the corners, narrowed by up to %.3f\n",
        placement_name(placement), kept, worst_kept, near_corners, most_narrowed);
    EXPECT_GE(kept, 352);
    EXPECT_LE(worst_kept, 1e-13);
  }
}

// The nearest and farthest of the boundary samples from the segment a-b (m), of those whose
// projection falls at least `end_zone` inside it.
struct Range {
  double min = 1e300, max = 0.0;
  int count = 0;
};

Range distances_to_segment(const DetectedBoundary& boundary, const Vec2& a, const Vec2& b,
                           double end_zone) {
  Range r;
  const Vec2 t = (b - a).normalized();
  for (const Vec2& x : boundary_samples(boundary)) {
    const double along = (x - a).dot(t);
    if (along < end_zone || along > (b - a).norm() - end_zone) continue;
    const double d = segment_distance(x, a, b);
    r.min = std::min(r.min, d);
    r.max = std::max(r.max, d);
    ++r.count;
  }
  return r;
}

TEST(NeighbourShape, FilamentOneParticleThickIsOneLoopOfItsWidth) {
  // 40 points in a row at the initial spacing, along x and at 30 degrees: its material is a
  // strip one spacing wide. Without the option each point keeps its own guard island, which the
  // second pass bridges into one loop (spurious_loops "join", the default) about a fine cell
  // wider than the strip; with "keep", 40 islands.
  const Grid grid = grid_of(28, 20);
  for (const double angle : {0.0, std::numbers::pi / 6.0}) {
    const Vec2 a(2.0, 2.5), t(std::cos(angle), std::sin(angle));
    OwnedCloud row;
    row.initial_spacing = kSpacing;
    for (int k = 0; k < 40; ++k) {
      row.position.push_back(a + (k + 0.5) * kSpacing * t);
      row.volume.push_back(kSpacing * kSpacing);
    }
    const Vec2 b = a + 40 * kSpacing * t;
    const auto plain = run(row, grid, shaped_config(0.0));
    DetectorConfig keep = shaped_config(0.0);
    keep.improved.join_spurious_loops = false;
    const auto islands = run(row, grid, keep);
    DetectionTimings timings;
    const auto shaped = run(row, grid, shaped_config(), &timings);
    // The strip's long faces, away from its rounded ends (a kernel radius and a cell).
    const double end_zone = 3.0 * kSpacing + kH;
    const Range plain_faces = distances_to_segment(plain, a, b, end_zone);
    const Range faces = distances_to_segment(shaped, a, b, end_zone);
    std::printf(
        "filament at %2.0f deg: beta 0: %zu loops, faces %.4f-%.4f h from the axis; beta "
        "%.1f: %zu loop(s), %.4f-%.4f h (true %.4f h), shapes %.3f ms\n",
        angle * 180.0 / std::numbers::pi, plain.contours.size(), plain_faces.min / kH,
        plain_faces.max / kH, kBeta, shaped.contours.size(), faces.min / kH, faces.max / kH,
        0.5 * kSpacing / kH, 1e3 * timings.field_parts.shape);
    EXPECT_GT(faces.count, 100);
    EXPECT_EQ(plain.contours.size(), 1u);
    EXPECT_EQ(check_invariants(plain, grid, row.position).total(), 0);
    EXPECT_EQ(islands.contours.size(), 40u);
    EXPECT_EQ(shaped.contours.size(), 1u);
    // The flat-face target of issue 3: within 0.02 h of the strip's faces.
    EXPECT_LE(std::abs(faces.min - 0.5 * kSpacing), 0.02 * kH);
    EXPECT_LE(std::abs(faces.max - 0.5 * kSpacing), 0.02 * kH);
    EXPECT_EQ(check_invariants(shaped, grid, row.position).total(), 0);
    // The same contours on one thread and on two.
    const int threads = omp_get_max_threads();
    omp_set_num_threads(1);
    const auto one = run(row, grid, shaped_config());
    omp_set_num_threads(2);
    const auto two = run(row, grid, shaped_config());
    omp_set_num_threads(threads);
    EXPECT_TRUE(same_contours(one, two));
    EXPECT_TRUE(same_contours(one, shaped));
  }
}

}  // namespace
}  // namespace pfm::test

// The mirror images of the nodes behind a wall inside the grid (mpm/core/wall_mirror.hpp): with
// B-splines the field of the held component vanishes on the whole wall line for any values of
// the free nodes, next to the grid's clamped edge too; the free component is left alone; the
// scales give the image the row sum of its extended function as its mass; linear functions
// and uGIMP take no mirrors.
#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "mpm/core/wall_mirror.hpp"

namespace pfm {
namespace {

// A grid of 12 x 10 cells of 0.5 m; a wall holding x on the node columns i <= wall_i and a base
// holding x and y on the node rows j <= base_j.
struct Walls {
  Grid grid;
  std::vector<unsigned> fixed;
};

Walls walls(int wall_i, int base_j) {
  Walls w;
  w.grid.origin = Vec2(0.0, 0.0);
  w.grid.cell_size = 0.5;
  w.grid.n_cells_x = 12;
  w.grid.n_cells_y = 10;
  w.fixed.assign(static_cast<std::size_t>(w.grid.n_nodes()), kFixNone);
  for (int j = 0; j < w.grid.n_nodes_y(); ++j) {
    for (int i = 0; i < w.grid.n_nodes_x(); ++i) {
      unsigned& f = w.fixed[static_cast<std::size_t>(w.grid.node_index(i, j))];
      if (i <= wall_i) f |= kFixX;
      if (j <= base_j) f |= kFixXY;
    }
  }
  return w;
}

// The field sum_k N_k(x) v_k of component d.
double field(const Grid& grid, int degree, const std::vector<Vec2>& v, const Vec2& x, int d) {
  const ShapeStencil s = bspline_stencil(grid, degree, x);
  double sum = 0.0;
  for (int b = 0; b < s.width; ++b) {
    for (int a = 0; a < s.width; ++a) {
      sum += s.value[static_cast<std::size_t>(b * s.width + a)] *
             v[static_cast<std::size_t>(grid.node_index(s.base_i + a, s.base_j + b))][d];
    }
  }
  return sum;
}

class MirroredWalls : public ::testing::TestWithParam<std::tuple<ShapeFunctionKind, int>> {};

TEST_P(MirroredWalls, HeldComponentVanishesOnTheWholeWallLine) {
  const auto [kind, margin] = GetParam();
  const int degree = shape_degree(kind);
  const Walls w = walls(margin, margin);
  WallMirror mirror(w.grid, kind, w.fixed);
  ASSERT_FALSE(mirror.empty());
  // Masses that keep every image on: little behind the walls.
  std::vector<double> mass(static_cast<std::size_t>(w.grid.n_nodes()), 1.0);
  for (const WallMirror::Image& image : mirror.images()) {
    for (const WallMirror::Source& s : image.sources)
      mass[static_cast<std::size_t>(s.behind)] = 0.01;
  }
  // A node behind the wall next to the base is an image for y too: more than its source.
  for (const WallMirror::Image& image : mirror.images()) {
    double& m = mass[static_cast<std::size_t>(image.node)];
    if (m < 1.0) m = 0.05;
  }
  mirror.prepare(mass, nullptr);
  for (std::size_t k = 0; k < mirror.images().size(); ++k) {
    ASSERT_TRUE(mirror.active(k)) << "image at node " << mirror.images()[k].node;
  }
  // Any velocities of the free components; the held ones zero, as the grid update leaves them.
  std::mt19937 random(7);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::vector<Vec2> v(static_cast<std::size_t>(w.grid.n_nodes()));
  for (std::size_t n = 0; n < v.size(); ++n) {
    v[n] = Vec2(w.fixed[n] & kFixX ? 0.0 : uniform(random),
                w.fixed[n] & kFixY ? 0.0 : uniform(random));
  }
  const std::vector<Vec2> free = v;
  mirror.extrapolate(std::span<Vec2>(v));
  const double h = w.grid.cell_size;
  const double wall = margin * h;
  double largest_without = 0.0;
  for (double s = wall + 0.013; s < w.grid.n_cells_y * h - 1e-9; s += 0.1) {
    // The wall x = wall (x held) above the base, the base y = wall (x and y held) right of it.
    EXPECT_NEAR(field(w.grid, degree, v, Vec2(wall, s), 0), 0.0, 1e-14) << s;
    largest_without =
        std::max(largest_without, std::abs(field(w.grid, degree, free, Vec2(wall, s), 0)));
    if (s < w.grid.n_cells_x * h) {
      EXPECT_NEAR(field(w.grid, degree, v, Vec2(s, wall), 0), 0.0, 1e-14) << s;
      EXPECT_NEAR(field(w.grid, degree, v, Vec2(s, wall), 1), 0.0, 1e-14) << s;
    }
  }
  // Without the mirrors the wall gives way (1/8 or 1/6 of the free values).
  EXPECT_GT(largest_without, 0.05);
  // The wall's free component (y on the wall) is no image's.
  for (const WallMirror::Image& image : mirror.images()) {
    const int i = image.node % w.grid.n_nodes_x();
    if (i == margin + 1 && image.node / w.grid.n_nodes_x() > margin + 1) {
      EXPECT_EQ(image.component, 0);
    }
  }
}

INSTANTIATE_TEST_SUITE_P(BsplinesAwayFromAndNextToTheGridEdge, MirroredWalls,
                         ::testing::Combine(::testing::Values(ShapeFunctionKind::kQuadraticBspline,
                                                              ShapeFunctionKind::kCubicBspline),
                                            ::testing::Values(1, 2, 4)));

TEST(WallMirror, UniformSplinesMirrorWithWeightMinusOneAndScaleToTheRowSum) {
  const Walls w = walls(4, 4);
  const WallMirror mirror(w.grid, ShapeFunctionKind::kQuadraticBspline, w.fixed);
  // Node (5, 7) mirrors (3, 7) in x across the wall column 4.
  const int image = mirror.image_at(w.grid.node_index(5, 7), 0);
  ASSERT_GE(image, 0);
  ASSERT_EQ(mirror.images()[static_cast<std::size_t>(image)].sources.size(), 1u);
  const WallMirror::Source& source = mirror.images()[static_cast<std::size_t>(image)].sources[0];
  EXPECT_EQ(source.behind, w.grid.node_index(3, 7));
  EXPECT_DOUBLE_EQ(source.weight, -1.0);
  EXPECT_EQ(mirror.image_at(w.grid.node_index(5, 7), 1), -1);  // y is free on the wall
  // By the inside corner node (5, 5) mirrors (3, 5) across the wall, (5, 3) across the base
  // and (3, 3) across both (weight (-1) x (-1)).
  const int corner = mirror.image_at(w.grid.node_index(5, 5), 0);
  ASSERT_GE(corner, 0);
  const auto& sources = mirror.images()[static_cast<std::size_t>(corner)].sources;
  ASSERT_EQ(sources.size(), 3u);
  for (const WallMirror::Source& s : sources) {
    EXPECT_DOUBLE_EQ(s.weight, s.behind == w.grid.node_index(3, 3) ? 1.0 : -1.0);
  }
  // A node on the base line behind the wall, (3, 4), is held: the base's line is not mirrored.
  double unused = 0.0;
  EXPECT_EQ(mirror.source_at(w.grid.node_index(3, 4), 0, unused), -1);
  EXPECT_EQ(mirror.source_at(w.grid.node_index(3, 4), 1, unused), -1);

  std::vector<double> mass(static_cast<std::size_t>(w.grid.n_nodes()), 0.0);
  mass[static_cast<std::size_t>(w.grid.node_index(5, 7))] = 2.0;
  mass[static_cast<std::size_t>(w.grid.node_index(3, 7))] = 0.1;
  WallMirror prepared = mirror;
  prepared.prepare(mass, nullptr);
  ASSERT_TRUE(prepared.active(static_cast<std::size_t>(image)));
  EXPECT_DOUBLE_EQ(prepared.scale(static_cast<std::size_t>(image)), 2.0 / 1.9);
  // Momentum (1, 1) on the image and (0.3, 0.4) behind: x = (1 - 0.3) x 2 / 1.9, y untouched.
  std::vector<Vec2> p(static_cast<std::size_t>(w.grid.n_nodes()), Vec2::Zero());
  p[static_cast<std::size_t>(w.grid.node_index(5, 7))] = Vec2(1.0, 1.0);
  p[static_cast<std::size_t>(w.grid.node_index(3, 7))] = Vec2(0.3, 0.4);
  prepared.gather(std::span<Vec2>(p));
  EXPECT_DOUBLE_EQ(p[static_cast<std::size_t>(w.grid.node_index(5, 7))].x(), 0.7 * 2.0 / 1.9);
  EXPECT_DOUBLE_EQ(p[static_cast<std::size_t>(w.grid.node_index(5, 7))].y(), 1.0);
  EXPECT_EQ(p[static_cast<std::size_t>(w.grid.node_index(3, 7))], Vec2(0.0, 0.4));
  // An image that would keep less than half its mass is off: the node behind stays held.
  mass[static_cast<std::size_t>(w.grid.node_index(3, 7))] = 1.2;
  prepared.prepare(mass, nullptr);
  EXPECT_FALSE(prepared.active(static_cast<std::size_t>(image)));
}

// A held region two node columns thick inside the body (a rigid inclusion) has material on both
// sides: each column is a wall for its side, and neither is mirrored.
TEST(WallMirror, AHeldRegionTwoNodesThickIsAWallOnBothSides) {
  Walls w = walls(-1, -1);
  for (int j = 0; j < w.grid.n_nodes_y(); ++j) {
    for (const int i : {6, 7}) w.fixed[static_cast<std::size_t>(w.grid.node_index(i, j))] = kFixXY;
  }
  EXPECT_TRUE(WallMirror(w.grid, ShapeFunctionKind::kQuadraticBspline, w.fixed).empty());
}

TEST(WallMirror, LinearFunctionsAndUgimpInterpolateAndTakeNone) {
  const Walls w = walls(2, 2);
  EXPECT_TRUE(WallMirror(w.grid, ShapeFunctionKind::kLinear, w.fixed).empty());
  EXPECT_TRUE(WallMirror(w.grid, ShapeFunctionKind::kGimp, w.fixed).empty());
}

}  // namespace
}  // namespace pfm

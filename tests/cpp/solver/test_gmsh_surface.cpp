// The outline of a body given as a mesh (mpm/step/gmsh_surface.hpp).
#include <gtest/gtest.h>

#include "mpm/core/json_input.hpp"
#include "mpm/core/polygon.hpp"
#include "mpm/step/gmsh_surface.hpp"

namespace pfm {
namespace {

// n x n unit squares, counter-clockwise (as read_gmsh_surface returns them), the one at
// (hole, hole) left out when hole >= 0.
SurfaceMesh squares(int n, int hole) {
  SurfaceMesh mesh;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) mesh.node.emplace_back(i, j);
  const auto at = [n](int i, int j) { return i + j * (n + 1); };
  for (int j = 0; j < n; ++j) {
    for (int i = 0; i < n; ++i) {
      if (i == hole && j == hole) continue;
      mesh.element.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)});
    }
  }
  return mesh;
}

// The outline of a 3 x 3 block is its 12 boundary nodes, counter-clockwise, enclosing area 9;
// a block with a hole has two loops and is refused.
TEST(GmshSurface, OutlineIsOneCounterClockwiseLoopAndHolesAreRefused) {
  const std::vector<Vec2> outline = surface_outline(squares(3, -1), "test");
  EXPECT_EQ(outline.size(), 12u);
  EXPECT_DOUBLE_EQ(polygon_signed_area(outline), 9.0);
  EXPECT_THROW(surface_outline(squares(3, 1), "test"), InputError);
}

}  // namespace
}  // namespace pfm

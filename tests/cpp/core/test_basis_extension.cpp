// The ghost penalty's arrays (BasisExtension::light_arrays, mpm/core/basis_extension.hpp): which
// nodes they take and that their extrapolation reproduces the polynomials of the array's degree,
// so the penalty on a node's deviation from it vanishes on those fields.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "mpm/core/basis_extension.hpp"

namespace pfm {
namespace {

// A flat-topped body on a 12 x 12 grid: node rows 0..7 hold a full support's material, row 8 a
// `light` share, row 9 a share below the tie fraction, the rows above none.
std::vector<double> flat_top(const BasisExtension& extension, const Grid& grid, double light) {
  std::vector<double> mass(static_cast<std::size_t>(grid.n_nodes()), 0.0);
  for (int j = 0; j < grid.n_nodes_y(); ++j) {
    const double share = j <= 7 ? 1.0 : j == 8 ? light : j == 9 ? 0.02 : 0.0;
    for (int i = 0; i < grid.n_nodes_x(); ++i) {
      const int node = grid.node_index(i, j);
      mass[static_cast<std::size_t>(node)] = share * extension.support(node);
    }
  }
  return mass;
}

TEST(BasisExtension, LightArraysTakeTheNodesBetweenTheFractionsAndReproduceTheirDegree) {
  Grid grid;
  grid.cell_size = 0.5;
  grid.n_cells_x = 12;
  grid.n_cells_y = 12;
  const auto n = static_cast<std::size_t>(grid.n_nodes());
  const std::vector<unsigned> fixed(n, kFixNone);
  const std::vector<Vec2> still(n, Vec2::Zero());
  for (const auto kind : {ShapeFunctionKind::kGimp, ShapeFunctionKind::kQuadraticBspline,
                          ShapeFunctionKind::kCubicBspline}) {
    const int degree = shape_degree(kind);
    SCOPED_TRACE(degree);
    BasisExtension extension(grid, kind, 0.05);
    for (const double light : {0.07, 0.5}) {
      const std::vector<double> mass = flat_top(extension, grid, light);
      extension.classify(mass, 1.0, fixed, still, still);
      const NodeTies arrays = extension.light_arrays(mass, 1.0, 0.1, fixed, still, still);
      // Row 8 holds 7 % (between 5 % and 10 %): every node of it has an array; at 50 % none.
      ASSERT_EQ(arrays.size(), light < 0.1 ? static_cast<std::size_t>(grid.n_nodes_x()) : 0u);
      for (std::size_t k = 0; k < arrays.size(); ++k) {
        const int j = arrays.outer[k];
        EXPECT_EQ(j / grid.n_nodes_x(), 8);
        EXPECT_LT(extension.tie_of(j), 0);  // tied nodes (row 9) are not among them
        // Every monomial x^a y^b of the node indices, a, b <= degree, is reproduced at j.
        const double jx = j % grid.n_nodes_x(), jy = j / grid.n_nodes_x();
        for (int a = 0; a <= degree; ++a) {
          for (int b = 0; b <= degree; ++b) {
            double sum = 0.0;
            for (int t = arrays.start[k]; t < arrays.start[k + 1]; ++t) {
              const int i = arrays.inner[static_cast<std::size_t>(t)];
              const double ix = i % grid.n_nodes_x(), iy = i / grid.n_nodes_x();
              EXPECT_LE(iy, 7.0);  // the array holds full nodes only
              sum += arrays.weight[static_cast<std::size_t>(t)] * std::pow(ix - jx, a) *
                     std::pow(iy - jy, b);
            }
            EXPECT_NEAR(sum, a == 0 && b == 0 ? 1.0 : 0.0, 1e-9) << "x^" << a << " y^" << b;
          }
        }
      }
    }
  }
}

}  // namespace
}  // namespace pfm

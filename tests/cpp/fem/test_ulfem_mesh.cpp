// UL-FEM meshes: grid-aligned bodies give the MPM grid cells; the slope mesh conforms to the
// slope polygon; numbering and boundary loops follow their stated conventions.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <numbers>

#include "fem_reference/ulfem/quad_mesh.hpp"
#include "fem_reference/ulfem/ulfem_solver.hpp"
#include "mpm/core/materials.hpp"
#include "mpm/core/shape_functions.hpp"
#include "mpm/solver/mpm_solver.hpp"

namespace pfm::ulfem {
namespace {

double distance_to_segment(const Vec2& x, const Vec2& a, const Vec2& b) {
  const Vec2 d = b - a;
  const double t = std::clamp((x - a).dot(d) / d.squaredNorm(), 0.0, 1.0);
  return (x - (a + t * d)).norm();
}

double distance_to_polygon(const Vec2& x, const std::vector<Vec2>& polygon) {
  double best = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    best = std::min(best, distance_to_segment(x, polygon[i], polygon[(i + 1) % polygon.size()]));
  }
  return best;
}

double element_area(const QuadMesh& mesh, std::size_t e) {
  double area = 0.0;
  for (std::size_t a = 0; a < 4; ++a) {
    const Vec2& p = mesh.node_position[static_cast<std::size_t>(mesh.element_nodes[e][a])];
    const Vec2& q =
        mesh.node_position[static_cast<std::size_t>(mesh.element_nodes[e][(a + 1) % 4])];
    area += 0.5 * (p.x() * q.y() - q.x() * p.y());
  }
  return area;
}

// The bearing block (rectangle on grid nodes): elements = the 30 x 10 grid cells of the body,
// nodes = the grid nodes, counter-clockwise from the lower-left corner, numbered row by row.
TEST(UlFemMesh, GridAlignedBodyGivesTheGridCells) {
  const Case c = read_case("cases/thesis62_bearing_dynamic_zero_start.json");
  const QuadMesh mesh = mesh_case(c);
  EXPECT_EQ(mesh.generator, "grid");
  ASSERT_EQ(mesh.n_elements(), 300u);
  ASSERT_EQ(mesh.n_nodes(), 31u * 11u);
  const double h = c.grid.cell_size;
  for (std::size_t e = 0; e < mesh.n_elements(); ++e) {
    const int i = static_cast<int>(e % 30), j = static_cast<int>(e / 30);
    const Vec2 corners[4] = {c.grid.node_position(i, j), c.grid.node_position(i + 1, j),
                             c.grid.node_position(i + 1, j + 1), c.grid.node_position(i, j + 1)};
    for (std::size_t a = 0; a < 4; ++a) {
      EXPECT_EQ(mesh.node_position[static_cast<std::size_t>(mesh.element_nodes[e][a])], corners[a])
          << "element " << e << " node " << a;
    }
  }
  for (std::size_t n = 0; n < mesh.n_nodes(); ++n) {
    EXPECT_EQ(mesh.node_position[n],
              c.grid.node_position(static_cast<int>(n % 31), static_cast<int>(n / 31)));
  }
  (void)h;
}

// Test 4. The slope mesh (gmsh, transfinite slabs) conforms to the slope polygon: every boundary
// node lies on the polygon (1e-12 m), every polygon vertex is a node, the boundary loop is the
// polygon (same vertices in the same counter-clockwise order, same perimeter), the element
// areas sum to the polygon area, every element is a valid quad (det J > 0 at its Gauss points).
TEST(UlFemMesh, SlopeMeshConformsToThePolygon) {
  const Case c = read_case("cases/thesis55_slope_dynamic_zero_start.json");
  const QuadMesh mesh = mesh_case(c);
  EXPECT_EQ(mesh.generator, "gmsh-transfinite");
  const std::vector<Vec2>& polygon = c.bodies[0].polygon;
  const double h = c.grid.cell_size;

  const auto loops = boundary_loops(mesh, mesh.node_position);
  ASSERT_EQ(loops.size(), 1u);
  double worst_distance = 0.0, perimeter = 0.0, loop_area = 0.0;
  const auto& loop = loops[0];
  for (std::size_t k = 0; k < loop.size(); ++k) {
    const Vec2& x = mesh.node_position[static_cast<std::size_t>(loop[k])];
    const Vec2& y = mesh.node_position[static_cast<std::size_t>(loop[(k + 1) % loop.size()])];
    worst_distance = std::max(worst_distance, distance_to_polygon(x, polygon));
    perimeter += (y - x).norm();
    loop_area += 0.5 * (x.x() * y.y() - y.x() * x.y());
  }
  double polygon_perimeter = 0.0;
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    polygon_perimeter += (polygon[(i + 1) % polygon.size()] - polygon[i]).norm();
  }
  // The polygon vertices appear in the loop in the polygon's order (both start at (0, 0)).
  std::vector<Vec2> vertices_in_loop;
  for (int n : loop) {
    const Vec2& x = mesh.node_position[static_cast<std::size_t>(n)];
    for (const Vec2& v : polygon) {
      if (x == v) vertices_in_loop.push_back(x);
    }
  }
  EXPECT_EQ(vertices_in_loop, polygon);
  double total_area = 0.0, min_det_ratio = 1e300, max_edge = 0.0, min_edge = 1e300;
  for (std::size_t e = 0; e < mesh.n_elements(); ++e) {
    const double area = element_area(mesh, e);
    total_area += area;
    Eigen::Matrix<double, 4, 2> x;
    for (std::size_t a = 0; a < 4; ++a) {
      const Vec2& p = mesh.node_position[static_cast<std::size_t>(mesh.element_nodes[e][a])];
      x.row(static_cast<Eigen::Index>(a)) = p.transpose();
      const Vec2& q =
          mesh.node_position[static_cast<std::size_t>(mesh.element_nodes[e][(a + 1) % 4])];
      max_edge = std::max(max_edge, (q - p).norm());
      min_edge = std::min(min_edge, (q - p).norm());
    }
    for (const Vec2& g : q4_gauss_points_2x2()) {
      const double det = (x.transpose() * q4_natural_gradients(g.x(), g.y())).determinant();
      min_det_ratio = std::min(min_det_ratio, det / (0.25 * area));
    }
  }
  const double area = polygon_signed_area(polygon);
  std::printf(
      "[ulfem slope mesh] %zu elements, %zu nodes; boundary to polygon max %.2e m; "
      "area %.15g vs %.15g; perimeter %.15g vs %.15g; edges %.3f h .. %.3f h; "
      "min det J / (area / 4) = %.3f\n",
      mesh.n_elements(), mesh.n_nodes(), worst_distance, total_area, area, perimeter,
      polygon_perimeter, min_edge / h, max_edge / h, min_det_ratio);
  EXPECT_LE(worst_distance, 1e-12);
  EXPECT_NEAR(total_area, area, 1e-12 * area);
  EXPECT_NEAR(loop_area, area, 1e-12 * area);
  EXPECT_NEAR(perimeter, polygon_perimeter, 1e-12 * polygon_perimeter);
  EXPECT_GT(min_det_ratio, 0.3);
  EXPECT_LE(max_edge, 1.5 * h);
  EXPECT_GE(min_edge, 0.5 * h);
}

// Deterministic: two meshes of the same case are identical, node for node.
TEST(UlFemMesh, GmshMeshIsDeterministic) {
  const Case c = read_case("cases/thesis55_slope_dynamic_zero_start.json");
  const QuadMesh a = mesh_case(c), b = mesh_case(c);
  ASSERT_EQ(a.n_nodes(), b.n_nodes());
  EXPECT_EQ(a.node_position, b.node_position);
  EXPECT_EQ(a.element_nodes, b.element_nodes);
  // Nodes are numbered by (y, x) and every element starts at its lowest-then-leftmost node.
  for (std::size_t n = 1; n < a.n_nodes(); ++n) {
    const Vec2& p = a.node_position[n - 1];
    const Vec2& q = a.node_position[n];
    EXPECT_TRUE(p.y() < q.y() - 1e-9 || (std::abs(p.y() - q.y()) <= 1e-9 && p.x() < q.x())) << n;
  }
  for (std::size_t e = 0; e < a.n_elements(); ++e) EXPECT_GT(element_area(a, e), 0.0);
}

// A polygon that is not cut by every horizontal line in one interval (a U) falls back to
// gmsh's unstructured all-quad mesh, which still conforms and covers the area.
TEST(UlFemMesh, NonConvexPolygonFallsBackToUnstructuredQuads) {
  Case c = read_case("cases/thesis55_slope_dynamic_zero_start.json");
  c.bodies[0].polygon = {Vec2(0, 0),     Vec2(9, 0),     Vec2(9, 5.3),   Vec2(6.2, 5.3),
                         Vec2(6.2, 2.1), Vec2(2.9, 2.1), Vec2(2.9, 5.3), Vec2(0, 5.3)};
  const QuadMesh mesh = mesh_case(c);
  EXPECT_EQ(mesh.generator, "gmsh-unstructured");
  double total = 0.0;
  for (std::size_t e = 0; e < mesh.n_elements(); ++e) {
    EXPECT_GT(element_area(mesh, e), 0.0);
    total += element_area(mesh, e);
  }
  const double area = polygon_signed_area(c.bodies[0].polygon);
  std::printf("[ulfem U mesh] %zu elements, area %.15g vs %.15g\n", mesh.n_elements(), total, area);
  EXPECT_NEAR(total, area, 1e-12 * area);
  const auto loops = boundary_loops(mesh, mesh.node_position);
  ASSERT_EQ(loops.size(), 1u);
  for (int n : loops[0]) {
    EXPECT_LE(
        distance_to_polygon(mesh.node_position[static_cast<std::size_t>(n)], c.bodies[0].polygon),
        1e-12);
  }
}

}  // namespace
}  // namespace pfm::ulfem

namespace pfm::ulfem {
namespace {

// Patch test on the distorted slope mesh: a linear velocity field v = L x imposed on the nodes
// gives the same strain increment, hence the same stress, at every material point (the Q4
// isoparametric gradients reproduce linear fields exactly: sum_I x_I (x) grad N_I = I).
TEST(UlFemMesh, PatchTestOnTheDistortedSlopeMesh) {
  Case c = read_case("cases/thesis55_slope_dynamic_zero_start.json");
  c.materials[0].model = LinearElastic{elastic_parameters(c.materials[0].model)};
  UlFemSolver solver(c);
  Mat2 l;
  l << 1e-3, 4e-4, -2e-4, -5e-4;  // includes spin
  std::vector<Vec2> v(solver.mesh().n_nodes());
  for (std::size_t n = 0; n < v.size(); ++n) v[n] = l * solver.node_position()[n];
  solver.update_stress_from_node_velocity(v);
  const Strain de(l(0, 0) * solver.dt(), l(1, 1) * solver.dt(), (l(0, 1) + l(1, 0)) * solver.dt(),
                  0.0);
  const Stress expected = elastic_stress_increment(elastic_parameters(c.materials[0].model), de);
  double worst = 0.0;
  for (const Stress& s : solver.particles().stress) worst = std::max(worst, (s - expected).norm());
  std::printf("[ulfem patch test] max |stress - Hooke(L dt)| / |Hooke| = %.2e over %zu points\n",
              worst / expected.norm(), solver.particles().size());
  EXPECT_LE(worst, 1e-12 * expected.norm());
}
// (The load resultants on the slope's edges are tested in test_ulfem_loads.cpp.)

}  // namespace
}  // namespace pfm::ulfem

// Isoparametric 4-node quadrilateral meshes of the case bodies for the updated-Lagrangian FEM
// (method-map section 2: "an FEM extracted from MPM by removal of the Eulerian phase").
//
// Conventions (every mesh this file makes):
//  * element nodes counter-clockwise, the first node the one at natural (-1, -1), so the
//    element's edges traversed in node order have the material on their left;
//  * nodes numbered by (y, x) of their reference position (row by row, bottom to top), elements
//    by (y, x) of their centroid: the numbering depends only on the geometry (deterministic);
//  * element size = the case's grid cell size h.
//
// Two generators:
//  * grid-aligned bodies (every body polygon rectilinear with its vertices on grid nodes): the
//    elements are exactly the MPM grid cells inside the bodies (a cell belongs to the first body
//    holding its centre, as in fill_bodies), no gmsh involved;
//  * any other single body: gmsh (C++ API). A polygon that every horizontal line cuts in one
//    interval is split into horizontal slabs at its vertex heights; each slab is a trapezoid
//    (two horizontal sides, two sides on polygon edges) meshed as a transfinite (structured)
//    quad patch with round(height / h) rows; the columns follow the bottom of the lowest slab
//    (round(width / h)) and are carried up slab by slab, so the elements of a slab bounded by a
//    slanted face (the slope) are distorted to follow the face. Other polygons fall back to
//    gmsh's unstructured quads (Frontal-Delaunay, Blossom recombination, one all-quad
//    subdivision of a 2h mesh).
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "mpm/core/types.hpp"
#include "mpm/step/case.hpp"
#include "mpm/step/particles.hpp"

namespace pfm::ulfem {

struct QuadMesh {
  std::vector<Vec2> node_position;                ///< reference (initial) coordinates, m
  std::vector<std::array<int, 4>> element_nodes;  ///< counter-clockwise node indices
  std::vector<int> element_body;                  ///< index into Case::bodies
  std::string generator;  ///< "grid", "gmsh-transfinite", "gmsh-unstructured" or "gmsh-file"

  std::size_t n_nodes() const { return node_position.size(); }
  std::size_t n_elements() const { return element_nodes.size(); }
};

/// True when every body polygon has axis-parallel edges and its vertices on grid nodes.
bool bodies_are_grid_aligned(const Case& c);

/// The grid cells inside the (grid-aligned) bodies as elements. InputError if not grid-aligned.
QuadMesh grid_cell_mesh(const Case& c);

/// gmsh mesh of the case's single body (see the header comment). InputError for several bodies.
QuadMesh gmsh_body_mesh(const Case& c);

/// The quadrangles of the single body given as a gmsh mesh (bodies[0].mesh). InputError for
/// several bodies or a mesh with triangles.
QuadMesh file_body_mesh(const Case& c);

/// file_body_mesh for a body given as a mesh, else grid_cell_mesh when the bodies are
/// grid-aligned, gmsh_body_mesh otherwise.
QuadMesh mesh_case(const Case& c);

/// Boundary edges (edges of exactly one element), each oriented as in its element (material on
/// the left), as node index pairs, in element order.
std::vector<std::array<int, 2>> boundary_edges(const QuadMesh& mesh);

/// The closed boundary loops through the given node positions (one per boundary component):
/// counter-clockwise for outer loops (material on the left), no repeated closing point, each
/// loop starting at its lowest (then leftmost) node; loops ordered by that start point.
/// Returned as node indices.
std::vector<std::vector<int>> boundary_loops(const QuadMesh& mesh,
                                             const std::vector<Vec2>& positions);

/// Material point k of every element, at natural (-,-), (+,-), (-,+), (+,+) (the 2 x 2 Gauss
/// points row by row, as the MPM's fill_bodies places "gauss" points): the Q4 functions' values
/// and natural gradients there.
struct GaussSlot {
  Eigen::Vector4d value;
  Eigen::Matrix<double, 4, 2> natural_gradient;
};
const std::array<GaussSlot, 4>& gauss_slots();

/// Point k of element e (slot k of gauss_slots) with the nodes at `position`: sum_a N_a x_a.
Vec2 point_position(const QuadMesh& mesh, const std::vector<Vec2>& position, std::size_t e,
                    std::size_t k);

/// "element E (nodes a b c d) centred at (x, y)", for messages.
std::string describe_element(const QuadMesh& mesh, std::size_t e, const Vec2& centre);

/// Element e's node positions, one row per node in element order.
Eigen::Matrix<double, 4, 2> element_positions(const QuadMesh& mesh,
                                              const std::vector<Vec2>& position, std::size_t e);

/// The material points of the mesh with its nodes at `position`: point 4 e + k at slot k of
/// element e, volume det J (the Gauss weight is 1), mass density x volume (density = unit
/// weight / g, g = 9.81 m/s^2 when the case has no gravity), half lengths a quarter of the
/// element's box, the element's body and its material.
Particles material_points(const Case& c, const QuadMesh& mesh, const std::vector<Vec2>& position);

}  // namespace pfm::ulfem

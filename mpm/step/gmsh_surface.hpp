// gmsh files (a mesh, .msh, or a geometry, .geo, which gmsh meshes in 2D with the sizes it
// gives): bodies given as meshes (bodies[].mesh; their outline is the body polygon, so
// the MPM fills them as it fills a polygon), the UL-FEM's elements of such a body
// (fem_reference/ulfem/quad_mesh.hpp, mesh_case), and node sets given as physical groups of
// curves or points (node_sets[].mesh).
#pragma once

#include <array>
#include <string>
#include <vector>

#include "mpm/core/types.hpp"

namespace pfm {

/// A session of the gmsh library, which keeps one global model: initialised quietly (no
/// terminal output), finalised on every exit path. One at a time.
class GmshSession {
 public:
  GmshSession();
  ~GmshSession();
  GmshSession(const GmshSession&) = delete;
  GmshSession& operator=(const GmshSession&) = delete;
};

struct SurfaceMesh {
  std::vector<Vec2> node;                 ///< m (the file's z must be 0)
  std::vector<std::vector<int>> element;  ///< 3 or 4 node indices each, counter-clockwise
};

/// The linear 2D elements (3-node triangles, 4-node quadrangles) of the physical group named
/// `physical_group` (every 2D element when empty) of the gmsh file `path`, in the file's
/// order, each turned counter-clockwise; nodes numbered in order of first use. InputError,
/// prefixed with `where` (file and JSON path), when the file cannot be read, the group is
/// unknown, holds other element types (second order, say) or no 2D element, or a node lies off
/// the plane z = 0.
SurfaceMesh read_gmsh_surface(const std::string& path, const std::string& physical_group,
                              const std::string& where);

/// The mesh's outline as one counter-clockwise polygon: the element edges that belong to one
/// element only, chained (points on straight stretches kept). InputError (with `where`) when
/// they do not form one closed loop (a hole, or pieces apart).
std::vector<Vec2> surface_outline(const SurfaceMesh& mesh, const std::string& where);

/// The 2-node line elements of the physical group of curves named `physical_group` of the gmsh
/// file `path`, and its points (type 15 elements) as segments of zero length, m. InputError,
/// prefixed with `where`, when the file cannot be read, has no physical group of dimension 0
/// or 1 of that name, or the group holds other elements (second-order lines, say) or none.
std::vector<std::array<Vec2, 2>> read_gmsh_lines(const std::string& path,
                                                 const std::string& physical_group,
                                                 const std::string& where);

}  // namespace pfm

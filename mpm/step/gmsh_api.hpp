// The part of the gmsh API the project uses (gmsh_surface.cpp, the UL-FEM's quad_mesh.cpp),
// with the names and arguments of gmsh's C++ API (gmsh.h), resolved from the gmsh library
// (libgmsh) when it is first called. gmsh brings about a hundred shared libraries with it
// (OpenCASCADE, FLTK, X11, ...); linked into the program they cost every start of pfm-mpm
// about as long as a small run. Loaded on demand, only the cases that read or make a mesh pay
// for them. A call that gmsh reports as failed throws gmsh::CallError; the first call throws
// std::runtime_error when the library cannot be loaded (the message says which file and why).
#pragma once

#include <array>
#include <cstddef>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

namespace pfm::gmsh {

using vectorpair = std::vector<std::pair<int, int>>;  ///< (dimension, tag)

/// A call that gmsh reported as failed (a file it cannot read, a geometry it cannot mesh).
class CallError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// gmsh's global state, without reading configuration files.
void initialize();
void finalize();
void open(const std::string& file_name);

namespace option {
void setNumber(const std::string& name, double value);
}  // namespace option

namespace model {
void add(const std::string& name);
void getEntities(vectorpair& dim_tags, int dim);
void getPhysicalGroups(vectorpair& dim_tags, int dim);
void getPhysicalName(int dim, int tag, std::string& name);
void getEntitiesForPhysicalGroup(int dim, int tag, std::vector<int>& tags);

namespace mesh {
void generate(int dim);
/// The name of element type `element_type` ("Triangle 6", say).
std::string elementName(int element_type);
/// The coordinates (x, y, z) of node `node_tag`.
std::array<double, 3> getNode(std::size_t node_tag);
/// Every node of the model (the geometric points' too), without parametric coordinates:
/// tags, and x, y, z for each.
void getNodes(std::vector<std::size_t>& node_tags, std::vector<double>& coord);
/// The elements of entity (dim, tag) by type: element_tags[t] and node_tags[t] (the nodes of
/// each element in turn) for types[t].
void getElements(std::vector<int>& types, std::vector<std::vector<std::size_t>>& element_tags,
                 std::vector<std::vector<std::size_t>>& node_tags, int dim, int tag);
/// The elements of type `element_type` in every entity.
void getElementsByType(int element_type, std::vector<std::size_t>& element_tags,
                       std::vector<std::size_t>& node_tags);
}  // namespace mesh

namespace geo {
int addPoint(double x, double y, double z, double mesh_size = 0.0);
int addLine(int start_tag, int end_tag);
int addCurveLoop(const std::vector<int>& curve_tags);
int addPlaneSurface(const std::vector<int>& wire_tags);
void synchronize();

namespace mesh {
/// A transfinite curve of n_points nodes, evenly spaced.
void setTransfiniteCurve(int tag, int n_points);
void setTransfiniteSurface(int tag, const std::string& arrangement,
                           const std::vector<int>& corner_tags);
void setRecombine(int dim, int tag);
}  // namespace mesh
}  // namespace geo
}  // namespace model

}  // namespace pfm::gmsh

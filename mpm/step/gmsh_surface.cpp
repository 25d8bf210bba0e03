#include "mpm/step/gmsh_surface.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <utility>

#include "mpm/core/json_input.hpp"
#include "mpm/step/gmsh_api.hpp"

namespace pfm {

GmshSession::GmshSession() {
  gmsh::initialize();
  gmsh::option::setNumber("General.Terminal", 0);
}

GmshSession::~GmshSession() {
  gmsh::finalize();
}

namespace {

// gmsh element types: 2 = 3-node triangle, 3 = 4-node quadrangle, 1 = 2-node line, 15 = point.
constexpr int kTriangle = 2, kQuadrangle = 3, kLine = 1, kPoint = 15;

void open_file(const std::string& path, const std::string& where) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error))
    throw InputError(where + ": " + path + " is not a readable file");
  try {
    gmsh::open(path);
    // A geometry file (.geo) is meshed here, in 2D, with the sizes it gives.
    if (std::filesystem::path(path).extension() == ".geo") gmsh::model::mesh::generate(2);
  } catch (const gmsh::CallError&) {
    throw InputError(where + ": gmsh cannot read or mesh " + path);
  }
}

// The entities (dimension, tag) of the physical groups named `name` of the dimensions `dims`
// of the open model; InputError listing the groups there are when there is none.
gmsh::vectorpair group_entities(const std::string& name, std::initializer_list<int> dims,
                                const std::string& what, const std::string& path,
                                const std::string& where) {
  gmsh::vectorpair entities;
  std::string names;
  for (const int d : dims) {
    gmsh::vectorpair groups;
    gmsh::model::getPhysicalGroups(groups, d);
    for (const auto& [dim, tag] : groups) {
      std::string group;
      gmsh::model::getPhysicalName(dim, tag, group);
      names += (names.empty() ? "" : ", ") + ("\"" + group + "\"");
      if (group != name) continue;
      std::vector<int> tags;
      gmsh::model::getEntitiesForPhysicalGroup(dim, tag, tags);
      for (const int t : tags) entities.emplace_back(dim, t);
    }
  }
  if (entities.empty()) {
    throw InputError(where + ": " + path + " has no " + what + " physical group \"" + name +
                     "\" (it has " + (names.empty() ? std::string("none") : names) + ")");
  }
  return entities;
}

// The node `tag`'s position; InputError when it lies off the plane z = 0.
Vec2 node_position(std::size_t tag, const std::string& path, const std::string& where) {
  const std::array<double, 3> coord = gmsh::model::mesh::getNode(tag);
  if (coord[2] != 0.0) {
    throw InputError(where + ": " + path + ": node " + std::to_string(tag) +
                     " lies off the plane z = 0 (z = " + std::to_string(coord[2]) + ")");
  }
  return {coord[0], coord[1]};
}

}  // namespace

SurfaceMesh read_gmsh_surface(const std::string& path, const std::string& physical_group,
                              const std::string& where) {
  GmshSession session;
  open_file(path, where);
  gmsh::vectorpair entities;
  if (physical_group.empty()) {
    gmsh::model::getEntities(entities, 2);
  } else {
    entities = group_entities(physical_group, {2}, "2D", path, where);
  }
  SurfaceMesh mesh;
  std::map<std::size_t, int> index;  // gmsh node tag -> our node
  for (const auto& [dim, entity] : entities) {
    std::vector<int> types;
    std::vector<std::vector<std::size_t>> element_tags, node_tags;
    gmsh::model::mesh::getElements(types, element_tags, node_tags, dim, entity);
    for (std::size_t t = 0; t < types.size(); ++t) {
      if (types[t] != kTriangle && types[t] != kQuadrangle) {
        throw InputError(where + ": " + path + " holds " +
                         gmsh::model::mesh::elementName(types[t]) +
                         " elements; bodies take 3-node triangles and 4-node quadrangles");
      }
      const std::size_t corners = types[t] == kTriangle ? 3 : 4;
      for (std::size_t e = 0; e < element_tags[t].size(); ++e) {
        std::vector<int> element;
        for (std::size_t k = 0; k < corners; ++k) {
          const std::size_t tag = node_tags[t][corners * e + k];
          auto [it, added] = index.emplace(tag, static_cast<int>(mesh.node.size()));
          if (added) mesh.node.push_back(node_position(tag, path, where));
          element.push_back(it->second);
        }
        double area = 0.0;  // twice the signed area
        for (std::size_t k = 0; k < corners; ++k) {
          const Vec2& a = mesh.node[static_cast<std::size_t>(element[k])];
          const Vec2& b = mesh.node[static_cast<std::size_t>(element[(k + 1) % corners])];
          area += a.x() * b.y() - b.x() * a.y();
        }
        if (area < 0.0) std::reverse(element.begin() + 1, element.end());
        mesh.element.push_back(std::move(element));
      }
    }
  }
  if (mesh.element.empty()) {
    throw InputError(where + ": " + path + " has no triangle or quadrangle" +
                     (physical_group.empty() ? "" : " in \"" + physical_group + "\""));
  }
  return mesh;
}

std::vector<Vec2> surface_outline(const SurfaceMesh& mesh, const std::string& where) {
  // Directed edges of the counter-clockwise elements; an edge whose reverse is there too is
  // inside the mesh.
  std::map<std::pair<int, int>, int> count;
  for (const auto& element : mesh.element) {
    for (std::size_t k = 0; k < element.size(); ++k)
      ++count[{element[k], element[(k + 1) % element.size()]}];
  }
  std::map<int, int> next;  // boundary edge start -> end
  for (const auto& [edge, n] : count) {
    if (count.count({edge.second, edge.first}) != 0) continue;
    if (n != 1 || !next.emplace(edge.first, edge.second).second)
      throw InputError(where + ": the mesh's elements overlap or touch at a corner only");
  }
  if (next.empty()) throw InputError(where + ": the mesh has no boundary edge");
  std::vector<Vec2> outline;
  int node = next.begin()->first;
  do {
    outline.push_back(mesh.node[static_cast<std::size_t>(node)]);
    node = next.at(node);
  } while (node != next.begin()->first && outline.size() <= next.size());
  if (outline.size() != next.size()) {
    throw InputError(where + ": the mesh's outline is not one closed loop (" +
                     std::to_string(next.size()) + " boundary edges, " +
                     std::to_string(outline.size()) +
                     " in the first loop): a body is one piece without holes");
  }
  return outline;
}

std::vector<std::array<Vec2, 2>> read_gmsh_lines(const std::string& path,
                                                 const std::string& physical_group,
                                                 const std::string& where) {
  GmshSession session;
  open_file(path, where);
  std::vector<std::array<Vec2, 2>> segments;
  for (const auto& [dim, entity] :
       group_entities(physical_group, {1, 0}, "curve or point", path, where)) {
    std::vector<int> types;
    std::vector<std::vector<std::size_t>> element_tags, node_tags;
    gmsh::model::mesh::getElements(types, element_tags, node_tags, dim, entity);
    for (std::size_t t = 0; t < types.size(); ++t) {
      if (types[t] != kLine && types[t] != kPoint) {
        throw InputError(where + ": " + path + " holds " +
                         gmsh::model::mesh::elementName(types[t]) +
                         " elements; node sets take 2-node lines and points");
      }
      const std::size_t corners = types[t] == kLine ? 2 : 1;
      for (std::size_t e = 0; e < element_tags[t].size(); ++e) {
        const Vec2 a = node_position(node_tags[t][corners * e], path, where);
        segments.push_back(
            {a, node_position(node_tags[t][corners * e + corners - 1], path, where)});
      }
    }
  }
  if (segments.empty()) {
    throw InputError(where + ": " + path + " has no line or point in \"" + physical_group + "\"");
  }
  return segments;
}

}  // namespace pfm

#include "mpm/solver/gmsh_surface.hpp"

#include <gmsh.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <utility>

#include "mpm/core/json_input.hpp"

namespace pfm {

GmshSession::GmshSession() {
  gmsh::initialize(0, nullptr, false);
  gmsh::option::setNumber("General.Terminal", 0);
}

GmshSession::~GmshSession() {
  gmsh::finalize();
}

namespace {

// gmsh element types: 2 = 3-node triangle, 3 = 4-node quadrangle.
constexpr int kTriangle = 2, kQuadrangle = 3;

}  // namespace

SurfaceMesh read_gmsh_surface(const std::string& path, const std::string& physical_group,
                              const std::string& where) {
  std::error_code error;
  if (!std::filesystem::is_regular_file(path, error))
    throw InputError(where + ": " + path + " is not a readable file");
  GmshSession session;
  try {
    gmsh::open(path);
  } catch (...) {  // gmsh reports its errors as exceptions of its own types
    throw InputError(where + ": gmsh cannot read " + path);
  }
  std::vector<int> entities;
  if (physical_group.empty()) {
    gmsh::vectorpair all;
    gmsh::model::getEntities(all, 2);
    for (const auto& [dim, tag] : all) entities.push_back(tag);
  } else {
    gmsh::vectorpair groups;
    gmsh::model::getPhysicalGroups(groups, 2);
    std::string names;
    bool found = false;
    for (const auto& [dim, tag] : groups) {
      std::string name;
      gmsh::model::getPhysicalName(dim, tag, name);
      names += (names.empty() ? "" : ", ") + ("\"" + name + "\"");
      if (name != physical_group) continue;
      found = true;
      std::vector<int> tags;
      gmsh::model::getEntitiesForPhysicalGroup(dim, tag, tags);
      entities.insert(entities.end(), tags.begin(), tags.end());
    }
    if (!found) {
      throw InputError(where + ": " + path + " has no 2D physical group \"" + physical_group +
                       "\" (it has " + (names.empty() ? std::string("none") : names) + ")");
    }
  }
  SurfaceMesh mesh;
  std::map<std::size_t, int> index;  // gmsh node tag -> our node
  for (const int entity : entities) {
    std::vector<int> types;
    std::vector<std::vector<std::size_t>> element_tags, node_tags;
    gmsh::model::mesh::getElements(types, element_tags, node_tags, 2, entity);
    for (std::size_t t = 0; t < types.size(); ++t) {
      if (types[t] != kTriangle && types[t] != kQuadrangle) {
        std::string name;
        int dim = 0, order = 0, n_nodes = 0, n_primary = 0;
        std::vector<double> local;
        gmsh::model::mesh::getElementProperties(types[t], name, dim, order, n_nodes, local,
                                                n_primary);
        throw InputError(where + ": " + path + " holds " + name +
                         " elements; bodies take 3-node triangles and 4-node quadrangles");
      }
      const std::size_t corners = types[t] == kTriangle ? 3 : 4;
      for (std::size_t e = 0; e < element_tags[t].size(); ++e) {
        std::vector<int> element;
        for (std::size_t k = 0; k < corners; ++k) {
          const std::size_t tag = node_tags[t][corners * e + k];
          auto [it, added] = index.emplace(tag, static_cast<int>(mesh.node.size()));
          if (added) {
            std::vector<double> coord, parametric;
            gmsh::model::mesh::getNode(tag, coord, parametric);
            if (coord[2] != 0.0) {
              throw InputError(where + ": " + path + ": node " + std::to_string(tag) +
                               " lies off the plane z = 0 (z = " + std::to_string(coord[2]) + ")");
            }
            mesh.node.emplace_back(coord[0], coord[1]);
          }
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

}  // namespace pfm

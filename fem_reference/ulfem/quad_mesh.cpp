#include "fem_reference/ulfem/quad_mesh.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <optional>
#include <sstream>
#include <stdexcept>

#include "mpm/core/json_input.hpp"
#include "mpm/core/shape_functions.hpp"
#include "mpm/step/body_fill.hpp"
#include "mpm/step/gmsh_api.hpp"
#include "mpm/step/gmsh_surface.hpp"

namespace pfm::ulfem {

namespace {

// Sort nodes by (y, x) and elements by centroid (y, x), on keys rounded to 1e-9 h so that
// numerically equal rows sort together; rotate each element so that its first node is the one
// at natural (-1, -1) (kept as given: generators produce that order already).
void renumber(QuadMesh& mesh, double h) {
  const double unit = 1e-9 * h;
  auto key = [unit](const Vec2& x) {
    return std::pair<long long, long long>(std::llround(x.y() / unit), std::llround(x.x() / unit));
  };
  std::vector<int> order(mesh.n_nodes());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
    return key(mesh.node_position[static_cast<std::size_t>(a)]) <
           key(mesh.node_position[static_cast<std::size_t>(b)]);
  });
  std::vector<int> new_index(mesh.n_nodes());
  std::vector<Vec2> positions(mesh.n_nodes());
  for (std::size_t k = 0; k < order.size(); ++k) {
    new_index[static_cast<std::size_t>(order[k])] = static_cast<int>(k);
    positions[k] = mesh.node_position[static_cast<std::size_t>(order[k])];
  }
  mesh.node_position = std::move(positions);
  for (auto& element : mesh.element_nodes) {
    for (int& n : element) n = new_index[static_cast<std::size_t>(n)];
  }
  std::vector<int> element_order(mesh.n_elements());
  std::iota(element_order.begin(), element_order.end(), 0);
  auto centroid = [&](int e) {
    Vec2 c = Vec2::Zero();
    for (int n : mesh.element_nodes[static_cast<std::size_t>(e)]) {
      c += 0.25 * mesh.node_position[static_cast<std::size_t>(n)];
    }
    return c;
  };
  std::stable_sort(element_order.begin(), element_order.end(),
                   [&](int a, int b) { return key(centroid(a)) < key(centroid(b)); });
  std::vector<std::array<int, 4>> elements(mesh.n_elements());
  std::vector<int> bodies(mesh.n_elements());
  for (std::size_t k = 0; k < element_order.size(); ++k) {
    elements[k] = mesh.element_nodes[static_cast<std::size_t>(element_order[k])];
    bodies[k] = mesh.element_body[static_cast<std::size_t>(element_order[k])];
  }
  mesh.element_nodes = std::move(elements);
  mesh.element_body = std::move(bodies);
}

// Make every element counter-clockwise and start it at its lowest-then-leftmost node (for a
// grid cell: the lower-left corner, natural (-1, -1)).
void orient_elements(QuadMesh& mesh) {
  for (auto& element : mesh.element_nodes) {
    const Vec2& a = mesh.node_position[static_cast<std::size_t>(element[0])];
    const Vec2& b = mesh.node_position[static_cast<std::size_t>(element[1])];
    const Vec2& c = mesh.node_position[static_cast<std::size_t>(element[2])];
    const Vec2& d = mesh.node_position[static_cast<std::size_t>(element[3])];
    const double twice_area = (c - a).x() * (d - b).y() - (c - a).y() * (d - b).x();
    if (twice_area < 0.0) std::swap(element[1], element[3]);
    int first = 0;
    for (int k = 1; k < 4; ++k) {
      const Vec2& x =
          mesh.node_position[static_cast<std::size_t>(element[static_cast<std::size_t>(k)])];
      const Vec2& best =
          mesh.node_position[static_cast<std::size_t>(element[static_cast<std::size_t>(first)])];
      if (x.y() < best.y() || (x.y() == best.y() && x.x() < best.x())) first = k;
    }
    std::rotate(element.begin(), element.begin() + first, element.end());
  }
}

// The mesh gmsh holds now, as a QuadMesh (quads only; InputError if other elements remain).
QuadMesh read_gmsh_quads(const std::string& file) {
  std::vector<std::size_t> tags;
  std::vector<double> coords;
  gmsh::model::mesh::getNodes(tags, coords);
  std::map<std::size_t, int> index;
  QuadMesh mesh;
  for (std::size_t k = 0; k < tags.size(); ++k) {
    index[tags[k]] = static_cast<int>(k);
    mesh.node_position.emplace_back(coords[3 * k], coords[3 * k + 1]);
  }
  std::vector<std::size_t> element_tags, node_tags;
  gmsh::model::mesh::getElementsByType(2, element_tags, node_tags);
  if (!element_tags.empty()) {
    throw InputError(file + ": /bodies/0/polygon: gmsh left " +
                     std::to_string(element_tags.size()) +
                     " triangles in the quadrilateral mesh of this polygon");
  }
  gmsh::model::mesh::getElementsByType(3, element_tags, node_tags);
  // Nodes of the geometric points and curves that no quad uses are dropped below.
  std::vector<int> used(mesh.n_nodes(), -1);
  QuadMesh compact;
  for (std::size_t e = 0; e < element_tags.size(); ++e) {
    std::array<int, 4> element{};
    for (int k = 0; k < 4; ++k) {
      const int n = index.at(node_tags[4 * e + static_cast<std::size_t>(k)]);
      if (used[static_cast<std::size_t>(n)] < 0) {
        used[static_cast<std::size_t>(n)] = static_cast<int>(compact.node_position.size());
        compact.node_position.push_back(mesh.node_position[static_cast<std::size_t>(n)]);
      }
      element[static_cast<std::size_t>(k)] = used[static_cast<std::size_t>(n)];
    }
    compact.element_nodes.push_back(element);
    compact.element_body.push_back(0);
  }
  return compact;
}

// A trapezoid of the slab decomposition: horizontal bottom and top, sides on polygon edges.
struct Slab {
  double y0 = 0, y1 = 0;
  double bottom_left = 0, bottom_right = 0, top_left = 0, top_right = 0;  // x at y0 and y1
  int rows = 1;
};

// x of the polygon edge (a, b) at height y, exact at the end points.
double edge_x_at(const Vec2& a, const Vec2& b, double y) {
  if (y == a.y()) return a.x();
  if (y == b.y()) return b.x();
  return a.x() + (y - a.y()) * (b.x() - a.x()) / (b.y() - a.y());
}

// Slab decomposition of a polygon every horizontal line cuts in one interval; nullopt if the
// polygon is not of that kind or a slab degenerates to a triangle.
std::optional<std::vector<Slab>> slab_decomposition(const std::vector<Vec2>& polygon, double h) {
  std::vector<double> levels;
  for (const Vec2& v : polygon) levels.push_back(v.y());
  std::sort(levels.begin(), levels.end());
  levels.erase(std::unique(levels.begin(), levels.end()), levels.end());
  std::vector<Slab> slabs;
  const std::size_t n = polygon.size();
  for (std::size_t k = 0; k + 1 < levels.size(); ++k) {
    Slab slab;
    slab.y0 = levels[k];
    slab.y1 = levels[k + 1];
    const double mid = 0.5 * (slab.y0 + slab.y1);
    std::vector<std::pair<double, std::size_t>> crossings;
    for (std::size_t i = 0; i < n; ++i) {
      const Vec2& a = polygon[i];
      const Vec2& b = polygon[(i + 1) % n];
      if ((a.y() > mid) != (b.y() > mid)) crossings.emplace_back(edge_x_at(a, b, mid), i);
    }
    if (crossings.size() != 2) return std::nullopt;
    std::sort(crossings.begin(), crossings.end());
    const Vec2& la = polygon[crossings[0].second];
    const Vec2& lb = polygon[(crossings[0].second + 1) % n];
    const Vec2& ra = polygon[crossings[1].second];
    const Vec2& rb = polygon[(crossings[1].second + 1) % n];
    slab.bottom_left = edge_x_at(la, lb, slab.y0);
    slab.top_left = edge_x_at(la, lb, slab.y1);
    slab.bottom_right = edge_x_at(ra, rb, slab.y0);
    slab.top_right = edge_x_at(ra, rb, slab.y1);
    const double tol = 1e-9 * h;
    if (slab.bottom_right - slab.bottom_left <= tol || slab.top_right - slab.top_left <= tol) {
      return std::nullopt;  // a triangle: not a transfinite quad patch
    }
    slab.rows = std::max(1, static_cast<int>(std::lround((slab.y1 - slab.y0) / h)));
    slabs.push_back(slab);
  }
  if (slabs.empty()) return std::nullopt;
  return slabs;
}

// Distribute `total` elements over segments in proportion to their lengths (largest
// remainder), at least one each. False if total < number of segments.
bool distribute(int total, const std::vector<double>& lengths, std::vector<int>& counts) {
  const int n = static_cast<int>(lengths.size());
  if (total < n) return false;
  const double sum = std::accumulate(lengths.begin(), lengths.end(), 0.0);
  counts.assign(lengths.size(), 1);
  const int spare = total - n;
  std::vector<double> share(lengths.size());
  int given = 0;
  for (std::size_t k = 0; k < lengths.size(); ++k) {
    share[k] = spare * lengths[k] / sum;
    const int whole = static_cast<int>(std::floor(share[k]));
    counts[k] += whole;
    given += whole;
    share[k] -= whole;
  }
  std::vector<std::size_t> order(lengths.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return share[a] > share[b]; });
  for (int k = 0; k < spare - given; ++k) ++counts[order[static_cast<std::size_t>(k)]];
  return true;
}

// Structured gmsh mesh from the slab decomposition. False (nothing meshed) if the element
// counts cannot be matched.
bool mesh_slabs(const std::vector<Slab>& slabs, double h) {
  // Break points per level (level k is y of slab k's bottom; level K the last top).
  const std::size_t n_levels = slabs.size() + 1;
  std::vector<std::vector<double>> breaks(n_levels);
  const double tol = 1e-9 * h;
  auto add_break = [&](std::size_t level, double x) {
    for (double b : breaks[level]) {
      if (std::abs(b - x) <= tol) return;
    }
    breaks[level].push_back(x);
  };
  for (std::size_t k = 0; k < slabs.size(); ++k) {
    add_break(k, slabs[k].bottom_left);
    add_break(k, slabs[k].bottom_right);
    add_break(k + 1, slabs[k].top_left);
    add_break(k + 1, slabs[k].top_right);
  }
  for (auto& b : breaks) std::sort(b.begin(), b.end());
  auto level_y = [&](std::size_t level) {
    return level < slabs.size() ? slabs[level].y0 : slabs.back().y1;
  };
  // Segment s of level k spans breaks[k][s] .. breaks[k][s + 1]; counts[k][s] = 0 until set.
  std::vector<std::vector<int>> counts(n_levels);
  for (std::size_t k = 0; k < n_levels; ++k) counts[k].assign(breaks[k].size() - 1, 0);
  auto segments_in = [&](std::size_t level, double x0, double x1) {
    std::vector<std::size_t> list;
    for (std::size_t s = 0; s + 1 < breaks[level].size(); ++s) {
      if (breaks[level][s] >= x0 - tol && breaks[level][s + 1] <= x1 + tol) list.push_back(s);
    }
    return list;
  };
  for (std::size_t k = 0; k < slabs.size(); ++k) {
    const Slab& slab = slabs[k];
    int bottom_total = 0;
    for (std::size_t s : segments_in(k, slab.bottom_left, slab.bottom_right)) {
      int& c = counts[k][s];
      if (c == 0) {
        c = std::max(1, static_cast<int>(std::lround((breaks[k][s + 1] - breaks[k][s]) / h)));
      }
      bottom_total += c;
    }
    const auto top = segments_in(k + 1, slab.top_left, slab.top_right);
    std::vector<double> lengths;
    for (std::size_t s : top) lengths.push_back(breaks[k + 1][s + 1] - breaks[k + 1][s]);
    std::vector<int> top_counts;
    if (!distribute(bottom_total, lengths, top_counts)) return false;
    for (std::size_t i = 0; i < top.size(); ++i) counts[k + 1][top[i]] = top_counts[i];
  }

  namespace geo = gmsh::model::geo;
  std::vector<std::vector<int>> point(n_levels), segment(n_levels);
  for (std::size_t k = 0; k < n_levels; ++k) {
    for (double x : breaks[k]) point[k].push_back(geo::addPoint(x, level_y(k), 0.0));
    for (std::size_t s = 0; s + 1 < breaks[k].size(); ++s) {
      const int line = geo::addLine(point[k][s], point[k][s + 1]);
      geo::mesh::setTransfiniteCurve(line, counts[k][s] + 1);
      segment[k].push_back(line);
    }
  }
  auto point_at = [&](std::size_t level, double x) {
    for (std::size_t s = 0; s < breaks[level].size(); ++s) {
      if (std::abs(breaks[level][s] - x) <= tol)
        return std::pair<int, std::size_t>(point[level][s], s);
    }
    throw std::logic_error("slab corner not among the break points");
  };
  for (std::size_t k = 0; k < slabs.size(); ++k) {
    const Slab& slab = slabs[k];
    const auto [bl, bl_index] = point_at(k, slab.bottom_left);
    const auto [br, br_index] = point_at(k, slab.bottom_right);
    const auto [tl, tl_index] = point_at(k + 1, slab.top_left);
    const auto [tr, tr_index] = point_at(k + 1, slab.top_right);
    const int left = geo::addLine(bl, tl);
    const int right = geo::addLine(br, tr);
    geo::mesh::setTransfiniteCurve(left, slab.rows + 1);
    geo::mesh::setTransfiniteCurve(right, slab.rows + 1);
    std::vector<int> loop;
    for (std::size_t s = bl_index; s < br_index; ++s) loop.push_back(segment[k][s]);
    loop.push_back(right);
    for (std::size_t s = tr_index; s > tl_index; --s) loop.push_back(-segment[k + 1][s - 1]);
    loop.push_back(-left);
    const int surface = geo::addPlaneSurface({geo::addCurveLoop(loop)});
    geo::mesh::setTransfiniteSurface(surface, "Left", {bl, br, tr, tl});
    geo::mesh::setRecombine(2, surface);
  }
  geo::synchronize();
  return true;
}

}  // namespace

bool bodies_are_grid_aligned(const Case& c) {
  const Grid& grid = c.grid;
  const double tol = 1e-9 * grid.cell_size;
  for (const BodySpec& body : c.bodies) {
    const std::size_t n = body.polygon.size();
    for (std::size_t i = 0; i < n; ++i) {
      const Vec2& a = body.polygon[i];
      const Vec2& b = body.polygon[(i + 1) % n];
      if (a.x() != b.x() && a.y() != b.y()) return false;
      const Vec2 cell = (a - grid.origin) / grid.cell_size;
      if (std::abs(cell.x() - std::round(cell.x())) * grid.cell_size > tol ||
          std::abs(cell.y() - std::round(cell.y())) * grid.cell_size > tol) {
        return false;
      }
    }
  }
  return true;
}

QuadMesh grid_cell_mesh(const Case& c) {
  if (!bodies_are_grid_aligned(c)) {
    throw InputError(c.file + ": /bodies: grid_cell_mesh needs rectilinear bodies on grid nodes");
  }
  const Grid& grid = c.grid;
  QuadMesh mesh;
  mesh.generator = "grid";
  std::vector<int> node_of(static_cast<std::size_t>(grid.n_nodes()), -1);
  // Cells row by row, nodes numbered on first use row by row: the (y, x) order of renumber().
  std::vector<std::pair<int, int>> cells;
  std::vector<int> cell_body;
  for (int j = 0; j < grid.n_cells_y; ++j) {
    for (int i = 0; i < grid.n_cells_x; ++i) {
      const Vec2 centre = grid.node_position(i, j) + Vec2(0.5, 0.5) * grid.cell_size;
      for (std::size_t b = 0; b < c.bodies.size(); ++b) {
        if (point_in_polygon(c.bodies[b].polygon, centre)) {
          cells.emplace_back(i, j);
          cell_body.push_back(static_cast<int>(b));
          node_of[static_cast<std::size_t>(grid.node_index(i, j))] = 0;
          node_of[static_cast<std::size_t>(grid.node_index(i + 1, j))] = 0;
          node_of[static_cast<std::size_t>(grid.node_index(i + 1, j + 1))] = 0;
          node_of[static_cast<std::size_t>(grid.node_index(i, j + 1))] = 0;
          break;
        }
      }
    }
  }
  for (int j = 0; j < grid.n_nodes_y(); ++j) {
    for (int i = 0; i < grid.n_nodes_x(); ++i) {
      int& slot = node_of[static_cast<std::size_t>(grid.node_index(i, j))];
      if (slot < 0) continue;
      slot = static_cast<int>(mesh.node_position.size());
      mesh.node_position.push_back(grid.node_position(i, j));
    }
  }
  for (std::size_t k = 0; k < cells.size(); ++k) {
    const auto [i, j] = cells[k];
    auto at = [&](int ii, int jj) {
      return node_of[static_cast<std::size_t>(grid.node_index(ii, jj))];
    };
    mesh.element_nodes.push_back({at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1)});
    mesh.element_body.push_back(cell_body[k]);
  }
  if (mesh.element_nodes.empty())
    throw InputError(c.file + ": /bodies: no grid cell inside a body");
  return mesh;
}

QuadMesh gmsh_body_mesh(const Case& c) {
  if (c.bodies.size() != 1) {
    throw InputError(c.file + ": /bodies: the UL-FEM meshes several bodies only when all are " +
                     "rectilinear on grid nodes (one conforming mesh); got " +
                     std::to_string(c.bodies.size()) + " bodies, not all grid-aligned");
  }
  const std::vector<Vec2>& polygon = c.bodies.front().polygon;
  const double h = c.grid.cell_size;
  QuadMesh mesh;
  {
    GmshSession session;
    gmsh::model::add("ulfem");
    bool structured = false;
    if (const auto slabs = slab_decomposition(polygon, h)) structured = mesh_slabs(*slabs, h);
    if (!structured) {
      namespace geo = gmsh::model::geo;
      std::vector<int> points, lines;
      for (const Vec2& v : polygon) points.push_back(geo::addPoint(v.x(), v.y(), 0.0, 2.0 * h));
      for (std::size_t i = 0; i < points.size(); ++i) {
        lines.push_back(geo::addLine(points[i], points[(i + 1) % points.size()]));
      }
      const int surface = geo::addPlaneSurface({geo::addCurveLoop(lines)});
      geo::mesh::setRecombine(2, surface);
      geo::synchronize();
      gmsh::option::setNumber("Mesh.Algorithm", 6);               // Frontal-Delaunay
      gmsh::option::setNumber("Mesh.RecombinationAlgorithm", 1);  // Blossom
      gmsh::option::setNumber("Mesh.SubdivisionAlgorithm", 1);    // all quadrangles
    }
    try {
      gmsh::model::mesh::generate(2);
    } catch (const gmsh::CallError&) {
      throw InputError(c.file + ": /bodies/0/polygon: gmsh could not mesh this polygon");
    }
    mesh = read_gmsh_quads(c.file);
    mesh.generator = structured ? "gmsh-transfinite" : "gmsh-unstructured";
  }
  // Snap nodes that gmsh placed within round-off of a polygon vertex onto it.
  for (Vec2& x : mesh.node_position) {
    for (const Vec2& v : polygon) {
      if ((x - v).norm() <= 1e-12 * h) x = v;
    }
  }
  if (mesh.element_nodes.empty()) throw InputError(c.file + ": /bodies/0/polygon: empty mesh");
  return mesh;
}

QuadMesh file_body_mesh(const Case& c) {
  const std::string where = c.file + ": /bodies/0/mesh";
  if (c.bodies.size() != 1) {
    throw InputError(where + ": the UL-FEM takes a body given as a mesh when it is the only " +
                     "body (got " + std::to_string(c.bodies.size()) + ")");
  }
  const BodySpec& body = c.bodies.front();
  const SurfaceMesh surface = read_gmsh_surface(body.mesh_file, body.physical_group, where);
  QuadMesh mesh;
  mesh.generator = "gmsh-file";
  mesh.node_position = surface.node;
  for (const auto& element : surface.element) {
    if (element.size() != 4) {
      throw InputError(where + ": " + body.mesh_file + " holds triangles; the UL-FEM takes " +
                       "4-node quadrangles (recombine the mesh: gmsh Mesh.RecombineAll = 1)");
    }
    mesh.element_nodes.push_back({element[0], element[1], element[2], element[3]});
    mesh.element_body.push_back(0);
  }
  return mesh;
}

QuadMesh mesh_case(const Case& c) {
  for (std::size_t b = 0; b < c.bodies.size(); ++b) {
    if (c.bodies[b].from_file()) {
      throw InputError(c.file + ": /bodies/" + std::to_string(b) +
                       "/particles: the UL-FEM meshes rectangle and polygon bodies, not points");
    }
  }
  QuadMesh mesh;
  if (c.bodies.front().mesh_file.empty()) {
    mesh = bodies_are_grid_aligned(c) ? grid_cell_mesh(c) : gmsh_body_mesh(c);
  } else {
    mesh = file_body_mesh(c);
  }
  orient_elements(mesh);
  renumber(mesh, c.grid.cell_size);
  return mesh;
}

std::vector<std::array<int, 2>> boundary_edges(const QuadMesh& mesh) {
  std::map<std::pair<int, int>, int> uses;
  for (const auto& element : mesh.element_nodes) {
    for (int k = 0; k < 4; ++k) {
      const int a = element[static_cast<std::size_t>(k)];
      const int b = element[static_cast<std::size_t>((k + 1) % 4)];
      ++uses[{std::min(a, b), std::max(a, b)}];
    }
  }
  std::vector<std::array<int, 2>> edges;
  for (const auto& element : mesh.element_nodes) {
    for (int k = 0; k < 4; ++k) {
      const int a = element[static_cast<std::size_t>(k)];
      const int b = element[static_cast<std::size_t>((k + 1) % 4)];
      if (uses[{std::min(a, b), std::max(a, b)}] == 1) edges.push_back({a, b});
    }
  }
  return edges;
}

std::vector<std::vector<int>> boundary_loops(const QuadMesh& mesh,
                                             const std::vector<Vec2>& positions) {
  const auto edges = boundary_edges(mesh);
  // Each boundary node of a manifold mesh has one outgoing boundary edge; where a node has
  // several (two bodies touching at a corner) the first is taken.
  std::map<int, std::vector<int>> next;
  for (const auto& e : edges) next[e[0]].push_back(e[1]);
  std::map<std::pair<int, int>, bool> used;
  std::vector<std::vector<int>> loops;
  auto lower = [&](int a, int b) {
    const Vec2& x = positions[static_cast<std::size_t>(a)];
    const Vec2& y = positions[static_cast<std::size_t>(b)];
    return x.y() < y.y() || (x.y() == y.y() && x.x() < y.x());
  };
  for (const auto& e : edges) {
    if (used[{e[0], e[1]}]) continue;
    std::vector<int> loop;
    int current = e[0];
    while (true) {
      int to = -1;
      for (int candidate : next[current]) {
        if (!used[{current, candidate}]) {
          to = candidate;
          break;
        }
      }
      if (to < 0) break;
      used[{current, to}] = true;
      loop.push_back(current);
      current = to;
    }
    const auto start = std::min_element(loop.begin(), loop.end(), lower);
    std::rotate(loop.begin(), start, loop.end());
    loops.push_back(std::move(loop));
  }
  std::stable_sort(loops.begin(), loops.end(),
                   [&](const auto& a, const auto& b) { return lower(a.front(), b.front()); });
  return loops;
}

const std::array<GaussSlot, 4>& gauss_slots() {
  static const std::array<GaussSlot, 4> slots = [] {
    // q4_gauss_points_2x2 lists the points counter-clockwise: slots 2 and 3 swap.
    const std::array<Vec2, 4> ccw = q4_gauss_points_2x2();
    const std::array<Vec2, 4> natural = {ccw[0], ccw[1], ccw[3], ccw[2]};
    std::array<GaussSlot, 4> out;
    for (std::size_t k = 0; k < 4; ++k) {
      out[k].value = q4_values(natural[k].x(), natural[k].y());
      out[k].natural_gradient = q4_natural_gradients(natural[k].x(), natural[k].y());
    }
    return out;
  }();
  return slots;
}

Vec2 point_position(const QuadMesh& mesh, const std::vector<Vec2>& position, std::size_t e,
                    std::size_t k) {
  const Eigen::Vector4d& value = gauss_slots()[k].value;
  Vec2 x = Vec2::Zero();
  for (std::size_t a = 0; a < 4; ++a) {
    x += value[static_cast<Eigen::Index>(a)] *
         position[static_cast<std::size_t>(mesh.element_nodes[e][a])];
  }
  return x;
}

std::string describe_element(const QuadMesh& mesh, std::size_t e, const Vec2& centre) {
  std::ostringstream s;
  s << "element " << e << " (nodes";
  for (const int n : mesh.element_nodes[e]) s << ' ' << n;
  s << ") centred at (" << centre.x() << ", " << centre.y() << ")";
  return s.str();
}

Eigen::Matrix<double, 4, 2> element_positions(const QuadMesh& mesh,
                                              const std::vector<Vec2>& position, std::size_t e) {
  Eigen::Matrix<double, 4, 2> x;
  for (std::size_t a = 0; a < 4; ++a) {
    x.row(static_cast<Eigen::Index>(a)) =
        position[static_cast<std::size_t>(mesh.element_nodes[e][a])].transpose();
  }
  return x;
}

Particles material_points(const Case& c, const QuadMesh& mesh, const std::vector<Vec2>& position) {
  const double g = c.gravity.g > 0.0 ? c.gravity.g : 9.81;
  const std::array<GaussSlot, 4>& slots = gauss_slots();
  Particles points;
  points.reserve(4 * mesh.n_elements());
  for (std::size_t e = 0; e < mesh.n_elements(); ++e) {
    const int body = mesh.element_body[e];
    const int material = c.bodies[static_cast<std::size_t>(body)].material;
    const double density = c.materials[static_cast<std::size_t>(material)].unit_weight / g;
    const Eigen::Matrix<double, 4, 2> x = element_positions(mesh, position, e);
    const Vec2 lo = x.colwise().minCoeff().transpose(), hi = x.colwise().maxCoeff().transpose();
    for (std::size_t k = 0; k < 4; ++k) {
      const Vec2 at = point_position(mesh, position, e, k);
      const double volume = (x.transpose() * slots[k].natural_gradient).determinant();
      points.add(at, volume, density, 0.25 * (hi - lo), material, body);
    }
  }
  return points;
}

}  // namespace pfm::ulfem

#include "mpm/step/case.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <limits>
#include <numbers>
#include <set>

#include "mpm/boundary/load_input.hpp"
#include "mpm/core/json_input.hpp"
#include "mpm/core/polygon.hpp"
#include "mpm/core/provenance.hpp"
#include "mpm/detect/detect_command.hpp"
#include "mpm/step/gmsh_surface.hpp"
#include "mpm/step/particle_input.hpp"

namespace pfm {

namespace {

PiecewiseLinear parse_cohesion(const JsonView& v) {
  PiecewiseLinear law;
  if (v.is_number()) {
    const double c = v.as_number();
    v.require(c > 0.0, "must be > 0");
    law.x = {0.0};
    law.y = {c};
    return law;
  }
  if (!v.is_object()) v.fail("expected a number or an object");
  if (v.has("table")) {
    v.expect_object({"table"});
    const JsonView table = v.at("table");
    table.require(table.array_size() >= 1, "must hold at least one [plastic_strain, cohesion]");
    for (std::size_t k = 0; k < table.array_size(); ++k) {
      const JsonView row = table.at(k);
      const Vec2 xy = row.as_vec2();
      row.require(xy.x() >= 0.0, "plastic strain must be >= 0");
      row.require(xy.y() > 0.0, "cohesion must be > 0");
      row.require(k == 0 || xy.x() > law.x.back(), "plastic strains must increase strictly");
      law.x.push_back(xy.x());
      law.y.push_back(xy.y());
    }
    return law;
  }
  v.expect_object(
      {"initial", "peak", "residual", "peak_plastic_strain", "residual_plastic_strain"});
  const double initial = v.at("initial").as_number();
  const double peak = v.at("peak").as_number();
  const double residual = v.at("residual").as_number();
  const double eps_peak = v.at("peak_plastic_strain").as_number();
  const double eps_residual = v.at("residual_plastic_strain").as_number();
  v.at("initial").require(initial > 0.0, "must be > 0");
  v.at("peak").require(peak > 0.0, "must be > 0");
  v.at("residual").require(residual > 0.0, "must be > 0");
  v.at("peak_plastic_strain").require(eps_peak > 0.0, "must be > 0");
  v.at("residual_plastic_strain").require(eps_residual > eps_peak, "must be > peak_plastic_strain");
  law.x = {0.0, eps_peak, eps_residual};
  law.y = {initial, peak, residual};
  return law;
}

// materials[].softening_length, m: the width of the band that the cohesion law's plastic
// strains are meant for. Softening localises in a band a few cells (or elements) wide, so with
// one law for every cell size h the band softens faster, per metre of plastic displacement
// across it, the finer the grid: the results depend on h. With a softening length L the law's
// plastic strains are scaled by L / h, so the cohesion reaches each of its values at the same
// plastic displacement across the band at every h (the dissipated energy per unit area of the
// band is fixed: Pietruszczak and Mroz 1981). The law is the given one at h = L. h is the grid's
// cell size, for the UL-FEM too: its elements are the grid's cells for grid-aligned bodies, and
// of about that size (or twice it, unstructured) for polygons and meshes read from a file.
PiecewiseLinear regularised(PiecewiseLinear law, const JsonView& v, double cell_size) {
  if (!v.has("softening_length")) return law;
  const double length = v.at("softening_length").as_number();
  v.at("softening_length").require(length > 0.0, "must be > 0 (m)");
  v.at("softening_length")
      .require(law.x.size() >= 2, "needs a cohesion that changes with the plastic strain");
  for (double& x : law.x) x *= length / cell_size;
  return law;
}

MaterialRecord parse_material(const JsonView& v, double cell_size) {
  const std::string model = v.at("model").as_choice({"linear_elastic", "tresca", "mohr_coulomb"});
  if (model == "linear_elastic") {
    v.expect_object({"name", "model", "youngs_modulus", "poisson_ratio", "unit_weight"});
  } else if (model == "tresca") {
    v.expect_object({"name", "model", "youngs_modulus", "poisson_ratio", "unit_weight", "cohesion",
                     "softening_length"});
  } else {
    v.expect_object({"name", "model", "youngs_modulus", "poisson_ratio", "unit_weight", "cohesion",
                     "softening_length", "friction_angle", "dilation_angle", "tension_cutoff"});
  }
  MaterialRecord record;
  record.name = v.at("name").as_string();
  v.at("name").require(!record.name.empty(), "must not be empty");
  ElasticParameters elastic;
  elastic.youngs_modulus = v.at("youngs_modulus").as_number();
  v.at("youngs_modulus").require(elastic.youngs_modulus > 0.0, "must be > 0");
  elastic.poisson_ratio = v.at("poisson_ratio").as_number();
  v.at("poisson_ratio")
      .require(elastic.poisson_ratio >= 0.0 && elastic.poisson_ratio < 0.5, "must be in [0, 0.5)");
  record.unit_weight = v.at("unit_weight").as_number();
  v.at("unit_weight").require(record.unit_weight >= 0.0, "must be >= 0");
  if (model != "linear_elastic") {
    record.written_cohesion = parse_cohesion(v.at("cohesion"));
    if (v.has("softening_length")) record.softening_length = v.at("softening_length").as_number();
  }
  if (model == "linear_elastic") {
    record.model = LinearElastic{elastic};
  } else if (model == "tresca") {
    record.model = Tresca{elastic, regularised(record.written_cohesion, v, cell_size)};
  } else {
    MohrCoulomb mc;
    mc.elastic = elastic;
    mc.cohesion = regularised(record.written_cohesion, v, cell_size);
    mc.friction_angle_deg = v.at("friction_angle").as_number();
    v.at("friction_angle")
        .require(mc.friction_angle_deg >= 0.0 && mc.friction_angle_deg < 90.0,
                 "must be in [0, 90) degrees");
    mc.dilation_angle_deg = v.number_or("dilation_angle", 0.0);
    if (v.has("dilation_angle")) {
      v.at("dilation_angle")
          .require(mc.dilation_angle_deg >= 0.0 && mc.dilation_angle_deg <= mc.friction_angle_deg,
                   "must be in [0, friction_angle] degrees");
    }
    // Default: no cut-off of its own; the effective cut-off is then the cone apex c cot(phi)
    // (materials.cpp), so phi = 0 with the default is Tresca exactly.
    mc.tension_cutoff = v.number_or("tension_cutoff", std::numeric_limits<double>::infinity());
    if (v.has("tension_cutoff"))
      v.at("tension_cutoff").require(mc.tension_cutoff >= 0.0, "must be >= 0");
    record.model = mc;
  }
  return record;
}

// bodies[k].particles: a CSV or HDF5 file (relative to the case file's folder) with x, y and
// volume, optionally the stress and the material (read_particle_file). Every point inside the
// grid, every material an index of materials[].
void read_body_particles(const JsonView& body, const Case& c, BodySpec& out) {
  for (const char* key :
       {"rectangle", "polygon", "mesh", "physical_group", "points_per_cell", "placement"}) {
    if (body.has(key)) {
      body.at(key).fail(std::string("not used with \"particles\" (the file gives the points)"));
    }
  }
  const JsonView entry = body.at("particles");
  std::filesystem::path path = entry.as_string();
  if (path.is_relative()) path = std::filesystem::path(c.file).parent_path() / path;
  std::error_code error;
  entry.require(
      !std::filesystem::exists(path, error) || std::filesystem::is_regular_file(path, error),
      path.string() + " is not a regular file");
  ParticleTable table;
  try {
    table = read_particle_file(path.string());
  } catch (const InputError& e) {
    entry.fail(e.what());
  }
  for (std::size_t k = 0; k < table.material.size(); ++k) {
    if (table.material[k] >= static_cast<int>(c.materials.size())) {
      entry.fail(path.string() + ": point " + std::to_string(k + 1) + ": material " +
                 std::to_string(table.material[k]) + " is not an index of materials[] (0.." +
                 std::to_string(c.materials.size() - 1) + ")");
    }
  }
  const Grid& grid = c.grid;
  const Vec2 lo = grid.node_position(0, 0);
  const Vec2 hi = grid.node_position(grid.n_cells_x, grid.n_cells_y);
  for (std::size_t k = 0; k < table.position.size(); ++k) {
    const Vec2& x = table.position[k];
    if (!(x.x() > lo.x() && x.x() < hi.x() && x.y() > lo.y() && x.y() < hi.y())) {
      entry.fail(path.string() + ": point " + std::to_string(k + 1) + " (" + std::to_string(x.x()) +
                 ", " + std::to_string(x.y()) + ") is not inside the grid");
    }
  }
  out.point_position = std::move(table.position);
  out.point_volume = std::move(table.volume);
  out.point_stress = std::move(table.stress);
  out.point_material = std::move(table.material);
}

void require_inside_grid(const std::vector<Vec2>& polygon, const JsonView& at, const Grid& grid) {
  const Vec2 lo = grid.origin, hi = grid.upper_corner();
  for (const Vec2& v : polygon) {
    if (v.x() < lo.x() || v.y() < lo.y() || v.x() > hi.x() || v.y() > hi.y()) {
      at.fail("vertex (" + std::to_string(v.x()) + ", " + std::to_string(v.y()) +
              ") lies outside the grid [" + std::to_string(lo.x()) + ", " + std::to_string(hi.x()) +
              "] x [" + std::to_string(lo.y()) + ", " + std::to_string(hi.y()) + "]");
    }
  }
}

std::vector<Vec2> parse_polygon(const JsonView& body, const Grid& grid) {
  std::vector<Vec2> polygon;
  const bool has_rectangle = body.has("rectangle"), has_polygon = body.has("polygon");
  body.require(has_rectangle != has_polygon, "give exactly one of \"rectangle\" or \"polygon\"");
  if (has_rectangle) {
    const JsonView r = body.at("rectangle");
    r.require(r.array_size() == 2, "expected [[x0, y0], [x1, y1]]");
    const Vec2 a = r.at(std::size_t{0}).as_vec2(), b = r.at(std::size_t{1}).as_vec2();
    r.require(b.x() > a.x() && b.y() > a.y(), "expected x1 > x0 and y1 > y0");
    polygon = {a, Vec2(b.x(), a.y()), b, Vec2(a.x(), b.y())};
  } else {
    const JsonView p = body.at("polygon");
    p.require(p.array_size() >= 3, "a polygon needs at least 3 vertices");
    for (std::size_t k = 0; k < p.array_size(); ++k) polygon.push_back(p.at(k).as_vec2());
    if ((polygon.front() - polygon.back()).norm() == 0.0) polygon.pop_back();  // closed form
    p.require(polygon.size() >= 3, "a polygon needs at least 3 distinct vertices");
    p.require(!polygon_self_intersects(polygon),
              "polygon edges intersect each other (or a vertex repeats)");
    const double area = polygon_signed_area(polygon);
    p.require(std::abs(area) > 0.0, "polygon has zero area");
    if (area < 0.0) std::reverse(polygon.begin(), polygon.end());
  }
  require_inside_grid(polygon, body.at(has_rectangle ? "rectangle" : "polygon"), grid);
  return polygon;
}

// bodies[k].mesh: a gmsh .msh file (relative to the case file's folder) whose 2D elements (of
// bodies[k].physical_group, or all) make the body; its outline is the body polygon.
void read_body_mesh(const JsonView& body, const Case& c, BodySpec& out) {
  for (const char* key : {"rectangle", "polygon", "particles"}) {
    if (body.has(key)) body.at(key).fail(std::string("not used with \"mesh\" (it gives the body)"));
  }
  const JsonView entry = body.at("mesh");
  std::filesystem::path path = entry.as_string();
  if (path.is_relative()) path = std::filesystem::path(c.file).parent_path() / path;
  out.mesh_file = path.string();
  if (body.has("physical_group")) {
    out.physical_group = body.at("physical_group").as_string();
    body.at("physical_group").require(!out.physical_group.empty(), "must not be empty");
  }
  const std::string where = c.file + ": " + entry.pointer();
  out.polygon = surface_outline(read_gmsh_surface(out.mesh_file, out.physical_group, where), where);
  require_inside_grid(out.polygon, entry, c.grid);
}

// node_sets[k].mesh: a gmsh .msh file (relative to the case file's folder) whose physical group
// node_sets[k].physical_group, of curves or points, gives the set.
void read_node_set_mesh(const JsonView& v, const Case& c, NodeSet& out) {
  const JsonView entry = v.at("mesh");
  std::filesystem::path path = entry.as_string();
  if (path.is_relative()) path = std::filesystem::path(c.file).parent_path() / path;
  out.mesh_file = path.string();
  out.physical_group = v.at("physical_group").as_string();
  v.at("physical_group").require(!out.physical_group.empty(), "must not be empty");
  out.segments =
      read_gmsh_lines(out.mesh_file, out.physical_group, c.file + ": " + entry.pointer());
}

unsigned parse_fix(const JsonView& v) {
  const std::string s = v.as_choice({"x", "y", "xy"});
  return s == "x" ? kFixX : (s == "y" ? kFixY : kFixXY);
}

TimeFunction parse_time_function(const JsonView& v) {
  TimeFunction f;
  const std::string type = v.at("type").as_choice({"constant", "ramp", "smooth_ramp"});
  if (type == "constant") {
    v.expect_object({"type"});
  } else {
    v.expect_object({"type", "ramp_time"});
    f.kind = type == "ramp" ? TimeFunctionKind::kRamp : TimeFunctionKind::kSmoothRamp;
    f.ramp_time = v.at("ramp_time").as_number();
    v.at("ramp_time").require(f.ramp_time > 0.0, "must be > 0");
  }
  return f;
}

}  // namespace

bool NodeSet::contains(const Vec2& x, double tolerance) const {
  if (segments.empty()) {
    return x.x() >= box_min.x() - tolerance && x.x() <= box_max.x() + tolerance &&
           x.y() >= box_min.y() - tolerance && x.y() <= box_max.y() + tolerance;
  }
  for (const auto& [a, b] : segments) {
    const Vec2 ab = b - a;
    const double length2 = ab.squaredNorm();
    const double t = length2 > 0.0 ? std::clamp((x - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
    if ((a + t * ab - x).norm() <= tolerance) return true;
  }
  return false;
}

double largest_constrained_modulus(const std::vector<MaterialRecord>& materials) {
  double modulus = 0.0;
  for (const MaterialRecord& m : materials)
    modulus = std::max(modulus, elastic_parameters(m.model).constrained_modulus());
  return modulus;
}

double largest_wave_speed(const Case& c) {
  const double g = c.gravity.g > 0.0 ? c.gravity.g : 9.81;
  double speed = 0.0;
  for (const MaterialRecord& m : c.materials) {
    const double density = m.unit_weight / g;
    if (density <= 0.0) continue;
    speed = std::max(speed, std::sqrt(elastic_parameters(m.model).constrained_modulus() / density));
  }
  if (speed <= 0.0) {
    throw InputError(c.file + ": /materials: every material has zero unit weight, so the " +
                     "critical time step is undefined");
  }
  return speed;
}

double estimated_particles(const Case& c) {
  double count = 0.0;
  const double cell_area = c.grid.cell_size * c.grid.cell_size;
  for (const BodySpec& body : c.bodies) {
    if (body.from_file()) {
      count += static_cast<double>(body.point_position.size());
      continue;
    }
    const double per_cell = static_cast<double>(body.points_per_cell) * body.points_per_cell;
    count += std::abs(polygon_signed_area(body.polygon)) / cell_area * per_cell;
  }
  return count;
}

double estimated_memory_bytes(const Case& c) {
  const double nodes = (c.grid.n_cells_x + 1.0) * (c.grid.n_cells_y + 1.0);
  return nodes * kBytesPerGridNode + estimated_particles(c) * kBytesPerParticle;
}

// Shamos and Hoey's sweep (1976): a line sweeps the edges left to right, holding those it crosses
// ordered by height; the first intersection, if any, is between two edges that are neighbours
// in that order at some moment, so each edge is tested only against its neighbours when it
// enters and against each other when an edge between them leaves: O(n log n). Edges sharing a
// vertex may touch there; every other contact (crossing, a vertex on an edge, a collinear
// overlap) counts.
bool polygon_self_intersects(const std::vector<Vec2>& polygon) {
  const std::size_t n = polygon.size();
  const auto before = [](const Vec2& a, const Vec2& b) {
    return a.x() < b.x() || (a.x() == b.x() && a.y() < b.y());
  };
  {
    std::vector<Vec2> sorted = polygon;
    std::sort(sorted.begin(), sorted.end(), before);
    for (std::size_t k = 1; k < n; ++k)
      if (sorted[k] == sorted[k - 1]) return true;  // a vertex repeats
  }
  // Adjacent edges folding back onto each other (collinear overlap).
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2& a = polygon[(i + n - 1) % n];
    const Vec2& b = polygon[i];
    const Vec2& c = polygon[(i + 1) % n];
    if (orient(a, b, c) == 0.0 && (a - b).dot(c - b) > 0.0) return true;
  }

  struct Edge {
    Vec2 left, right;  // lexicographically ordered ends
  };
  std::vector<Edge> edges(n);
  for (std::size_t i = 0; i < n; ++i) {
    const Vec2 &a = polygon[i], &b = polygon[(i + 1) % n];
    edges[i] = before(a, b) ? Edge{a, b} : Edge{b, a};
  }
  struct Event {
    Vec2 at;
    int starts;  // 0: the edge leaves (processed first at a point), 1: it enters
    std::size_t edge;
  };
  std::vector<Event> events;
  events.reserve(2 * n);
  for (std::size_t i = 0; i < n; ++i) {
    events.push_back({edges[i].left, 1, i});
    events.push_back({edges[i].right, 0, i});
  }
  std::sort(events.begin(), events.end(), [&](const Event& e, const Event& f) {
    if (e.at != f.at) return before(e.at, f.at);
    return e.starts != f.starts ? e.starts < f.starts : e.edge < f.edge;
  });

  double sweep_x = 0.0;
  bool overlap = false;
  // Height at the sweep line (a vertical edge, there only at its x: its lower end), then slope.
  const auto height = [&](std::size_t e) {
    const Edge& s = edges[e];
    if (sweep_x == s.left.x()) return s.left.y();
    if (sweep_x == s.right.x()) return s.right.y();
    return s.left.y() +
           (s.right.y() - s.left.y()) * (sweep_x - s.left.x()) / (s.right.x() - s.left.x());
  };
  const auto slope = [&](std::size_t e) {
    const Edge& s = edges[e];
    const double dx = s.right.x() - s.left.x();
    return dx == 0.0 ? std::numeric_limits<double>::infinity() : (s.right.y() - s.left.y()) / dx;
  };
  const auto below = [&](std::size_t a, std::size_t b) {
    const double ya = height(a), yb = height(b);
    if (ya != yb) return ya < yb;
    const double sa = slope(a), sb = slope(b);
    if (sa != sb) return sa < sb;
    overlap = overlap || a != b;  // collinear through one point
    return a < b;
  };
  const auto touch = [&](std::size_t a, std::size_t b) {
    if ((a + 1) % n == b || (b + 1) % n == a) return false;  // a shared vertex
    return segments_intersect(edges[a].left, edges[a].right, edges[b].left, edges[b].right);
  };
  std::set<std::size_t, decltype(below)> crossing(below);
  std::vector<std::set<std::size_t, decltype(below)>::iterator> place(n);
  for (const Event& e : events) {
    sweep_x = e.at.x();
    if (e.starts == 1) {
      const auto it = crossing.insert(e.edge).first;
      if (overlap) return true;
      place[e.edge] = it;
      if (it != crossing.begin() && touch(*std::prev(it), e.edge)) return true;
      if (std::next(it) != crossing.end() && touch(*std::next(it), e.edge)) return true;
    } else {
      const auto it = place[e.edge];
      if (it != crossing.begin() && std::next(it) != crossing.end() &&
          touch(*std::prev(it), *std::next(it)))
        return true;
      crossing.erase(it);
    }
  }
  return false;
}

Case read_case(const std::string& path) {
  return parse_case(read_json_file(path), path);
}

namespace {

// "manufactured_solution" (mpm/core/manufactured.hpp): {"type": "standing_wave" (default),
// "amplitude": A, "period": T} on a rectangle whose edges the case fixes, or {"type":
// "uniform_dilatation"} on a free body squeezed by its one load, a follower pressure on the
// detected boundary with a smooth ramp. Either lives on one body of linear elastic material with
// nothing else loading it: no gravity, no other load, a zero initial stress.
void parse_manufactured(const JsonView& m, const JsonView& root, Case& c) {
  ManufacturedSolution s;
  const std::string type =
      m.choice_or("type", {"standing_wave", "uniform_dilatation"}, "standing_wave");
  const std::string needs = "a manufactured solution needs ";
  root.at("bodies").require(c.bodies.size() == 1, needs + "exactly one body");
  const BodySpec& body = c.bodies.front();
  const JsonView body_view = root.at("bodies").at(std::size_t{0});
  body_view.require(body.point_position.empty(),
                    needs + "points placed by the body's cells, not a file");
  const MaterialRecord& material = c.materials[static_cast<std::size_t>(body.material)];
  const auto* elastic = std::get_if<LinearElastic>(&material.model);
  body_view.at("material").require(elastic != nullptr, needs + "a body of linear_elastic material");
  const std::vector<Vec2>& p = body.polygon;
  if (type == "standing_wave") {
    m.expect_object({"type", "amplitude", "period"});
    s.amplitude = m.at("amplitude").as_number();
    m.at("amplitude").require(s.amplitude > 0.0, "must be > 0 (m)");
    s.period = m.at("period").as_number();
    m.at("period").require(s.period > 0.0, "must be > 0 (s)");
    const bool rectangle = p.size() == 4 && p[0].y() == p[1].y() && p[1].x() == p[2].x() &&
                           p[2].y() == p[3].y() && p[3].x() == p[0].x();
    body_view.require(rectangle, needs + "a rectangle body (standing_wave)");
    m.require(c.loads.empty(), needs + "no loads: b is its only load (standing_wave)");
    s.origin = p[0];
    s.size = p[2] - p[0];
  } else {
    m.expect_object({"type"});
    s.kind = ManufacturedKind::kUniformDilatation;
    const bool squeezed = c.loads.size() == 1 && c.loads[0].type == "follower_pressure" &&
                          c.loads[0].apply_on == LoadTarget::kDetectedBoundary &&
                          c.loads[0].time_function.kind == TimeFunctionKind::kSmoothRamp;
    m.require(squeezed, needs +
                            "one load, a follower_pressure on the detected boundary with a "
                            "smooth_ramp time function (uniform_dilatation)");
    m.require(c.boundary_conditions.empty(),
              needs + "a free body: no boundary conditions (uniform_dilatation)");
    s.pressure = c.loads[0].pressure;
    s.ramp_time = c.loads[0].time_function.ramp_time;
    s.centre = polygon_centroid(p);
  }
  m.require(c.gravity.g == 0.0, needs + "gravity off (gravity.g = 0): b is its only body force");
  m.require(c.initial_stress.method == InitialStressMethod::kZero,
            needs + "the zero initial stress (it starts at rest, unstressed)");
  const ElasticParameters e = elastic_parameters(material.model);
  s.lambda = e.lame_lambda();
  s.mu = e.shear_modulus();
  s.density = material.unit_weight / 9.81;  // as largest_wave_speed with gravity off
  m.require(s.density > 0.0, needs + "a material with mass (unit_weight > 0)");
  c.manufactured = s;
}

}  // namespace

namespace {

/// The grid: origin, cell size, cell counts and the node limit.
void parse_grid(const JsonView& root, Case& c) {
  const JsonView g = root.at("grid");
  g.expect_object({"origin", "cell_size", "n_cells", "max_nodes"});
  if (g.has("origin")) c.grid.origin = g.at("origin").as_vec2();
  c.grid.cell_size = g.at("cell_size").as_number();
  g.at("cell_size").require(c.grid.cell_size > 0.0, "must be > 0");
  const JsonView n = g.at("n_cells");
  n.require(n.array_size() == 2, "expected [nx, ny]");
  c.grid.n_cells_x = n.at(std::size_t{0}).as_int();
  c.grid.n_cells_y = n.at(std::size_t{1}).as_int();
  n.at(std::size_t{0}).require(c.grid.n_cells_x >= 1, "must be >= 1");
  n.at(std::size_t{1}).require(c.grid.n_cells_y >= 1, "must be >= 1");
  c.max_grid_nodes = g.number_or("max_nodes", c.max_grid_nodes);
  if (g.has("max_nodes")) {
    g.at("max_nodes")
        .require(c.max_grid_nodes >= 1.0 && c.max_grid_nodes <= 2e9,
                 "must be in [1, 2e9] (node indices are 32-bit)");
  }
  const double nodes = (c.grid.n_cells_x + 1.0) * (c.grid.n_cells_y + 1.0);
  if (!(nodes <= c.max_grid_nodes)) {
    char text[200];
    std::snprintf(text, sizeof text,
                  "%.3g grid nodes, more than grid.max_nodes (%.3g): a unit mistake? (raise "
                  "grid.max_nodes for a grid that large)",
                  nodes, c.max_grid_nodes);
    n.fail(text);
  }
}

/// The materials, by unique name.
void parse_materials(const JsonView& root, Case& c) {
  const JsonView m = root.at("materials");
  m.require(m.array_size() >= 1, "at least one material is required");
  std::set<std::string> names;
  for (std::size_t k = 0; k < m.array_size(); ++k) {
    c.materials.push_back(parse_material(m.at(k), c.grid.cell_size));
    m.at(k).at("name").require(names.insert(c.materials.back().name).second,
                               "duplicate material name");
  }
}

/// The bodies: a rectangle, a polygon, a particle file or a mesh each, with its material.
void parse_bodies(const JsonView& root, Case& c) {
  const JsonView b = root.at("bodies");
  b.require(b.array_size() >= 1, "at least one body is required");
  std::set<std::string> names;
  for (std::size_t k = 0; k < b.array_size(); ++k) {
    const JsonView v = b.at(k);
    v.expect_object({"name", "material", "rectangle", "polygon", "particles", "mesh",
                     "physical_group", "points_per_cell", "placement"});
    BodySpec body;
    body.name = v.at("name").as_string();
    v.at("name").require(names.insert(body.name).second, "duplicate body name");
    const std::string material = v.at("material").as_string();
    int index = -1;
    for (std::size_t i = 0; i < c.materials.size(); ++i) {
      if (c.materials[i].name == material) index = static_cast<int>(i);
    }
    v.at("material").require(index >= 0, "no material named \"" + material + "\"");
    body.material = index;
    if (v.has("particles")) {
      read_body_particles(v, c, body);
      c.bodies.push_back(std::move(body));
      continue;
    }
    if (v.has("mesh")) {
      read_body_mesh(v, c, body);
    } else {
      if (v.has("physical_group"))
        v.at("physical_group").fail("used only with \"mesh\" (a gmsh file)");
      body.polygon = parse_polygon(v, c.grid);
    }
    body.points_per_cell = v.int_or("points_per_cell", 2);
    if (v.has("points_per_cell")) {
      v.at("points_per_cell")
          .require(body.points_per_cell >= 1 && body.points_per_cell <= 8, "must be in 1..8");
    }
    const std::string placement =
        v.choice_or("placement", {"equal", "gauss", "conforming"}, "equal");
    body.placement = placement == "gauss"        ? Placement::kGauss
                     : placement == "conforming" ? Placement::kConforming
                                                 : Placement::kEqual;
    c.bodies.push_back(std::move(body));
  }
}

/// Refuses a run the machine cannot hold, before a byte of it is allocated.
void check_memory(const JsonView& root, const Case& c) {
  // Before a byte of the run is allocated: the machine must hold it.
  const double need = estimated_memory_bytes(c), have = available_memory_bytes();
  if (need > have) {
    char text[240];
    std::snprintf(text, sizeof text,
                  "the run would need about %.3g GB of memory (%.3g grid nodes, about %.3g "
                  "material points), more than the %.3g GB this machine has available",
                  need / 1e9, (c.grid.n_cells_x + 1.0) * (c.grid.n_cells_y + 1.0),
                  estimated_particles(c), have / 1e9);
    root.at("grid").at("n_cells").fail(text);
  }
}

/// Gravity and its ramp.
void parse_gravity(const JsonView& root, Case& c) {
  if (const auto g = root.find("gravity")) {
    g->expect_object({"g", "ramp_time"});
    c.gravity.g = g->number_or("g", 9.81);
    if (g->has("g")) g->at("g").require(c.gravity.g >= 0.0, "must be >= 0");
    c.gravity.ramp_time = g->number_or("ramp_time", 0.0);
    if (g->has("ramp_time")) g->at("ramp_time").require(c.gravity.ramp_time >= 0.0, "must be >= 0");
  }
}

/// The initial stress procedure, and what it cannot take (stresses from a file, K0 without a top).
void parse_initial_stress(const JsonView& root, Case& c) {
  if (const auto s = root.find("initial_stress")) {
    s->expect_object({"method", "k0", "kinetic_energy_ratio", "damping", "max_time"});
    const std::string method = s->at("method").as_choice({"zero", "k0", "gravity"});
    c.initial_stress.method = method == "zero" ? InitialStressMethod::kZero
                              : method == "k0" ? InitialStressMethod::kK0
                                               : InitialStressMethod::kGravity;
    if (s->has("k0")) {
      s->at("k0").require(method == "k0", "only used with method \"k0\"");
      c.initial_stress.k0 = s->at("k0").as_number();
      s->at("k0").require(*c.initial_stress.k0 >= 0.0, "must be >= 0");
    }
    for (const char* key : {"kinetic_energy_ratio", "damping", "max_time"}) {
      if (s->has(key)) s->at(key).require(method == "gravity", "only used with method \"gravity\"");
    }
    c.initial_stress.kinetic_energy_ratio = s->number_or("kinetic_energy_ratio", 1e-6);
    if (s->has("kinetic_energy_ratio")) {
      s->at("kinetic_energy_ratio")
          .require(c.initial_stress.kinetic_energy_ratio > 0.0 &&
                       c.initial_stress.kinetic_energy_ratio < 1.0,
                   "must be in (0, 1)");
    }
    c.initial_stress.damping = s->number_or("damping", 0.7);
    if (s->has("damping")) {
      s->at("damping").require(c.initial_stress.damping >= 0.0 && c.initial_stress.damping < 1.0,
                               "must be in [0, 1)");
    }
    c.initial_stress.max_time = s->number_or("max_time", 20.0);
    if (s->has("max_time"))
      s->at("max_time").require(c.initial_stress.max_time > 0.0, "must be > 0");
  }
  for (std::size_t b = 0; b < c.bodies.size(); ++b) {
    if (!c.bodies[b].point_stress.empty() &&
        c.initial_stress.method != InitialStressMethod::kZero) {
      root.at("bodies")
          .at(b)
          .at("particles")
          .fail(
              "the file gives the points' stresses, which are the initial state: use "
              "initial_stress.method \"zero\" (or a file without sxx, syy, sxy, szz)");
    }
  }
  if (c.initial_stress.method == InitialStressMethod::kK0) {
    for (const BodySpec& body : c.bodies) {
      if (body.from_file()) {
        root.at("initial_stress")
            .at("method")
            .fail(
                "K0 takes each point's depth below its body's top, which a body from a particle "
                "file (\"" +
                body.name + "\") does not have: use \"zero\" or \"gravity\"");
      }
    }
  }
}

/// The node sets (boxes or mesh groups).
void parse_node_sets(const JsonView& root, Case& c) {
  if (const auto ns = root.find("node_sets")) {
    for (std::size_t k = 0; k < ns->array_size(); ++k) {
      const JsonView v = ns->at(k);
      v.expect_object({"name", "box", "mesh", "physical_group"});
      NodeSet set;
      set.name = v.at("name").as_string();
      for (const char* reserved : {"left", "right", "bottom", "top"}) {
        v.at("name").require(set.name != reserved, "\"" + set.name + "\" is reserved");
      }
      for (const auto& other : c.node_sets) {
        v.at("name").require(other.name != set.name, "duplicate node-set name");
      }
      v.require(v.has("box") != v.has("mesh"), "give exactly one of \"box\" or \"mesh\"");
      if (v.has("mesh")) {
        read_node_set_mesh(v, c, set);
      } else {
        if (v.has("physical_group"))
          v.at("physical_group").fail("used only with \"mesh\" (a gmsh file)");
        const JsonView box = v.at("box");
        box.require(box.array_size() == 2, "expected [[x0, y0], [x1, y1]]");
        set.box_min = box.at(std::size_t{0}).as_vec2();
        set.box_max = box.at(std::size_t{1}).as_vec2();
        box.require(set.box_max.x() >= set.box_min.x() && set.box_max.y() >= set.box_min.y(),
                    "expected x1 >= x0 and y1 >= y0");
      }
      c.node_sets.push_back(set);
    }
  }
}

/// The supports and prescribed velocities on node sets.
void parse_boundary_conditions(const JsonView& root, Case& c) {
  if (const auto bcs = root.find("boundary_conditions")) {
    for (std::size_t k = 0; k < bcs->array_size(); ++k) {
      const JsonView v = bcs->at(k);
      v.expect_object({"where", "fix", "velocity", "time_function"});
      BoundaryCondition bc;
      bc.where = v.at("where").as_string();
      bool known =
          bc.where == "left" || bc.where == "right" || bc.where == "bottom" || bc.where == "top";
      for (const auto& set : c.node_sets) known = known || set.name == bc.where;
      v.at("where").require(
          known, "\"" + bc.where + "\" is neither left, right, bottom, top nor a node set");
      bc.fix = parse_fix(v.at("fix"));
      if (const auto velocity = v.find("velocity")) {
        bc.velocity = velocity->as_vec2();
        bc.moving = true;
        velocity->require((bc.fix & kFixX) || bc.velocity.x() == 0.0,
                          "x is not fixed (\"fix\"): its velocity must be 0");
        velocity->require((bc.fix & kFixY) || bc.velocity.y() == 0.0,
                          "y is not fixed (\"fix\"): its velocity must be 0");
      }
      if (v.has("time_function")) {
        v.at("time_function").require(bc.moving, "used only with \"velocity\"");
        bc.time_function = parse_time_function(v.at("time_function"));
      }
      c.boundary_conditions.push_back(bc);
    }
  }
}

/// The loads on grid-top nodes and on the detected boundary.
void parse_loads(const JsonView& root, Case& c) {
  if (const auto loads = root.find("loads")) {
    for (std::size_t k = 0; k < loads->array_size(); ++k) {
      const JsonView v = loads->at(k);
      LoadSpec load;
      load.raw = v.raw();
      const std::string target =
          v.choice_or("apply_on", {"grid_top_nodes", "detected_boundary"}, "grid_top_nodes");
      if (target == "detected_boundary") {
        load.apply_on = LoadTarget::kDetectedBoundary;
        load.surface = boundary::parse_boundary_load(v);
        load.type = v.at("type").as_string();
        load.pressure = load.surface->pressure;
        if (load.surface->x_range) {
          load.x0 = load.surface->x_range->x();
          load.x1 = load.surface->x_range->y();
        }
        if (v.has("time_function")) load.time_function = parse_time_function(v.at("time_function"));
        c.loads.push_back(std::move(load));
        continue;
      }
      // A load on the grid's top nodes (the default target) is a vertical pressure; the other
      // types act on the detected boundary, which the user has most likely forgotten to name.
      if (v.has("type") && v.at("type").is_string() &&
          v.at("type").raw().get<std::string>() != "vertical_pressure") {
        std::string message = v.at("type").raw().get<std::string>();
        message.append(
            " acts on the detected boundary only: add \"apply_on\": \"detected_boundary\" "
            "(without apply_on a load is a \"vertical_pressure\" on the grid's top nodes)");
        v.at("type").fail(message);
      }
      v.expect_object({"type", "pressure", "x_range", "apply_on", "time_function"});
      load.type = v.at("type").as_choice({"vertical_pressure"});
      load.pressure = v.at("pressure").as_number();
      v.at("pressure").require(load.pressure >= 0.0, "must be >= 0");
      const Vec2 range = v.at("x_range").as_vec2();
      v.at("x_range").require(range.x() < range.y(), "expected x0 < x1");
      load.x0 = range.x();
      load.x1 = range.y();
      if (v.has("time_function")) load.time_function = parse_time_function(v.at("time_function"));
      c.loads.push_back(std::move(load));
    }
  }
}

/// The essential conditions on the detected boundary.
void parse_constraints(const JsonView& root, Case& c) {
  if (const auto constraints = root.find("constraints")) {
    // The stiffest material's constrained modulus, the scale of the default penalty.
    const double modulus = largest_constrained_modulus(c.materials);
    for (std::size_t k = 0; k < constraints->array_size(); ++k) {
      const JsonView v = constraints->at(k);
      v.expect_object({"apply_on", "x_range", "faces", "normal", "curve", "interval",
                       "gauss_points", "normal_displacement", "displacement", "normal_velocity",
                       "velocity", "time_function", "method", "penalty", "penalty_factor",
                       "band_factor"});
      v.at("apply_on").as_choice({"detected_boundary"});
      ConstraintSpec constraint;
      constraint.raw = v.raw();
      boundary::parse_boundary_part(v, false, "all", constraint.part);
      if (constraint.part.interval == boundary::LoadInterval::kMaterial) {
        v.at("interval")
            .fail(
                "\"material\" is for loads: a constraint's part is fixed in space (x_range) or a "
                "face (normal)");
      }
      constraint.part.quadrature.gauss_points = v.int_or("gauss_points", 2);
      if (constraint.part.quadrature.gauss_points < 1 ||
          constraint.part.quadrature.gauss_points > boundary::kMaxGaussPoints) {
        v.at("gauss_points").fail("must be in 1.." + std::to_string(boundary::kMaxGaussPoints));
      }
      int given = 0;
      for (const char* key : {"normal_displacement", "displacement", "normal_velocity", "velocity"})
        given += v.has(key) ? 1 : 0;
      v.require(given == 1,
                "give one of normal_displacement (m), displacement ([ux, uy], m), "
                "normal_velocity (m/s) or velocity ([vx, vy], m/s)");
      constraint.normal_only = v.has("normal_displacement") || v.has("normal_velocity");
      constraint.velocity = v.has("normal_velocity") || v.has("velocity");
      const char* key = constraint.normal_only
                            ? (constraint.velocity ? "normal_velocity" : "normal_displacement")
                            : (constraint.velocity ? "velocity" : "displacement");
      constraint.value =
          constraint.normal_only ? Vec2(v.at(key).as_number(), 0.0) : v.at(key).as_vec2();
      if (v.has("time_function"))
        constraint.time_function = parse_time_function(v.at("time_function"));
      const std::string method = v.choice_or("method", {"penalty", "nitsche", "ibm"}, "penalty");
      constraint.method = method == "penalty"   ? ConstraintMethod::kPenalty
                          : method == "nitsche" ? ConstraintMethod::kNitsche
                                                : ConstraintMethod::kImplicitBoundary;
      if (constraint.method == ConstraintMethod::kImplicitBoundary) {
        for (const char* unused : {"penalty", "penalty_factor"}) {
          if (v.has(unused))
            v.at(unused).fail("is not read by \"ibm\" (its band's stiffness is the material's)");
        }
        constraint.band_factor = v.number_or("band_factor", constraint.band_factor);
        if (v.has("band_factor")) {
          v.at("band_factor")
              .require(constraint.band_factor > 0.0 && constraint.band_factor < 1.0,
                       "must be in (0, 1): the band's thickness over h");
        }
      } else if (v.has("band_factor")) {
        v.at("band_factor").fail("is read only with method \"ibm\"");
      }
      v.require(!(v.has("penalty") && v.has("penalty_factor")),
                "give penalty (kPa/m) or penalty_factor, not both");
      constraint.penalty_factor = v.number_or("penalty_factor", constraint.penalty_factor);
      if (v.has("penalty_factor"))
        v.at("penalty_factor").require(constraint.penalty_factor > 0.0, "must be > 0");
      constraint.penalty = constraint.penalty_factor * modulus / c.grid.cell_size;
      if (v.has("penalty")) {
        constraint.penalty = v.at("penalty").as_number();
        v.at("penalty").require(constraint.penalty > 0.0, "must be > 0 (kPa/m)");
      }
      c.constraints.push_back(std::move(constraint));
    }
  }
}

/// The particle velocity update of solver block `s`: pic_fraction and xpic_order.
void parse_velocity_update(const JsonView& s, SolverSpec& solver) {
  solver.pic_fraction = s.number_or("pic_fraction", 0.0);
  if (s.has("pic_fraction")) {
    s.at("pic_fraction")
        .require(solver.pic_fraction >= 0.0 && solver.pic_fraction <= 1.0,
                 "must be in [0, 1] (0 = FLIP, 1 = PIC)");
  }
  solver.xpic_order = s.int_or("xpic_order", 1);
  if (s.has("xpic_order")) {
    s.at("xpic_order")
        .require(solver.xpic_order >= 1 && solver.xpic_order <= kMaxXpicOrder,
                 "must be an integer in [1, " + std::to_string(kMaxXpicOrder) + "]");
    s.at("xpic_order")
        .require(solver.xpic_order == 1 || solver.pic_fraction > 0.0,
                 "an order above 1 needs solver.pic_fraction > 0 (it shapes the PIC part)");
  }
}

/// The solver settings and their defaults (which depend on the materials, the constraints and the
/// shape function), with the checks that need the shape function.
void parse_solver(const JsonView& root, Case& c) {
  // The mean dilatation by default where a material is nearly incompressible: without it such a
  // soil locks (a smooth footing on Tresca soil with nu = 0.49 shows no collapse up to
  // 1.2 (2 + pi) c, test_anti_locking); with it the stresses of a compressible one converge at
  // first order only (the manufactured solution with quadratic B-splines and nu = 0.3: 12.7 %,
  // 6.3 %, 3.1 % at 8, 16, 32 cells, against 1.1 %, 0.29 %, 0.085 % without).
  double largest_poisson_ratio = 0.0;
  for (const MaterialRecord& m : c.materials) {
    largest_poisson_ratio =
        std::max(largest_poisson_ratio, elastic_parameters(m.model).poisson_ratio);
  }
  // And in a strength reduction, which seeks a collapse by plastic flow, isochoric for
  // Tresca and for Mohr-Coulomb without dilation: it locks without the mean dilatation whatever
  // nu is (a pressed block on uGIMP stands well past its factor of safety).
  const auto implicit = root.find("implicit");
  const bool seeks_collapse = implicit && implicit->has("strength_reduction");
  const bool mean_dilatation = largest_poisson_ratio >= kBbarPoissonRatio || seeks_collapse;
  c.solver.mean_dilatation = mean_dilatation;
  std::optional<double> outer_node_fraction;
  std::optional<JsonView> ghost_penalty;
  if (const auto s = root.find("solver")) {
    s->expect_object({"type", "scheme", "shape_function", "damping", "damping_form", "pic_fraction",
                      "xpic_order", "anti_locking", "outer_node_fraction", "ghost_penalty"});
    c.solver.type = s->choice_or("type", {"explicit", "implicit"}, "explicit") == "implicit"
                        ? SolverType::kImplicit
                        : SolverType::kExplicit;
    c.solver.scheme =
        s->choice_or("scheme", {"musl", "usl"}, "musl") == "usl" ? Scheme::kUSL : Scheme::kMUSL;
    const std::string shape =
        s->choice_or("shape_function", {"linear", "gimp", "quadratic_bspline", "cubic_bspline"},
                     "quadratic_bspline");
    c.solver.shape_function = shape == "gimp"                ? ShapeFunctionKind::kGimp
                              : shape == "quadratic_bspline" ? ShapeFunctionKind::kQuadraticBspline
                              : shape == "cubic_bspline"     ? ShapeFunctionKind::kCubicBspline
                                                             : ShapeFunctionKind::kLinear;
    c.solver.damping = s->number_or("damping", 0.0);
    if (s->has("damping")) {
      s->at("damping").require(c.solver.damping >= 0.0 && c.solver.damping < 1.0,
                               "must be in [0, 1)");
    }
    c.solver.damping_form = s->choice_or("damping_form", {"per_axis", "along_velocity"},
                                         "along_velocity") == "along_velocity"
                                ? DampingForm::kAlongVelocity
                                : DampingForm::kPerAxis;
    parse_velocity_update(*s, c.solver);
    c.solver.mean_dilatation =
        s->choice_or("anti_locking", {"none", "bbar"}, mean_dilatation ? "bbar" : "none") == "bbar";
    if (s->has("outer_node_fraction")) {
      outer_node_fraction = s->at("outer_node_fraction").as_number();
      s->at("outer_node_fraction")
          .require(*outer_node_fraction >= 0.0 && *outer_node_fraction <= 0.5,
                   "must be in [0, 0.5] (0 leaves every node free)");
    }
    ghost_penalty = s->find("ghost_penalty");
  }
  // The ties of nearly empty nodes (mpm/core/basis_extension.hpp): on by default with uGIMP and
  // B-splines (linear functions, the thesis's, keep their results). The explicit step's
  // constraints on the detected boundary put their penalty forces and nodal stiffness on the nodes
  // with mass (boundary_constraint.hpp), not through the ties, so an explicit case with
  // constraints has none; the implicit step's act through each node's map of unknowns, ties
  // included (implicit_constraints.cpp), and take them: without them a node over a sliver of
  // perfectly plastic material leaves Newton's tangent near singular (the rigid footing's steps
  // do not converge).
  const bool explicit_constraints =
      !c.constraints.empty() && c.solver.type == SolverType::kExplicit;
  if (explicit_constraints && outer_node_fraction.value_or(0.0) > 0.0) {
    root.at("solver")
        .at("outer_node_fraction")
        .fail(
            "must be 0 in an explicit case with constraints (their forces do not act through tied "
            "nodes)");
  }
  const bool tied = c.solver.shape_function != ShapeFunctionKind::kLinear && !explicit_constraints;
  // The Implicit Boundary Method changes the stiffness matrix, which only the implicit step has
  // (thesis 3.3.3: "IBM is therefore not applicable to explicit MPM").
  for (std::size_t k = 0; k < c.constraints.size(); ++k) {
    if (c.constraints[k].method == ConstraintMethod::kImplicitBoundary &&
        c.solver.type != SolverType::kImplicit) {
      root.at("constraints")
          .at(k)
          .at("method")
          .fail("\"ibm\" (the Implicit Boundary Method) needs solver.type \"implicit\"");
    }
  }
  c.solver.outer_node_fraction =
      outer_node_fraction.value_or(tied ? kDefaultOuterNodeFraction : 0.0);
  // The ghost penalty acts on the light nodes next to the tied ones (the tie fraction up to
  // twice it), in the implicit step's tangent, which the explicit step does not have.
  const bool ghosted = c.solver.type == SolverType::kImplicit && c.solver.outer_node_fraction > 0.0;
  c.solver.ghost_penalty = ghosted ? kDefaultGhostPenalty : 0.0;
  if (ghost_penalty) {
    c.solver.ghost_penalty = ghost_penalty->as_number();
    ghost_penalty->require(c.solver.ghost_penalty >= 0.0 && c.solver.ghost_penalty <= 1.0,
                           "must be in [0, 1] (0: none)");
    ghost_penalty->require(
        ghosted || c.solver.ghost_penalty == 0.0,
        "must be 0 unless solver.type is \"implicit\" with solver.outer_node_fraction > 0 (it "
        "acts on the nodes next to the tied ones, in the implicit tangent)");
  }
  // Checks that need the shape function, which has a default.
  {
    const int degree = shape_degree(c.solver.shape_function);
    if (degree > 1 && std::min(c.grid.n_cells_x, c.grid.n_cells_y) < degree) {
      const std::string message =
          "B-splines of degree " + std::to_string(degree) + " need at least " +
          std::to_string(degree) + " cells along each axis of the grid (it has " +
          std::to_string(c.grid.n_cells_x) + " x " + std::to_string(c.grid.n_cells_y) + ")";
      const auto s = root.find("solver");
      if (s && s->has("shape_function")) s->at("shape_function").fail(message);
      root.at("grid").at("n_cells").fail(
          message + "; they are the default shape function: give solver.shape_function");
    }
    for (std::size_t k = 0; k < c.constraints.size(); ++k) {
      const int extra = boundary::gauss_points_for_degree(0, degree);
      if (c.constraints[k].part.quadrature.gauss_points + extra > boundary::kMaxGaussPoints) {
        root.at("constraints")
            .at(k)
            .at("gauss_points")
            .fail("with B-splines of degree " + std::to_string(degree) + " the rule takes " +
                  std::to_string(extra) + " points more: give at most " +
                  std::to_string(boundary::kMaxGaussPoints - extra));
      }
    }
    for (std::size_t k = 0; k < c.loads.size(); ++k) {
      const auto& surface = c.loads[k].surface;
      const int extra = boundary::gauss_points_for_degree(0, degree);
      if (surface && surface->quadrature.gauss_points + extra > boundary::kMaxGaussPoints) {
        root.at("loads")
            .at(k)
            .at("gauss_points")
            .fail("with B-splines of degree " + std::to_string(degree) + " the rule takes " +
                  std::to_string(extra) + " points more, and at most " +
                  std::to_string(boundary::kMaxGaussPoints) + " are available: give at most " +
                  std::to_string(boundary::kMaxGaussPoints - extra));
      }
    }
  }
}

/// The "implicit" block, only with solver.type "implicit".
void parse_implicit(const JsonView& root, Case& c) {
  const auto b = root.find("implicit");
  if (!b) return;
  if (c.solver.type != SolverType::kImplicit) b->fail("is read only with solver.type \"implicit\"");
  b->expect_object({"load_steps", "tolerance", "max_iterations", "max_cuts", "strength_reduction"});
  const auto integer = [&](const char* key, int& value, int least) {
    if (!b->has(key)) return;
    const double v = b->at(key).as_number();
    b->at(key).require(v == std::floor(v) && v >= least && v <= 1e6,
                       "must be a whole number from " + std::to_string(least) + " to 1e6");
    value = static_cast<int>(v);
  };
  integer("load_steps", c.implicit.load_steps, 1);
  integer("max_iterations", c.implicit.max_iterations, 1);
  integer("max_cuts", c.implicit.max_cuts, 0);
  c.implicit.tolerance = b->number_or("tolerance", c.implicit.tolerance);
  if (b->has("tolerance")) {
    b->at("tolerance")
        .require(c.implicit.tolerance > 0.0 && c.implicit.tolerance < 1.0, "must be in (0, 1)");
  }
  if (const auto r = b->find("strength_reduction")) {
    r->expect_object({"start_time", "final_factor"});
    StrengthReduction reduction;
    reduction.start_time = r->at("start_time").as_number();
    r->at("start_time")
        .require(reduction.start_time >= 0.0 && reduction.start_time < c.time.end_time,
                 "must be in [0, time.end_time)");
    reduction.final_factor = r->at("final_factor").as_number();
    r->at("final_factor")
        .require(reduction.final_factor > 1.0 && std::isfinite(reduction.final_factor),
                 "must be a number > 1");
    c.implicit.strength_reduction = reduction;
  }
}

/// The end time and the time step.
void parse_time(const JsonView& root, Case& c) {
  const JsonView t = root.at("time");
  t.expect_object({"end_time", "cfl", "dt", "max_steps"});
  c.time.end_time = t.at("end_time").as_number();
  t.at("end_time").require(c.time.end_time > 0.0, "must be > 0");
  c.time.cfl = t.number_or("cfl", 0.5);
  if (t.has("cfl")) t.at("cfl").require(c.time.cfl > 0.0 && c.time.cfl <= 1.0, "must be in (0, 1]");
  if (t.has("dt")) {
    c.time.dt = t.at("dt").as_number();
    t.at("dt").require(*c.time.dt > 0.0, "must be > 0");
  }
  c.time.max_steps = t.number_or("max_steps", c.time.max_steps);
  if (t.has("max_steps")) t.at("max_steps").require(c.time.max_steps >= 1.0, "must be >= 1");
}

/// The output intervals and formats (the default interval is a twentieth of the end time).
void parse_output(const JsonView& root, Case& c) {
  c.output.interval = c.time.end_time / 20.0;
  if (const auto o = root.find("output")) {
    o->expect_object({"interval", "timeseries_interval", "nodal_loads", "compression", "vtk"});
    if (const auto nodal = o->find("nodal_loads")) c.output.nodal_loads = nodal->as_bool();
    if (const auto vtk = o->find("vtk")) c.output.vtk = vtk->as_bool();
    c.output.compress = o->choice_or("compression", {"none", "gzip"}, "none") == "gzip";
    c.output.interval = o->number_or("interval", c.output.interval);
    c.output.interval_given = o->has("interval");
    if (o->has("interval")) o->at("interval").require(c.output.interval > 0.0, "must be > 0");
    c.output.timeseries_interval = o->number_or("timeseries_interval", c.output.interval / 10.0);
    c.output.timeseries_interval_given = o->has("timeseries_interval");
    if (o->has("timeseries_interval")) {
      o->at("timeseries_interval").require(c.output.timeseries_interval > 0.0, "must be > 0");
    }
  } else {
    c.output.timeseries_interval = c.output.interval / 10.0;
  }
}

/// The detection settings; a default detection where loads or constraints need the detected
/// boundary.
void parse_detection(const JsonView& root, Case& c) {
  if (const auto d = root.find("detection")) {
    d->require(d->is_object(), "expected an object");
    DetectionSpec detection;
    detection.every_steps = d->int_or("every_steps", 1);
    if (d->has("every_steps"))
      d->at("every_steps").require(detection.every_steps >= 1, "must be a whole number >= 1");
    detection.max_motion = d->number_or("max_motion", detection.max_motion);
    if (d->has("max_motion")) {
      d->at("max_motion")
          .require(detection.max_motion >= 0.0 && detection.max_motion <= 1.0,
                   "must be in [0, 1] (a fraction of the cell size)");
    }
    // The rest of the block is the detector configuration; errors keep their JSON pointers.
    nlohmann::json config = d->raw();
    config.erase("every_steps");
    config.erase("max_motion");
    detection.detector = parse_detector_config(JsonView(config, d->file(), d->pointer()));
    c.detection = std::move(detection);
  } else {
    for (std::size_t k = 0; k < c.loads.size(); ++k) {
      if (c.loads[k].apply_on == LoadTarget::kDetectedBoundary) {
        c.detection = DetectionSpec{};  // the improved detector, every step
        break;
      }
    }
    if (!c.constraints.empty()) c.detection = DetectionSpec{};
  }
}

}  // namespace

Case parse_case(const nlohmann::json& document, const std::string& file) {
  Case c;
  c.file = file;
  c.source = document;
  const JsonView root(document, file);
  root.expect_object({"title", "grid", "materials", "bodies", "gravity", "initial_stress",
                      "node_sets", "boundary_conditions", "loads", "constraints", "solver",
                      "implicit", "time", "output", "detection", "manufactured_solution"});
  if (root.has("title")) c.title = root.at("title").as_string();

  parse_grid(root, c);
  parse_materials(root, c);
  parse_bodies(root, c);
  check_memory(root, c);
  parse_gravity(root, c);
  parse_initial_stress(root, c);
  parse_node_sets(root, c);
  parse_boundary_conditions(root, c);
  parse_loads(root, c);
  parse_constraints(root, c);
  parse_solver(root, c);
  parse_time(root, c);
  parse_implicit(root, c);
  parse_output(root, c);
  parse_detection(root, c);
  if (const auto m = root.find("manufactured_solution")) parse_manufactured(*m, root, c);
  return c;
}

void check_run_length(const Case& c, double dt) {
  char text[320];
  const char* step_key = c.time.dt ? "/time/dt" : "/time/cfl";
  if (!(dt > 0.0) || !std::isfinite(dt)) {
    std::snprintf(text, sizeof text,
                  ": %s: the time step is %g s, not a positive number (check the materials' "
                  "stiffness and density: kPa and t/m^3)",
                  step_key, dt);
    throw InputError(c.file + text);
  }
  const double steps = c.time.end_time / dt;
  if (!(steps <= c.time.max_steps)) {
    std::snprintf(text, sizeof text,
                  ": /time/end_time: %g s takes %.3g steps of %g s, more than time.max_steps "
                  "(%.3g): a unit mistake? (raise time.max_steps for a run that long)",
                  c.time.end_time, steps, dt, c.time.max_steps);
    throw InputError(c.file + text);
  }
  if (!(steps > 1e-9)) {  // the drivers run ceil(end_time / dt - 1e-9) steps
    std::snprintf(text, sizeof text,
                  ": /time/end_time: %g s is not a time step's worth (the step is %g s, %s): the "
                  "run would take 0 steps (check the units: kPa, kN/m^3, m/s^2)",
                  c.time.end_time, dt, step_key);
    throw InputError(c.file + text);
  }
  // Particle outputs (HDF5) at every step are a mistake; the time series is recorded at most
  // once a step, so an interval a little below the step just asks for every step, while one a
  // hundred times below it asks for what no run can give.
  const auto at_least = [&](bool given, double interval, double least, const char* key,
                            const char* what) {
    if (!given || interval >= least) return;
    std::snprintf(text, sizeof text, ": %s: %g s is shorter than %s (the step is %g s, %s)", key,
                  interval, what, dt, step_key);
    throw InputError(c.file + text);
  };
  at_least(c.output.interval_given, c.output.interval, dt, "/output/interval", "the time step");
  at_least(c.output.timeseries_interval_given, c.output.timeseries_interval, 0.01 * dt,
           "/output/timeseries_interval", "a hundredth of the time step");
}

}  // namespace pfm

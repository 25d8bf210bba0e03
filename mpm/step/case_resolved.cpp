// resolved_case(): the validated case as JSON, every value resolved (case.hpp).
#include <cmath>
#include <numbers>
#include <variant>

#include "mpm/step/case.hpp"

namespace pfm {

namespace {

using nlohmann::json;

json point(const Vec2& v) {
  return json::array({v.x(), v.y()});
}

// A number, or null where the case has none (an optional, or infinity: "no limit").
json number_or_null(std::optional<double> v) {
  return v && std::isfinite(*v) ? json(*v) : json(nullptr);
}

json material_json(const MaterialRecord& m) {
  const ElasticParameters& elastic = elastic_parameters(m.model);
  json out = {{"name", m.name},
              {"youngs_modulus", elastic.youngs_modulus},
              {"poisson_ratio", elastic.poisson_ratio},
              {"unit_weight", m.unit_weight}};
  if (std::holds_alternative<LinearElastic>(m.model)) {
    out["model"] = "linear_elastic";
    return out;
  }
  out["cohesion"] = {{"plastic_strain", m.written_cohesion.x}, {"cohesion", m.written_cohesion.y}};
  out["softening_length"] = number_or_null(m.softening_length);
  if (const auto* mc = std::get_if<MohrCoulomb>(&m.model)) {
    out["model"] = "mohr_coulomb";
    out["friction_angle"] = mc->friction_angle_deg;
    out["dilation_angle"] = mc->dilation_angle_deg;
    out["tension_cutoff"] = number_or_null(mc->tension_cutoff);
  } else {
    out["model"] = "tresca";
  }
  return out;
}

json body_json(const BodySpec& b) {
  json polygon = json::array();
  for (const Vec2& v : b.polygon) polygon.push_back(point(v));
  const char* placement = b.placement == Placement::kGauss        ? "gauss"
                          : b.placement == Placement::kConforming ? "conforming"
                                                                  : "equal";
  return {{"name", b.name},
          {"material", b.material},
          {"source", b.from_file()         ? "particles"
                     : b.mesh_file.empty() ? "polygon"
                                           : "mesh"},
          {"polygon", polygon},
          {"points_per_cell", b.points_per_cell},
          {"placement", placement},
          {"mesh", b.mesh_file},
          {"physical_group", b.physical_group},
          {"n_points", b.point_position.size()}};
}

json time_function_json(const TimeFunction& f) {
  const char* type = f.kind == TimeFunctionKind::kRamp         ? "ramp"
                     : f.kind == TimeFunctionKind::kSmoothRamp ? "smooth_ramp"
                                                               : "constant";
  return {{"type", type}, {"ramp_time", f.ramp_time}};
}

json normal_json(const boundary::NormalWindow& w) {
  return {{"direction", point(w.direction)},
          {"max_angle", std::acos(w.min_cosine) * 180.0 / std::numbers::pi}};
}

json load_json(const LoadSpec& load) {
  json out = {{"type", load.type},
              {"apply_on", "grid_top_nodes"},
              {"pressure", load.pressure},
              {"traction", nullptr},
              {"x_range", point(Vec2(load.x0, load.x1))},
              {"faces", "top"},
              {"interval", "fixed"},
              {"time_function", time_function_json(load.time_function)}};
  if (!load.surface) return out;
  const boundary::BoundaryLoadSpec& s = *load.surface;
  out["apply_on"] = "detected_boundary";
  if (s.type == boundary::BoundaryLoadType::kTraction) {
    out["pressure"] = nullptr;
    out["traction"] = point(s.traction);
  }
  out["x_range"] = s.x_range ? point(*s.x_range) : json(nullptr);
  out["faces"] = s.faces == boundary::LoadedFaces::kTop      ? "top"
                 : s.faces == boundary::LoadedFaces::kUpward ? "upward"
                                                             : "all";
  out["interval"] = s.interval == boundary::LoadInterval::kMaterial ? "material" : "fixed";
  if (s.normal_window) out["normal"] = normal_json(*s.normal_window);
  return out;
}

json constraint_json(const ConstraintSpec& c) {
  const boundary::BoundaryLoadSpec& s = c.part;
  json out = {{"x_range", s.x_range ? point(*s.x_range) : json(nullptr)},
              {"faces", s.faces == boundary::LoadedFaces::kTop      ? "top"
                        : s.faces == boundary::LoadedFaces::kUpward ? "upward"
                                                                    : "all"},
              {"normal", nullptr},
              {"quantity", c.velocity ? "velocity" : "displacement"},
              {"normal_only", c.normal_only},
              {"value", c.normal_only ? json(c.value.x()) : point(c.value)},
              {"time_function", time_function_json(c.time_function)},
              {"method", "penalty"},
              {"penalty", c.penalty}};
  if (s.normal_window) out["normal"] = normal_json(*s.normal_window);
  return out;
}

const char* shape_function_name(ShapeFunctionKind kind) {
  switch (kind) {
    case ShapeFunctionKind::kLinear:
      return "linear";
    case ShapeFunctionKind::kGimp:
      return "gimp";
    case ShapeFunctionKind::kQuadraticBspline:
      return "quadratic_bspline";
    case ShapeFunctionKind::kCubicBspline:
      return "cubic_bspline";
  }
  return "linear";
}

}  // namespace

json resolved_case(const Case& c) {
  json out;
  out["title"] = c.title;
  out["file"] = c.file;
  out["grid"] = {{"origin", point(c.grid.origin)},
                 {"cell_size", c.grid.cell_size},
                 {"n_cells", {c.grid.n_cells_x, c.grid.n_cells_y}},
                 {"max_nodes", c.max_grid_nodes}};
  out["materials"] = json::array();
  for (const MaterialRecord& m : c.materials) out["materials"].push_back(material_json(m));
  out["bodies"] = json::array();
  for (const BodySpec& b : c.bodies) out["bodies"].push_back(body_json(b));
  out["gravity"] = {{"g", c.gravity.g}, {"ramp_time", c.gravity.ramp_time}};
  const InitialStressSpec& s = c.initial_stress;
  out["initial_stress"] = {{"method", s.method == InitialStressMethod::kK0        ? "k0"
                                      : s.method == InitialStressMethod::kGravity ? "gravity"
                                                                                  : "zero"},
                           {"k0", number_or_null(s.k0)},
                           {"kinetic_energy_ratio", s.kinetic_energy_ratio},
                           {"damping", s.damping},
                           {"max_time", s.max_time}};
  out["node_sets"] = json::array();
  for (const NodeSet& set : c.node_sets) {
    json segments = json::array();
    for (const auto& [a, b] : set.segments) segments.push_back({point(a), point(b)});
    out["node_sets"].push_back(
        {{"name", set.name},
         {"box", set.segments.empty() ? json{point(set.box_min), point(set.box_max)} : json()},
         {"mesh", set.mesh_file},
         {"physical_group", set.physical_group},
         {"segments", segments}});
  }
  out["boundary_conditions"] = json::array();
  for (const BoundaryCondition& bc : c.boundary_conditions) {
    const char* fix = bc.fix == kFixXY ? "xy" : bc.fix == kFixX ? "x" : "y";
    out["boundary_conditions"].push_back({{"where", bc.where},
                                          {"fix", fix},
                                          {"velocity", bc.moving ? point(bc.velocity) : json()},
                                          {"time_function", time_function_json(bc.time_function)}});
  }
  out["loads"] = json::array();
  for (const LoadSpec& load : c.loads) out["loads"].push_back(load_json(load));
  out["constraints"] = json::array();
  for (const ConstraintSpec& constraint : c.constraints)
    out["constraints"].push_back(constraint_json(constraint));
  out["solver"] = {
      {"type", c.solver.type == SolverType::kImplicit ? "implicit" : "explicit"},
      {"scheme", c.solver.scheme == Scheme::kUSL ? "usl" : "musl"},
      {"shape_function", shape_function_name(c.solver.shape_function)},
      {"damping", c.solver.damping},
      {"damping_form",
       c.solver.damping_form == DampingForm::kAlongVelocity ? "along_velocity" : "per_axis"},
      {"pic_fraction", c.solver.pic_fraction},
      {"xpic_order", c.solver.xpic_order},
      {"anti_locking", c.solver.mean_dilatation ? "bbar" : "none"}};
  out["implicit"] = nullptr;
  if (c.solver.type == SolverType::kImplicit) {
    out["implicit"] = {{"load_steps", c.implicit.load_steps},
                       {"tolerance", c.implicit.tolerance},
                       {"max_iterations", c.implicit.max_iterations},
                       {"max_cuts", c.implicit.max_cuts},
                       {"strength_reduction", nullptr}};
    if (const auto& r = c.implicit.strength_reduction) {
      out["implicit"]["strength_reduction"] = {{"start_time", r->start_time},
                                               {"final_factor", r->final_factor}};
    }
  }
  out["time"] = {{"end_time", c.time.end_time},
                 {"cfl", c.time.cfl},
                 {"dt", number_or_null(c.time.dt)},
                 {"max_steps", c.time.max_steps}};
  out["output"] = {{"interval", c.output.interval},
                   {"timeseries_interval", c.output.timeseries_interval},
                   {"nodal_loads", c.output.nodal_loads},
                   {"compression", c.output.compress ? "gzip" : "none"},
                   {"vtk", c.output.vtk}};
  out["detection"] = nullptr;
  if (c.detection) {
    out["detection"] = {{"every_steps", c.detection->every_steps},
                        {"max_motion", c.detection->max_motion},
                        {"method", detector_method_name(c.detection->detector.method)}};
  }
  out["manufactured_solution"] = c.manufactured.has_value();
  return out;
}

}  // namespace pfm

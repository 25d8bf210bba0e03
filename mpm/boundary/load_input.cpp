#include "mpm/boundary/load_input.hpp"

#include <cmath>
#include <numbers>
#include <string>

namespace pfm::boundary {

BoundaryLoadSpec parse_boundary_load(const pfm::JsonView& entry) {
  entry.expect_object({"apply_on", "type", "pressure", "traction", "x_range", "faces", "curve",
                       "integration", "gauss_points", "split_at_cell_edges", "scale_eq_6_15",
                       "redistribute_lost_load", "min_node_mass_fraction", "interval", "normal",
                       "time_function"});
  entry.at("apply_on").as_choice({"detected_boundary"});
  BoundaryLoadSpec spec;
  const std::string type =
      entry.at("type").as_choice({"vertical_pressure", "follower_pressure", "traction"});
  if (type == "vertical_pressure") {
    spec.type = BoundaryLoadType::kVerticalPressure;
    const JsonView pressure = entry.at("pressure");
    spec.pressure = pressure.as_number();
    pressure.require(spec.pressure >= 0.0, "must be >= 0 (kPa, acting downwards)");
  } else if (type == "follower_pressure") {
    spec.type = BoundaryLoadType::kFollowerPressure;
    spec.pressure = entry.at("pressure").as_number();
  } else {
    spec.type = BoundaryLoadType::kTraction;
    spec.traction = entry.at("traction").as_vec2();
  }
  if (spec.type == BoundaryLoadType::kTraction && entry.has("pressure")) {
    entry.at("pressure").fail("not used by type \"traction\" (give \"traction\")");
  }
  if (spec.type != BoundaryLoadType::kTraction && entry.has("traction")) {
    entry.at("traction").fail("only used by type \"traction\"");
  }
  const bool vertical = spec.type == BoundaryLoadType::kVerticalPressure;
  parse_boundary_part(entry, vertical, vertical ? "top" : "all", spec);
  const bool thesis = entry.choice_or("integration", {"exact", "thesis"}, "exact") == "thesis";
  spec.quadrature.mode = thesis ? IntegrationMode::kThesis : IntegrationMode::kExact;
  spec.quadrature.gauss_points = entry.int_or("gauss_points", 5);
  if (spec.quadrature.gauss_points < 1 || spec.quadrature.gauss_points > kMaxGaussPoints) {
    entry.at("gauss_points").fail("must be in 1.." + std::to_string(kMaxGaussPoints));
  }
  auto bool_or = [&](std::string_view key, bool fallback) {
    const auto value = entry.find(key);
    return value ? value->as_bool() : fallback;
  };
  spec.quadrature.split_at_cell_edges = bool_or("split_at_cell_edges", !thesis);
  spec.quadrature.scale_eq_6_15 = bool_or("scale_eq_6_15", false);
  spec.redistribute_lost_load = bool_or("redistribute_lost_load", true);
  if (const auto fraction = entry.find("min_node_mass_fraction")) {
    spec.min_node_mass_fraction = fraction->as_number();
    fraction->require(spec.min_node_mass_fraction >= 0.0 && spec.min_node_mass_fraction < 1.0,
                      "must be in [0, 1) (a fraction of a full cell's mass)");
  }
  return spec;
}

void parse_boundary_part(const pfm::JsonView& entry, bool x_range_required,
                         const char* default_faces, BoundaryLoadSpec& spec) {
  if (x_range_required || entry.has("x_range")) {
    const JsonView range = entry.at("x_range");
    const Vec2 x_range = range.as_vec2();
    range.require(x_range.x() < x_range.y(), "must be [x0, x1] with x0 < x1 (m)");
    spec.x_range = x_range;
  }
  const std::string faces = entry.choice_or("faces", {"top", "upward", "all"}, default_faces);
  spec.faces = faces == "top"      ? LoadedFaces::kTop
               : faces == "upward" ? LoadedFaces::kUpward
                                   : LoadedFaces::kAll;
  if (const auto normal = entry.find("normal")) {
    normal->expect_object({"direction", "max_angle"});
    NormalWindow window;
    const Vec2 direction = normal->at("direction").as_vec2();
    normal->at("direction").require(direction.norm() > 0.0, "must be a nonzero [nx, ny]");
    window.direction = direction.normalized();
    const double angle = normal->at("max_angle").as_number();
    normal->at("max_angle").require(angle > 0.0 && angle <= 180.0, "must be in (0, 180] (degrees)");
    window.min_cosine = std::cos(angle * std::numbers::pi / 180.0);
    spec.normal_window = window;
  }
  spec.curve = curve_kind_from_name(
      entry.choice_or("curve", {"linear", "quadratic", "cubic", "catmull_rom"}, "linear"));
  spec.interval = entry.choice_or("interval", {"fixed", "material"}, "fixed") == "fixed"
                      ? LoadInterval::kFixed
                      : LoadInterval::kMaterial;
  if (spec.interval == LoadInterval::kMaterial && !spec.x_range)
    entry.at("interval").fail("\"material\" moves the ends of x_range: give x_range");
}

}  // namespace pfm::boundary

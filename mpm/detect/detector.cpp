#include "mpm/detect/detector.hpp"

#include <cmath>
#include <string>

#include "mpm/detect/detect_internal.hpp"

namespace pfm {

namespace detail {

void check_cloud_shape(const ParticleCloud& cloud) {
  const std::size_t n = cloud.position.size();
  if (cloud.volume.size() != n) {
    throw InputError("particle cloud: " + std::to_string(cloud.volume.size()) + " volumes for " +
                     std::to_string(n) + " positions");
  }
  if (!cloud.deformation_gradient.empty() && cloud.deformation_gradient.size() != n) {
    throw InputError("particle cloud: " + std::to_string(cloud.deformation_gradient.size()) +
                     " deformation gradients for " + std::to_string(n) + " positions");
  }
  if (!(cloud.initial_spacing > 0.0) || !std::isfinite(cloud.initial_spacing)) {
    throw InputError("particle cloud: initial_spacing must be finite and > 0");
  }
}

void check_particle(const ParticleCloud& cloud, std::size_t p) {
  if (!cloud.position[p].allFinite() || !std::isfinite(cloud.volume[p]) || cloud.volume[p] <= 0.0) {
    throw InputError("particle cloud: particle " + std::to_string(p) +
                     " has a non-finite position or a volume <= 0");
  }
  if (!cloud.deformation_gradient.empty() &&
      (!cloud.deformation_gradient[p].allFinite() ||
       !(cloud.deformation_gradient[p].determinant() > 0.0))) {
    throw InputError("particle cloud: particle " + std::to_string(p) +
                     " has a deformation gradient with det F <= 0 or non-finite entries");
  }
}

void check_cloud(const ParticleCloud& cloud) {
  check_cloud_shape(cloud);
  for (std::size_t p = 0; p < cloud.position.size(); ++p) check_particle(cloud, p);
}

}  // namespace detail

namespace {

KernelDeformation parse_deformation(const JsonView& v) {
  const std::string s = v.as_choice({"none", "small_strain", "large_strain"});
  if (s == "small_strain") return KernelDeformation::kSmallStrain;
  if (s == "large_strain") return KernelDeformation::kLargeStrain;
  return KernelDeformation::kNone;
}

ThesisPfmConfig parse_pfm(const JsonView& v) {
  v.expect_object({"kernel_factor", "contour_level", "refinement", "negative_outside",
                   "deformation", "min_size_factor", "max_size_factor", "edge_location",
                   "bisection_steps", "bisection_tolerance", "remove_vertex_holes",
                   "gaussian_sigma", "gaussian_size", "median_weights"});
  ThesisPfmConfig c;
  c.kernel_factor = v.number_or("kernel_factor", c.kernel_factor);
  if (v.has("kernel_factor")) v.at("kernel_factor").require(c.kernel_factor > 0.0, "must be > 0");
  c.contour_level = v.number_or("contour_level", c.contour_level);
  c.refinement = v.int_or("refinement", c.refinement);
  if (v.has("refinement")) {
    v.at("refinement").require(c.refinement >= 1 && c.refinement <= 64, "must be in [1, 64]");
  }
  if (v.has("negative_outside")) c.negative_outside = v.at("negative_outside").as_bool();
  if (v.has("deformation")) c.deformation = parse_deformation(v.at("deformation"));
  c.min_size_factor = v.number_or("min_size_factor", c.min_size_factor);
  if (v.has("min_size_factor")) {
    v.at("min_size_factor")
        .require(c.min_size_factor >= 0.0 && c.min_size_factor < 1.0, "must be in [0, 1)");
  }
  c.max_size_factor = v.number_or("max_size_factor", c.max_size_factor);
  if (v.has("max_size_factor")) {
    v.at("max_size_factor")
        .require(c.max_size_factor == 0.0 || c.max_size_factor > 1.0, "must be 0 (off) or > 1");
  }
  if (v.has("edge_location")) {
    c.edge_location =
        v.at("edge_location").as_choice({"bisection", "shape_functions"}) == "bisection"
            ? EdgeLocation::kBisection
            : EdgeLocation::kShapeFunctions;
  }
  c.bisection_steps = v.int_or("bisection_steps", c.bisection_steps);
  if (v.has("bisection_steps")) {
    v.at("bisection_steps").require(c.bisection_steps >= 1, "must be >= 1");
  }
  c.bisection_tolerance = v.number_or("bisection_tolerance", c.bisection_tolerance);
  if (v.has("bisection_tolerance")) {
    v.at("bisection_tolerance").require(c.bisection_tolerance >= 0.0, "must be >= 0");
  }
  if (v.has("remove_vertex_holes")) c.remove_vertex_holes = v.at("remove_vertex_holes").as_bool();
  c.gaussian_sigma = v.number_or("gaussian_sigma", c.gaussian_sigma);
  if (v.has("gaussian_sigma")) {
    v.at("gaussian_sigma").require(c.gaussian_sigma >= 0.0, "must be >= 0 (0 = off)");
  }
  c.gaussian_size = v.int_or("gaussian_size", c.gaussian_size);
  if (v.has("gaussian_size")) {
    v.at("gaussian_size")
        .require(c.gaussian_size == 0 || (c.gaussian_size > 0 && c.gaussian_size % 2 == 1),
                 "must be 0 (eq. 5.7) or a positive odd number");
  }
  if (v.has("median_weights")) {
    const JsonView w = v.at("median_weights");
    w.require(w.is_array() && w.array_size() == 3, "must be [a, b, c] (centre, edge, corner)");
    for (std::size_t k = 0; k < 3; ++k) {
      c.median_weights[k] = w.at(k).as_int();
      w.at(k).require(c.median_weights[k] >= 0, "must be >= 0");
    }
  }
  return c;
}

ImprovedConfig parse_improved(const JsonView& v) {
  v.expect_object({"profile", "radius_factor", "level", "guard_factor", "guard_margin",
                   "refinement", "max_refinement", "saddle_rule", "narrow_band", "band_margin",
                   "root_tolerance", "curvature_correction", "mirror_grid_edges", "neighbour_shape",
                   "max_stretch", "spurious_loops"});
  ImprovedConfig c;
  if (v.has("profile")) {
    const std::string p = v.at("profile").as_choice({"epanechnikov", "biweight", "triweight"});
    c.profile = p == "epanechnikov" ? KernelProfile::kEpanechnikov
                : p == "biweight"   ? KernelProfile::kBiweight
                                    : KernelProfile::kTriweight;
  }
  c.radius_factor = v.number_or("radius_factor", c.radius_factor);
  if (v.has("radius_factor")) v.at("radius_factor").require(c.radius_factor > 0.0, "must be > 0");
  c.level = v.number_or("level", c.level);
  if (v.has("level")) v.at("level").require(c.level > 0.0 && c.level < 1.0, "must be in (0, 1)");
  c.guard_factor = v.number_or("guard_factor", c.guard_factor);
  if (v.has("guard_factor")) {
    v.at("guard_factor")
        .require(c.guard_factor >= 0.0 && c.guard_factor <= 1.0, "must be in [0, 1] (0 = off)");
  }
  c.guard_margin = v.number_or("guard_margin", c.guard_margin);
  if (v.has("guard_margin")) v.at("guard_margin").require(c.guard_margin >= 0.0, "must be >= 0");
  c.refinement = v.int_or("refinement", c.refinement);
  if (v.has("refinement")) {
    v.at("refinement").require(c.refinement >= 0 && c.refinement <= 64, "must be in [0, 64]");
  }
  c.max_refinement = v.int_or("max_refinement", c.max_refinement);
  if (v.has("max_refinement")) {
    v.at("max_refinement")
        .require(c.max_refinement >= 1 && c.max_refinement <= 64, "must be in [1, 64]");
  }
  if (v.has("saddle_rule")) {
    c.saddle_rule = v.at("saddle_rule").as_choice({"asymptotic_decider", "centre_sample"}) ==
                            "asymptotic_decider"
                        ? SaddleRule::kAsymptoticDecider
                        : SaddleRule::kCentreSample;
  }
  if (v.has("narrow_band")) c.narrow_band = v.at("narrow_band").as_bool();
  c.band_margin = v.number_or("band_margin", c.band_margin);
  if (v.has("band_margin")) v.at("band_margin").require(c.band_margin >= 0.0, "must be >= 0");
  c.root_tolerance = v.number_or("root_tolerance", c.root_tolerance);
  if (v.has("root_tolerance")) {
    v.at("root_tolerance")
        .require(c.root_tolerance > 0.0 && c.root_tolerance < 0.5, "must be in (0, 0.5)");
  }
  if (v.has("curvature_correction")) {
    c.curvature_correction = v.at("curvature_correction").as_bool();
  }
  if (v.has("mirror_grid_edges")) c.mirror_grid_edges = v.at("mirror_grid_edges").as_bool();
  c.neighbour_shape = v.number_or("neighbour_shape", c.neighbour_shape);
  if (v.has("neighbour_shape")) {
    v.at("neighbour_shape")
        .require(c.neighbour_shape >= 0.0 && c.neighbour_shape <= 0.9,
                 "must be in [0, 0.9] (0 = off)");
  }
  c.max_stretch = v.number_or("max_stretch", c.max_stretch);
  if (v.has("max_stretch")) {
    v.at("max_stretch")
        .require(c.max_stretch == 0.0 || c.max_stretch >= 1.0, "must be >= 1 (0 = no cap)");
  }
  if (v.has("spurious_loops")) {
    c.join_spurious_loops = v.at("spurious_loops").as_choice({"join", "keep"}) == "join";
  }
  return c;
}

SmmConfig parse_smm(const JsonView& v) {
  v.expect_object({"marker_spacing", "initial_contour", "massless_nodes"});
  SmmConfig c;
  c.marker_spacing = v.number_or("marker_spacing", c.marker_spacing);
  if (v.has("marker_spacing")) {
    v.at("marker_spacing")
        .require(c.marker_spacing > 0.0 && c.marker_spacing <= 100.0,
                 "must be in (0, 100] (grid cells)");
  }
  if (v.has("initial_contour")) {
    c.initial_contour = v.at("initial_contour").as_choice({"improved", "pfm"}) == "pfm"
                            ? DetectorMethod::kPfm
                            : DetectorMethod::kImproved;
  }
  if (v.has("massless_nodes")) {
    c.massless_nodes = v.at("massless_nodes").as_choice({"renormalise", "zero"}) == "zero"
                           ? MasslessNodes::kZero
                           : MasslessNodes::kRenormalise;
  }
  return c;
}

VofConfig parse_vof(const JsonView& v) {
  v.expect_object({"refinement", "fraction", "mixed_tolerance"});
  VofConfig c;
  c.refinement = v.int_or("refinement", c.refinement);
  if (v.has("refinement")) {
    v.at("refinement").require(c.refinement >= 1 && c.refinement <= 64, "must be in [1, 64]");
  }
  if (v.has("fraction")) {
    c.fraction = v.at("fraction").as_choice({"volume", "count"}) == "count" ? VofFraction::kCount
                                                                            : VofFraction::kVolume;
  }
  c.mixed_tolerance = v.number_or("mixed_tolerance", c.mixed_tolerance);
  if (v.has("mixed_tolerance")) {
    v.at("mixed_tolerance")
        .require(c.mixed_tolerance >= 0.0 && c.mixed_tolerance < 0.5, "must be in [0, 0.5)");
  }
  return c;
}

DensityConfig parse_density(const JsonView& v) {
  v.expect_object({"field", "threshold", "refinement"});
  DensityConfig c;
  if (v.has("field")) {
    c.field = v.at("field").as_choice({"nodal", "cell"}) == "cell" ? DensityField::kCell
                                                                   : DensityField::kNodal;
  }
  c.threshold = v.number_or("threshold", c.threshold);
  if (v.has("threshold")) {
    v.at("threshold").require(c.threshold > 0.0 && c.threshold < 1.0, "must be in (0, 1)");
  }
  c.refinement = v.int_or("refinement", c.refinement);
  if (v.has("refinement")) {
    v.at("refinement").require(c.refinement >= 1 && c.refinement <= 64, "must be in [1, 64]");
  }
  return c;
}

}  // namespace

const char* detector_method_name(DetectorMethod method) {
  switch (method) {
    case DetectorMethod::kPfm:
      return "pfm";
    case DetectorMethod::kImproved:
      return "improved";
    case DetectorMethod::kSmm:
      return "smm";
    case DetectorMethod::kVof:
      return "vof";
    case DetectorMethod::kDensity:
      return "density";
  }
  return "?";
}

DetectorConfig parse_detector_config(const JsonView& json) {
  json.expect_object({"method", "pfm", "improved", "smm", "vof", "density"});
  DetectorConfig config;
  constexpr DetectorMethod kMethods[] = {DetectorMethod::kPfm, DetectorMethod::kImproved,
                                         DetectorMethod::kSmm, DetectorMethod::kVof,
                                         DetectorMethod::kDensity};
  const std::string method =
      json.choice_or("method", {"pfm", "improved", "smm", "vof", "density"}, "improved");
  for (const DetectorMethod m : kMethods) {
    if (method == detector_method_name(m)) config.method = m;
  }
  if (const auto v = json.find("pfm")) config.pfm = parse_pfm(*v);
  if (const auto v = json.find("improved")) config.improved = parse_improved(*v);
  if (const auto v = json.find("smm")) config.smm = parse_smm(*v);
  if (const auto v = json.find("vof")) config.vof = parse_vof(*v);
  if (const auto v = json.find("density")) config.density = parse_density(*v);
  return config;
}

DetectedBoundary detect(const ParticleCloud& cloud, const Grid& grid, const DetectorConfig& config,
                        DetectorState& state, DetectionTimings* timings) {
  // The improved detector checks every particle in its own first sweep over the cloud.
  if (config.method == DetectorMethod::kImproved) {
    detail::check_cloud_shape(cloud);
  } else {
    detail::check_cloud(cloud);
  }
  if (!(grid.cell_size > 0.0) || grid.n_cells_x < 1 || grid.n_cells_y < 1) {
    throw InputError("detect: the field grid needs cell_size > 0 and at least one cell");
  }
  DetectionTimings local;
  DetectionTimings& t = timings != nullptr ? *timings : local;
  t = DetectionTimings{};
  switch (config.method) {
    case DetectorMethod::kImproved:
      return config.improved.narrow_band
                 ? detail::detect_improved(cloud, grid, config.improved, t)
                 : detail::detect_improved_reference(cloud, grid, config.improved, t);
    case DetectorMethod::kPfm:
      return detail::detect_thesis_pfm(cloud, grid, config.pfm, state, t);
    case DetectorMethod::kSmm:
      return detail::detect_surface_markers(cloud, grid, config, state, t);
    case DetectorMethod::kVof:
      return detail::detect_volume_of_fluid(cloud, grid, config.vof, t);
    case DetectorMethod::kDensity:
      return detail::detect_cell_density(cloud, grid, config.density, t);
  }
  throw InputError("detect: unknown detector method");
}

}  // namespace pfm

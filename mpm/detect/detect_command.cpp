#include "mpm/detect/detect_command.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "mpm/core/json_input.hpp"
#include "mpm/core/output_folder.hpp"
#include "mpm/core/provenance.hpp"
#include "mpm/detect/detector.hpp"
#include "mpm/detect/loop_classes.hpp"

namespace pfm {

namespace {

// The detection grid holds fields only (no solver arrays): at most 5e7 nodes.
constexpr double kMaxGridNodes = 5e7;

std::string trim(const std::string& s) {
  const auto begin = s.find_first_not_of(" \t\r");
  if (begin == std::string::npos) return "";
  const auto end = s.find_last_not_of(" \t\r");
  return s.substr(begin, end - begin + 1);
}

std::vector<std::string> split(const std::string& line) {
  std::vector<std::string> fields;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, ',')) fields.push_back(trim(field));
  if (!line.empty() && line.back() == ',') fields.emplace_back();
  return fields;
}

}  // namespace

Grid parse_detection_grid(const JsonView& g) {
  g.expect_object({"origin", "cell_size", "n_cells"});
  Grid grid;
  grid.origin = g.at("origin").as_vec2();
  grid.cell_size = g.at("cell_size").as_number();
  g.at("cell_size").require(grid.cell_size > 0.0, "must be > 0 (m)");
  const JsonView n = g.at("n_cells");
  n.require(n.is_array() && n.array_size() == 2, "must be [nx, ny]");
  grid.n_cells_x = n.at(0).as_int();
  grid.n_cells_y = n.at(1).as_int();
  n.require(grid.n_cells_x >= 1 && grid.n_cells_y >= 1, "must be >= 1");
  n.require((grid.n_cells_x + 1.0) * (grid.n_cells_y + 1.0) <= kMaxGridNodes,
            "more than 5e7 grid nodes");
  return grid;
}

ParticleTable read_particle_csv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path + ": cannot open file");
  std::string line;
  int line_number = 0;
  std::vector<std::string> header;
  while (std::getline(in, line)) {
    ++line_number;
    const std::string t = trim(line);
    if (t.empty() || t[0] == '#') continue;
    header = split(t);
    break;
  }
  if (header.empty()) throw InputError(path + ": file is empty, expected a header line x,y,volume");
  const auto column = [&](const char* name) {
    const auto it = std::find(header.begin(), header.end(), name);
    return it == header.end() ? -1 : static_cast<int>(it - header.begin());
  };
  const int cx = column("x"), cy = column("y"), cv = column("volume");
  for (const auto& [index, name] :
       {std::pair{cx, "x"}, std::pair{cy, "y"}, std::pair{cv, "volume"}}) {
    if (index < 0) {
      throw InputError(path + ":" + std::to_string(line_number) + ": missing column \"" + name +
                       "\" in the header (need x, y, volume; optional F11, F12, F21, F22)");
    }
  }
  const int cf[4] = {column("F11"), column("F12"), column("F21"), column("F22")};
  const int n_f = static_cast<int>(std::count_if(cf, cf + 4, [](int c) { return c >= 0; }));
  if (n_f != 0 && n_f != 4) {
    throw InputError(path + ":" + std::to_string(line_number) +
                     ": deformation gradient columns must be all of F11, F12, F21, F22 or none");
  }
  const int cs[4] = {column("sxx"), column("syy"), column("sxy"), column("szz")};
  const int n_s = static_cast<int>(std::count_if(cs, cs + 4, [](int c) { return c >= 0; }));
  if (n_s != 0 && n_s != 4) {
    throw InputError(path + ":" + std::to_string(line_number) +
                     ": stress columns must be all of sxx, syy, sxy, szz or none");
  }
  const int cm = column("material");
  ParticleTable table;
  while (std::getline(in, line)) {
    ++line_number;
    const std::string t = trim(line);
    if (t.empty() || t[0] == '#') continue;
    const auto fields = split(t);
    const std::string where = path + ":" + std::to_string(line_number);
    if (fields.size() != header.size()) {
      throw InputError(where + ": " + std::to_string(fields.size()) + " fields, the header has " +
                       std::to_string(header.size()));
    }
    const auto number = [&](int c) {
      const std::string& f = fields[c];
      double value = 0.0;
      const auto result = std::from_chars(f.data(), f.data() + f.size(), value);
      if (f.empty() || result.ec != std::errc() || result.ptr != f.data() + f.size()) {
        throw InputError(where + ": column " + header[c] + ": \"" + f + "\" is not a number");
      }
      if (!std::isfinite(value)) {
        throw InputError(where + ": column " + header[c] + ": must be finite, got " + f);
      }
      return value;
    };
    table.position.emplace_back(number(cx), number(cy));
    const double volume = number(cv);
    if (!(volume > 0.0)) throw InputError(where + ": column volume: must be > 0");
    table.volume.push_back(volume);
    if (n_f == 4) {
      // All four first: number() throwing inside Eigen's comma initializer trips its "too few
      // coefficients" assertion (an abort instead of InputError in builds with assertions).
      const double f11 = number(cf[0]), f12 = number(cf[1]), f21 = number(cf[2]),
                   f22 = number(cf[3]);
      Mat2 f;
      f << f11, f12, f21, f22;
      if (!(f.determinant() > 0.0)) {
        throw InputError(where + ": columns F11..F22: det F must be > 0");
      }
      table.deformation_gradient.push_back(f);
    }
    if (n_s == 4) {
      table.stress.emplace_back(number(cs[0]), number(cs[1]), number(cs[2]), number(cs[3]));
    }
    if (cm >= 0) {
      const double m = number(cm);
      if (!(m >= 0.0 && m == std::floor(m) && m < 1e9)) {
        throw InputError(where +
                         ": column material: must be a whole number >= 0 (an index "
                         "into the case's materials)");
      }
      table.material.push_back(static_cast<int>(m));
    }
  }
  if (table.position.empty()) throw InputError(path + ": no particle rows after the header");
  return table;
}

int run_detect_command(const std::string& particles_csv, const std::string& config_json,
                       const std::string& out_dir, int threads, const std::string& command_line,
                       bool overwrite) {
  if (threads < 0) throw InputError("--threads: expected a count >= 1 (0: every core)");
  // 1. Input: configuration, then particles; nothing is created before both are valid.
  nlohmann::json json = read_json_file(config_json);
  const JsonView root(json, config_json);
  root.require(root.is_object(), "expected an object");
  nlohmann::json detector_json = json;
  detector_json.erase("grid");
  detector_json.erase("initial_spacing");
  const DetectorConfig config = parse_detector_config(JsonView(detector_json, config_json));
  const ParticleTable table = read_particle_csv(particles_csv);
  std::vector<std::string> warnings;
  if (table.deformation_gradient.empty()) {
    warnings.push_back(particles_csv +
                       ": no F11..F22 columns: every particle's F is taken as the identity (the "
                       "kernels of a deformed body then keep their reference shape)");
    std::cerr << "pfm-mpm detect: warning: " << warnings.back() << "\n";
  }

  double spacing = 0.0;
  if (const auto v = root.find("initial_spacing")) {
    spacing = v->as_number();
    v->require(spacing > 0.0, "must be > 0 (m)");
  } else {
    std::vector<double> volumes = table.volume;
    std::nth_element(volumes.begin(), volumes.begin() + volumes.size() / 2, volumes.end());
    spacing = std::sqrt(volumes[volumes.size() / 2]);
  }
  Grid grid;
  if (const auto g = root.find("grid")) {
    grid = parse_detection_grid(*g);
    const Vec2 lo = grid.origin, hi = grid.upper_corner();  // no int casts: x may be 1e300
    const bool any_inside =
        std::any_of(table.position.begin(), table.position.end(), [&](const Vec2& p) {
          return p.x() >= lo.x() && p.y() >= lo.y() && p.x() <= hi.x() && p.y() <= hi.y();
        });
    g->require(any_inside, "every particle of " + particles_csv + " lies outside the grid");
  } else {
    grid.cell_size = 2.0 * spacing;
    Vec2 lo = table.position[0], hi = table.position[0];
    for (const auto& p : table.position) {
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    double stretch = 1.0;
    for (const auto& f : table.deformation_gradient) stretch = std::max(stretch, f.norm());
    const double radius = std::max(config.improved.radius_factor,
                                   0.5 * config.pfm.kernel_factor * config.pfm.max_size_factor);
    const double margin = radius * spacing * stretch + grid.cell_size;
    const double h = grid.cell_size;
    grid.origin =
        Vec2(std::floor((lo.x() - margin) / h) * h, std::floor((lo.y() - margin) / h) * h);
    const double nx = std::ceil((hi.x() + margin - grid.origin.x()) / h);
    const double ny = std::ceil((hi.y() + margin - grid.origin.y()) / h);
    if (!((nx + 1.0) * (ny + 1.0) <= kMaxGridNodes)) {
      throw InputError(particles_csv + ": the particles span " + std::to_string(hi.x() - lo.x()) +
                       " x " + std::to_string(hi.y() - lo.y()) + " m at a spacing of " +
                       std::to_string(spacing) +
                       " m: the automatic grid would have more than 5e7 nodes (give \"grid\" "
                       "or \"initial_spacing\" in " +
                       config_json + ")");
    }
    grid.n_cells_x = static_cast<int>(nx);
    grid.n_cells_y = static_cast<int>(ny);
  }

  // 2. Detection.
  nlohmann::json made =
      provenance({{"particles_file", particles_csv}, {"config_file", config_json}}, command_line,
                 use_threads(threads));
  const ParticleCloud cloud{table.position, table.volume, table.deformation_gradient, spacing};
  DetectorState state;
  DetectionTimings timings;
  const DetectedBoundary boundary = detect(cloud, grid, config, state, &timings);

  // 3. Output.
  const std::string csv = boundary_csv(boundary);
  nlohmann::json points_per_loop = nlohmann::json::array(), closed = nlohmann::json::array();
  int n_closed = 0;
  for (const Contour& contour : boundary.contours) {
    points_per_loop.push_back(contour.points.size());
    closed.push_back(contour.closed);
    n_closed += contour.closed ? 1 : 0;
  }
  const LoopClasses classes = classify_loops(boundary, table.position, spacing);
  nlohmann::json class_of_loop = nlohmann::json::array();
  for (const LoopClass c : classes.of_loop) class_of_loop.push_back(loop_class_name(c));
  made["finished_utc"] = utc_now();
  nlohmann::json summary = {
      {"provenance", made},
      {"warnings", warnings},
      {"method", detector_method_name(config.method)},
      {"particles", table.position.size()},
      {"initial_spacing", spacing},
      {"grid",
       {{"origin", {grid.origin.x(), grid.origin.y()}},
        {"cell_size", grid.cell_size},
        {"n_cells", {grid.n_cells_x, grid.n_cells_y}}}},
      {"refinement", timings.refinement},
      {"loops", boundary.contours.size()},
      {"closed", n_closed},
      {"open", static_cast<int>(boundary.contours.size()) - n_closed},
      {"points_per_loop", points_per_loop},
      {"loop_closed", closed},
      {"class_of_loop", class_of_loop},
      {"timings_s",
       {{"field", timings.field},
        {"edge_points", timings.edge_points},
        {"connection", timings.connection},
        {"filters", timings.filters}}},
      {"field_evaluations", timings.field_evaluations},
      {"edge_points", timings.edge_point_count},
  };
  for (const auto& [name, count] : classes.counts()) summary["loop_classes"][name] = count;
  if (config.method == DetectorMethod::kImproved) {
    const auto& parts = timings.field_parts;
    summary["timings_s"]["field_parts"] = {{"survey", parts.survey}, {"band", parts.band},
                                           {"setup", parts.setup},   {"screening", parts.screening},
                                           {"guards", parts.guards}, {"nodes", parts.nodes},
                                           {"shape", parts.shape}};
    summary["particles_guarded_after_contouring"] = timings.particles_guarded_after_contouring;
    summary["particles_outside_first_contours"] = timings.particles_outside_first_contours;
    summary["bridges"] = timings.bridges;
    summary["guard_refinement_passes"] = timings.guard_refinement_passes;
    summary["spurious_loops_removed"] = timings.spurious_loops_removed;
  }
  OutputFolder folder(out_dir,
                      overwrite ? OutputFolder::Mode::kOverwrite : OutputFolder::Mode::kNew);
  write_file_atomically(folder.file("boundary.csv"), csv);
  write_file_atomically(folder.file("summary.json"), summary.dump(2) + "\n");
  return 0;
}

}  // namespace pfm

#include "fuzz_harness.hpp"

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <vector>

#include "mpm/boundary/load_input.hpp"
#include "mpm/core/json_input.hpp"
#include "mpm/detect/detect_command.hpp"
#include "mpm/detect/detector.hpp"
#include "mpm/solver/case.hpp"

namespace pfm::fuzz {

namespace {

void check(bool condition, const std::string& path, const char* what) {
  if (!condition) throw InvariantViolation(path + ": accepted input breaks: " + what);
}

bool finite(const Vec2& v) {
  return std::isfinite(v.x()) && std::isfinite(v.y());
}

void check_case(const Case& c, const std::string& path) {
  const Grid& g = c.grid;
  check(std::isfinite(g.cell_size) && g.cell_size > 0.0, path, "cell_size finite and > 0");
  check(finite(g.origin), path, "grid origin finite");
  check(g.n_cells_x >= 1 && g.n_cells_y >= 1, path, "n_cells >= 1");
  check(static_cast<long long>(g.n_cells_x) + 1 <= 50'000'001LL &&
            (static_cast<long long>(g.n_cells_x) + 1) * (static_cast<long long>(g.n_cells_y) + 1) <=
                50'000'000LL,
        path, "at most 5e7 grid nodes");
  check(!c.materials.empty(), path, "at least one material");
  check(!c.bodies.empty(), path, "at least one body");
  const Vec2 lo = g.origin, hi = g.upper_corner();
  for (const BodySpec& b : c.bodies) {
    check(b.material >= 0 && b.material < static_cast<int>(c.materials.size()), path,
          "body material index in range");
    check(b.polygon.size() >= 3, path, "body polygon has >= 3 vertices");
    check(b.points_per_cell >= 1 && b.points_per_cell <= 8, path, "points_per_cell in 1..8");
    for (const Vec2& v : b.polygon) {
      check(finite(v), path, "polygon vertices finite");
      check(v.x() >= lo.x() && v.y() >= lo.y() && v.x() <= hi.x() && v.y() <= hi.y(), path,
            "polygon vertices inside the grid");
    }
    check(polygon_signed_area(b.polygon) > 0.0, path, "polygon counter-clockwise, area > 0");
  }
  check(std::isfinite(c.time.end_time) && c.time.end_time > 0.0, path, "end_time > 0");
  check(c.time.cfl > 0.0 && c.time.cfl <= 1.0, path, "cfl in (0, 1]");
  check(!c.time.dt || (std::isfinite(*c.time.dt) && *c.time.dt > 0.0), path, "dt > 0");
  check(std::isfinite(c.output.interval) && c.output.interval > 0.0, path, "output interval > 0");
  check(std::isfinite(c.output.timeseries_interval) && c.output.timeseries_interval > 0.0, path,
        "timeseries interval > 0");
  check(std::isfinite(c.gravity.g) && c.gravity.g >= 0.0, path, "g >= 0");
  for (const LoadSpec& load : c.loads) {
    if (load.apply_on == LoadTarget::kGridTopNodes) {
      check(load.x0 < load.x1 && load.pressure >= 0.0, path, "load x0 < x1 and pressure >= 0");
    } else {
      check(load.surface.has_value() && c.detection.has_value(), path,
            "a detected-boundary load has its specification and a detection block");
    }
  }
  check(!c.detection || c.detection->every_steps >= 1, path, "detection every_steps >= 1");
}

Outcome run_case(const std::string& path) {
  Case c;
  try {
    c = read_case(path);
  } catch (const InputError&) {
    return Outcome::kRejected;
  }
  check_case(c, path);
  return Outcome::kAccepted;
}

Outcome run_particle_csv(const std::string& path) {
  ParticleTable t;
  try {
    t = read_particle_csv(path);
  } catch (const InputError&) {
    return Outcome::kRejected;
  }
  const std::size_t n = t.position.size();
  check(n >= 1, path, "at least one particle");
  check(t.volume.size() == n, path, "one volume per particle");
  check(t.deformation_gradient.empty() || t.deformation_gradient.size() == n, path,
        "no or one deformation gradient per particle");
  for (std::size_t p = 0; p < n; ++p) {
    check(finite(t.position[p]), path, "finite positions");
    check(std::isfinite(t.volume[p]) && t.volume[p] > 0.0, path, "finite volumes > 0");
    if (!t.deformation_gradient.empty()) {
      check(t.deformation_gradient[p].allFinite() && t.deformation_gradient[p].determinant() > 0.0,
            path, "finite F with det F > 0");
    }
  }
  return Outcome::kAccepted;
}

Outcome run_config(const std::string& path) {
  nlohmann::json document;
  try {
    document = read_json_file(path);
  } catch (const InputError&) {
    return Outcome::kRejected;
  }
  const JsonView root(document, path);
  bool accepted = false;
  try {
    const DetectorConfig config = parse_detector_config(root);
    check(config.pfm.refinement >= 1 && config.pfm.refinement <= 64, path, "pfm refinement");
    check(config.improved.refinement >= 0 && config.improved.refinement <= 64, path,
          "improved refinement");
    check(config.improved.level > 0.0 && config.improved.level < 1.0, path, "improved level");
    accepted = true;
  } catch (const InputError&) {
  }
  try {
    const boundary::BoundaryLoadSpec spec = boundary::parse_boundary_load(root);
    check(spec.quadrature.gauss_points >= 1 && spec.quadrature.gauss_points <= 20, path,
          "gauss_points in 1..20");
    accepted = true;
  } catch (const InputError&) {
  }
  return accepted ? Outcome::kAccepted : Outcome::kRejected;
}

}  // namespace

const char* target_name(Target target) {
  switch (target) {
    case Target::kCase:
      return "case";
    case Target::kParticleCsv:
      return "particle_csv";
    case Target::kConfig:
      return "config";
  }
  return "unknown";
}

std::optional<Target> target_from_name(std::string_view name) {
  for (const Target t : kAllTargets) {
    if (name == target_name(t)) return t;
  }
  return std::nullopt;
}

Outcome run_file(Target target, const std::string& path) {
  switch (target) {
    case Target::kCase:
      return run_case(path);
    case Target::kParticleCsv:
      return run_particle_csv(path);
    case Target::kConfig:
      return run_config(path);
  }
  return Outcome::kRejected;
}

Outcome run_bytes(Target target, const std::uint8_t* data, std::size_t size) {
  // A scratch file per process and target, removed again after each input (it stays behind
  // only when the reader crashes, as the input that crashed it).
  struct Scratch {
    std::string path;
    ~Scratch() {
      std::error_code ignored;
      std::filesystem::remove(path, ignored);
    }
  };
  const Scratch scratch{
      (std::filesystem::temp_directory_path() /
       ("pfm-fuzz-" + std::to_string(::getpid()) + "-" + target_name(target) + ".input"))
          .string()};
  {
    std::ofstream out(scratch.path, std::ios::binary | std::ios::trunc);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
    if (!out) throw std::runtime_error(scratch.path + ": cannot write the fuzz input");
  }
  return run_file(target, scratch.path);
}

}  // namespace pfm::fuzz

#include "mpm/solver/boundary_coupling.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

namespace pfm {

namespace {

using Clock = std::chrono::steady_clock;

double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

/// The particle spacing of the initial state: the smallest cell size / points per cell over
/// the bodies (m).
double initial_particle_spacing(const Case& c) {
  double spacing = std::numeric_limits<double>::infinity();
  for (const BodySpec& body : c.bodies) {
    spacing = std::min(spacing, c.grid.cell_size / body.points_per_cell);
  }
  return spacing;
}

}  // namespace

BoundaryCoupling::BoundaryCoupling(const Case& c)
    : case_(c), initial_spacing_(initial_particle_spacing(c)), integrator_(c.grid) {
  for (std::size_t k = 0; k < c.loads.size(); ++k) {
    const LoadSpec& load = c.loads[k];
    if (load.apply_on != LoadTarget::kDetectedBoundary) continue;
    SurfaceLoad surface;
    surface.case_index = k;
    surface.spec = *load.surface;
    surface.time_function = load.time_function;
    loads_.push_back(surface);
  }
  load_force_.assign(static_cast<std::size_t>(c.grid.n_nodes()), Vec2::Zero());
}

void BoundaryCoupling::attach(MpmSolver& solver) {
  solver_ = &solver;
  if (!detection_enabled()) return;
  tie_material_intervals();
  solver.set_external_force_hook(
      [this](double time, const GridState& grid_state, std::vector<Vec2>& force) {
        const long step = solver_->step_count();
        const bool due = detected_at_step_ < 0 || step % case_.detection->every_steps == 0;
        if (due && detected_at_step_ != step) detect_now();
        if (!loads_.empty()) apply_loads(time, grid_state, force);
      });
}

void BoundaryCoupling::tie_material_intervals() {
  const Particles& particles = solver_->particles();
  for (SurfaceLoad& load : loads_) {
    if (load.spec.interval != boundary::LoadInterval::kMaterial || !load.spec.x_range) continue;
    const double ends[2] = {load.spec.x_range->x(), load.spec.x_range->y()};
    for (int e = 0; e < 2; ++e) {
      // The column of particles closest to the end in x, and its highest particle.
      double best_dx = std::numeric_limits<double>::infinity();
      for (std::size_t p = 0; p < particles.size(); ++p) {
        best_dx = std::min(best_dx, std::abs(particles.position[p].x() - ends[e]));
      }
      long best = -1;
      const double tolerance = 1e-9 * initial_spacing_;
      for (std::size_t p = 0; p < particles.size(); ++p) {
        if (std::abs(particles.position[p].x() - ends[e]) > best_dx + tolerance) continue;
        if (best < 0 ||
            particles.position[p].y() > particles.position[static_cast<std::size_t>(best)].y()) {
          best = static_cast<long>(p);
        }
      }
      load.end_particle[e] = best;
      load.end_x0[e] = particles.position[static_cast<std::size_t>(best)].x();
    }
  }
}

std::vector<std::array<long, 2>> BoundaryCoupling::interval_particles() const {
  std::vector<std::array<long, 2>> ids;
  for (const SurfaceLoad& load : loads_) ids.push_back(load.end_particle);
  return ids;
}

void BoundaryCoupling::detect_now() {
  const auto start = Clock::now();
  const Particles& particles = solver_->particles();
  ParticleCloud cloud;
  cloud.position = particles.position;
  cloud.volume = particles.volume;
  cloud.deformation_gradient = particles.deformation_gradient;
  cloud.initial_spacing = initial_spacing_;
  boundary_ =
      detect(cloud, case_.grid, case_.detection->detector, detector_state_, &detection_timings_);
  detected_at_step_ = solver_->step_count();
  times_.detect += seconds_since(start);
  ++times_.detections;
}

const DetectedBoundary& BoundaryCoupling::current_boundary() {
  if (detected_at_step_ != solver_->step_count()) detect_now();
  return boundary_;
}

void BoundaryCoupling::apply_loads(double time, const GridState& grid_state,
                                   std::vector<Vec2>& force) {
  diagnostics_ = SurfaceLoadDiagnostics{};
  const Particles& particles = solver_->particles();
  boundary::CurveKind built = boundary::CurveKind::kLinear;
  bool have_curves = false;
  for (SurfaceLoad& load : loads_) {
    auto start = Clock::now();
    if (!have_curves || built != load.spec.curve) {
      curves_ = boundary::make_composite_beziers(boundary_.contours, load.spec.curve);
      built = load.spec.curve;
      have_curves = true;
    }
    times_.bezier += seconds_since(start);
    start = Clock::now();
    boundary::BoundaryLoadSpec spec = load.spec;
    if (load.end_particle[0] >= 0) {
      const double shift0 =
          particles.position[static_cast<std::size_t>(load.end_particle[0])].x() - load.end_x0[0];
      const double shift1 =
          particles.position[static_cast<std::size_t>(load.end_particle[1])].x() - load.end_x0[1];
      spec.x_range = Vec2(load.spec.x_range->x() + shift0, load.spec.x_range->y() + shift1);
    }
    std::fill(load_force_.begin(), load_force_.end(), Vec2::Zero());
    const boundary::BoundaryLoadResult result = integrator_.integrate(
        curves_, spec, load.time_function.factor(time), grid_state.mass, load_force_);
    for (std::size_t n = 0; n < force.size(); ++n) force[n] += load_force_[n];
    diagnostics_.target += result.exact_force;
    diagnostics_.applied += result.total_force;
    diagnostics_.lost += result.lost_force;
    diagnostics_.off_grid += result.off_grid_force;
    diagnostics_.loaded_nodes += result.n_loaded_nodes;
    diagnostics_.lost_nodes += result.n_lost_nodes;
    times_.traction += seconds_since(start);
  }
}

std::string boundary_csv(const DetectedBoundary& boundary) {
  std::string csv = "loop,x,y\n";
  char buffer[96];
  for (std::size_t c = 0; c < boundary.contours.size(); ++c) {
    for (const Vec2& p : boundary.contours[c].points) {
      std::snprintf(buffer, sizeof buffer, "%zu,%.17g,%.17g\n", c, p.x(), p.y());
      csv += buffer;
    }
  }
  return csv;
}

}  // namespace pfm

#include "mpm/solver/boundary_coupling.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

#include "mpm/step/body_fill.hpp"
#include "mpm/step/stage_timer.hpp"

namespace pfm {

BoundaryCoupling::BoundaryCoupling(const Case& c)
    : case_(c),
      initial_spacing_(initial_particle_spacing(c)),
      integrator_(c.grid, shape_degree(c.solver.shape_function)),
      constraints_(c) {
  for (std::size_t k = 0; k < c.loads.size(); ++k) {
    const LoadSpec& load = c.loads[k];
    if (load.apply_on != LoadTarget::kDetectedBoundary) continue;
    SurfaceLoad surface;
    surface.case_index = k;
    surface.spec = *load.surface;
    surface.time_function = load.time_function;
    loads_.push_back(surface);
    current_range_.push_back(surface.spec.x_range);
  }
}

void BoundaryCoupling::attach(MpmSolver& solver) {
  // The mass of a full cell: the densest particle's density x h^2 (t per m).
  const double h = case_.grid.cell_size;
  const double density = largest_density(solver.particles());
  for (SurfaceLoad& load : loads_)
    load.spec.min_node_mass = load.spec.min_node_mass_fraction * density * h * h;
  if (!detection_enabled()) return;
  tie_material_intervals(solver.particles());
  if (case_.detection->detector.method == DetectorMethod::kSmm) {
    // Surface markers ride on the updated grid velocities (thesis eq. 4.6-4.7), every step.
    solver.set_grid_velocity_hook([this](const StepView& step, const GridState& grid_state) {
      const auto start = Clock::now();
      advect_surface_markers(detector_state_, case_.grid, grid_state.velocity, grid_state.mass,
                             step.dt);
      times_.detect += seconds_since(start);
    });
  }
  solver.set_external_force_hook([this](const StepView& step, GridState& grid_state,
                                        std::vector<Vec2>& force) {
    Detection& detection = detection_for(step);
    if (!loads_.empty()) apply_loads(step, detection, grid_state, force);
    if (!constraints_.empty()) {
      const auto start = Clock::now();
      constraints_.apply(
          step, grid_state, force,
          [&](boundary::CurveKind kind) { return curves(detection, kind); }, detection.positions);
      times_.constraint += seconds_since(start);
    }
  });
}

BoundaryCoupling::Detection& BoundaryCoupling::detection_for(const StepView& step) {
  const bool due = !detection_ || step.step % case_.detection->every_steps == 0;
  if (due && (!detection_ || detection_->step != step.step)) {
    if (moved_since_detection(step.particles)) {
      detect_now(step);
    } else {
      ++times_.kept;
    }
  }
  return *detection_;
}

void BoundaryCoupling::tie_material_intervals(const Particles& particles) {
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

bool BoundaryCoupling::moved_since_detection(const Particles& particles) const {
  const std::vector<Vec2>& x = particles.position;
  if (!detection_ || detection_->positions.size() != x.size()) return true;
  const double limit = case_.detection->max_motion * case_.grid.cell_size;
  if (!(limit > 0.0)) return true;
  const double limit2 = limit * limit;
  const std::vector<Vec2>& then = detection_->positions;
  for (std::size_t p = 0; p < x.size(); ++p) {
    if ((x[p] - then[p]).squaredNorm() > limit2) return true;
  }
  return false;
}

void BoundaryCoupling::detect_now(const StepView& step) {
  const auto start = Clock::now();
  const Particles& particles = step.particles;
  ParticleCloud cloud;
  cloud.position = particles.position;
  cloud.volume = particles.volume;
  cloud.deformation_gradient = particles.deformation_gradient;
  cloud.initial_spacing = initial_spacing_;
  detection_ = Detection{};
  detection_->boundary =
      detect(cloud, case_.grid, case_.detection->detector, detector_state_, &detection_timings_);
  detection_->step = step.step;
  detection_->positions = particles.position;
  times_.detect += seconds_since(start);
  ++times_.detections;
  const DetectionTimings& t = detection_timings_;
  times_.bridged_detections += t.bridges > 0;
  times_.bridges += t.bridges;
  times_.spurious_loops_removed += t.spurious_loops_removed;
  times_.guard_refinement_passes += t.guard_refinement_passes;
  times_.most_loops =
      std::max(times_.most_loops, static_cast<long>(detection_->boundary.contours.size()));
}

const DetectedBoundary& BoundaryCoupling::current_boundary(const StepView& step) {
  if (!detection_ || detection_->step != step.step) detect_now(step);
  return detection_->boundary;
}

void BoundaryCoupling::apply_loads(const StepView& step, Detection& detection,
                                   GridState& grid_state, std::vector<Vec2>& force) {
  diagnostics_ = SurfaceLoadDiagnostics{};
  const Particles& particles = step.particles;
  const bool keep = case_.output.nodal_loads;
  if (keep) nodal_forces_.clear();
  for (std::size_t k = 0; k < loads_.size(); ++k) {
    SurfaceLoad& load = loads_[k];
    const std::vector<boundary::CompositeBezier>& load_curves = curves(detection, load.spec.curve);
    const auto start = Clock::now();
    boundary::BoundaryLoadSpec spec = load.spec;
    if (load.end_particle[0] >= 0) {
      const double shift0 =
          particles.position[static_cast<std::size_t>(load.end_particle[0])].x() - load.end_x0[0];
      const double shift1 =
          particles.position[static_cast<std::size_t>(load.end_particle[1])].x() - load.end_x0[1];
      spec.x_range = Vec2(load.spec.x_range->x() + shift0, load.spec.x_range->y() + shift1);
    }
    current_range_[k] = spec.x_range;
    std::span<const double> carriers = grid_state.mass;
    if (grid_state.ties) {
      // Every node passes its load on: the solver ties the nodes with little or no material to
      // inner ones after this hook (basis_extension.hpp), and nothing is lost.
      spec.redistribute_lost_load = false;
      carriers = {};
    }
    const boundary::BoundaryLoadResult result = integrator_.integrate(
        load_curves, spec, load.time_function.factor(step.time), carriers, force, true);
    LoadWorkRecorder& recorder = step.load_work;
    for (const boundary::NodalForce& f : result.nodal_forces)
      recorder.add(load.case_index, static_cast<std::size_t>(f.node), f.force);
    // The lost nodes' internal forces go where their loads went (header comment).
    if (spec.redistribute_lost_load && !result.lost_nodes.empty()) {
      boundary::redistribute_lost_forces(case_.grid, grid_state.mass, grid_state.internal_force,
                                         result.lost_nodes, spec.min_node_mass);
    }
    diagnostics_.target += result.exact_force;
    diagnostics_.applied += result.total_force;
    diagnostics_.lost += result.lost_force;
    diagnostics_.lost_moment += result.lost_moment;
    diagnostics_.off_grid += result.off_grid_force;
    diagnostics_.loaded_nodes += result.n_loaded_nodes;
    diagnostics_.lost_nodes += result.n_lost_nodes;
    if (keep) {
      nodal_forces_.insert(nodal_forces_.end(), result.nodal_forces.begin(),
                           result.nodal_forces.end());
    }
    times_.traction += seconds_since(start);
  }
  if (keep && loads_.size() > 1) {
    // One entry per node, summed over the loads in load order.
    std::stable_sort(nodal_forces_.begin(), nodal_forces_.end(),
                     [](const auto& a, const auto& b) { return a.node < b.node; });
    std::size_t out = 0;
    for (std::size_t i = 0; i < nodal_forces_.size(); ++i) {
      if (out > 0 && nodal_forces_[out - 1].node == nodal_forces_[i].node) {
        nodal_forces_[out - 1].force += nodal_forces_[i].force;
      } else {
        nodal_forces_[out++] = nodal_forces_[i];
      }
    }
    nodal_forces_.resize(out);
  }
}

std::vector<TractionSample> BoundaryCoupling::traction_samples(const StepView& now,
                                                               std::span<const unsigned> fixed) {
  current_boundary(now);
  Detection& detection = *detection_;
  const Grid& grid = case_.grid;
  const double h = grid.cell_size;
  std::vector<TractionSample> samples;
  std::vector<boundary::CurvePoint> points;
  // The parts whose traction the loads give, and the constraints' parts (unknown traction).
  std::vector<Vec2> taken;
  // One Gauss point per piece for linear functions (4 and 7 with B-splines): the samples stand
  // for lengths, no integral is exact here.
  const auto add_part = [&](boundary::BoundaryLoadSpec spec, double factor, bool known) {
    spec.quadrature.gauss_points = 1;
    integrator_.quadrature_points(curves(detection, spec.curve), spec, points);
    const boundary::TractionLaw law = spec.traction_law(factor);
    for (const boundary::CurvePoint& c : points) {
      taken.push_back(c.x);
      if (!known) continue;
      const Vec2 t = law.normal_scale.cwiseProduct(c.normal) + law.fixed_traction;
      samples.push_back({c.x, c.normal, t, c.weight});
    }
  };
  for (std::size_t k = 0; k < loads_.size(); ++k) {
    boundary::BoundaryLoadSpec spec = loads_[k].spec;
    spec.x_range = current_range_[k];
    add_part(spec, loads_[k].time_function.factor(now.time), true);
  }
  for (const LoadSpec& load : case_.loads) {
    if (load.apply_on != LoadTarget::kGridTopNodes) continue;
    boundary::BoundaryLoadSpec spec;
    spec.type = boundary::BoundaryLoadType::kVerticalPressure;
    spec.pressure = load.pressure;
    spec.x_range = Vec2(load.x0, load.x1);
    spec.faces = boundary::LoadedFaces::kTop;
    add_part(spec, load.time_function.factor(now.time), true);
  }
  for (const ConstraintSpec& constraint : case_.constraints) add_part(constraint.part, 0.0, false);
  // The rest of the boundary is free: zero traction, where no part above took it (a point
  // within a quarter cell of one of theirs).
  boundary::BoundaryLoadSpec all;
  all.type = boundary::BoundaryLoadType::kTraction;
  all.faces = boundary::LoadedFaces::kAll;
  all.quadrature.gauss_points = 1;
  integrator_.quadrature_points(curves(detection, boundary::CurveKind::kLinear), all, points);
  std::sort(taken.begin(), taken.end(), [](const Vec2& a, const Vec2& b) { return a.x() < b.x(); });
  const double near = 0.25 * h;
  for (const boundary::CurvePoint& c : points) {
    auto it = std::lower_bound(taken.begin(), taken.end(), c.x.x() - near,
                               [](const Vec2& a, double x) { return a.x() < x; });
    bool covered = false;
    for (; it != taken.end() && it->x() <= c.x.x() + near && !covered; ++it) {
      covered = (*it - c.x).squaredNorm() <= near * near;
    }
    if (!covered) samples.push_back({c.x, c.normal, Vec2::Zero(), c.weight});
  }
  // On a support the traction is the unknown reaction: no sample within 3/4 of a cell of a node
  // with a fixed component (a wall's line of nodes, wherever the detector puts the boundary
  // beside it, and the first 3/4 cell of a free surface that meets it).
  const double reach = 0.75 * h;
  const int nx = grid.n_nodes_x(), ny = grid.n_nodes_y();
  std::erase_if(samples, [&](const TractionSample& s) {
    const double u = (s.x.x() - grid.origin.x()) / h, v = (s.x.y() - grid.origin.y()) / h;
    const int i0 = std::max(0, static_cast<int>(std::ceil(u - 0.75)));
    const int i1 = std::min(nx - 1, static_cast<int>(std::floor(u + 0.75)));
    const int j0 = std::max(0, static_cast<int>(std::ceil(v - 0.75)));
    const int j1 = std::min(ny - 1, static_cast<int>(std::floor(v + 0.75)));
    for (int j = j0; j <= j1; ++j) {
      for (int i = i0; i <= i1; ++i) {
        if (fixed[static_cast<std::size_t>(grid.node_index(i, j))] != kFixNone &&
            (grid.node_position(i, j) - s.x).squaredNorm() < reach * reach)
          return true;
      }
    }
    return false;
  });
  return samples;
}

const std::vector<boundary::CompositeBezier>& BoundaryCoupling::curves(Detection& detection,
                                                                       boundary::CurveKind kind) {
  if (detection.curve_kind != kind) {
    const auto start = Clock::now();
    detection.curves = boundary::make_composite_beziers(detection.boundary.contours, kind);
    detection.curve_kind = kind;
    times_.bezier += seconds_since(start);
  }
  return detection.curves;
}

void BoundaryCoupling::save(CheckpointFile& file) const {
  file.put("coupling/detector/shape", flatten(detector_state_.shape));
  file.put("coupling/detector/previous_deformation", flatten(detector_state_.previous_deformation));
  file.put("coupling/detector/n_calls", static_cast<double>(detector_state_.n_calls));
  std::vector<double> marker_points, marker_counts, marker_closed;
  for (std::size_t k = 0; k < detector_state_.markers.size(); ++k) {
    for (const Vec2& x : detector_state_.markers[k])
      marker_points.insert(marker_points.end(), {x.x(), x.y()});
    marker_counts.push_back(static_cast<double>(detector_state_.markers[k].size()));
    marker_closed.push_back(detector_state_.markers_closed[k] ? 1.0 : 0.0);
  }
  file.put("coupling/detector/marker_points", marker_points);
  file.put("coupling/detector/marker_counts", marker_counts);
  file.put("coupling/detector/marker_closed", marker_closed);
  file.put("coupling/detector/markers_placed", detector_state_.markers_placed ? 1.0 : 0.0);
  std::vector<double> points, counts, closed;
  const std::vector<Contour> none;
  for (const Contour& contour : detection_ ? detection_->boundary.contours : none) {
    for (const Vec2& x : contour.points) points.insert(points.end(), {x.x(), x.y()});
    counts.push_back(static_cast<double>(contour.points.size()));
    closed.push_back(contour.closed ? 1.0 : 0.0);
  }
  file.put("coupling/boundary/points", points);
  file.put("coupling/boundary/counts", counts);
  file.put("coupling/boundary/closed", closed);
  file.put("coupling/detected_at_step", static_cast<double>(detection_ ? detection_->step : -1));
  file.put("coupling/detected_positions",
           detection_ ? flatten(detection_->positions) : std::vector<double>{});
  std::vector<double> ends;
  for (const SurfaceLoad& load : loads_) {
    ends.insert(ends.end(),
                {static_cast<double>(load.end_particle[0]),
                 static_cast<double>(load.end_particle[1]), load.end_x0[0], load.end_x0[1]});
  }
  file.put("coupling/load_ends", ends);
  file.put("coupling/constraint_targets", flatten(constraints_.target()));
}

namespace {

/// Polylines saved as points (x, y pairs), counts and closed flags; InputError naming the dataset
/// when the counts are not whole, do not add up to the points, or a flag is not 0 or 1.
void read_polylines(const CheckpointFile& file, const std::string& prefix,
                    std::vector<std::vector<Vec2>>& lines, std::vector<bool>& closed) {
  const std::vector<double>& points = file.get(prefix + "points");
  const std::vector<double>& counts = file.get(prefix + "counts");
  const std::vector<double>& flags = file.get(prefix + "closed", counts.size());
  double total = 0.0;
  for (const double count : counts) {
    if (!(count >= 0.0 && count == std::floor(count)))
      file.fail(prefix + "counts", "a count is not a whole number");
    total += count;
  }
  if (2.0 * total != static_cast<double>(points.size()))
    file.fail(prefix + "counts", "the counts do not add up to the points");
  lines.clear();
  closed.clear();
  std::size_t next = 0;
  for (std::size_t k = 0; k < counts.size(); ++k) {
    if (flags[k] != 0.0 && flags[k] != 1.0) file.fail(prefix + "closed", "a flag is not 0 or 1");
    std::vector<Vec2> line;
    for (std::size_t i = 0; i < static_cast<std::size_t>(counts[k]); ++i, next += 2)
      line.emplace_back(points[next], points[next + 1]);
    lines.push_back(std::move(line));
    closed.push_back(flags[k] == 1.0);
  }
}

}  // namespace

void BoundaryCoupling::restore(const CheckpointFile& file, const StepView& now) {
  const std::size_t n = now.particles.size();
  const long step = now.step;
  for (const char* name : {"coupling/detector/shape", "coupling/detector/previous_deformation"}) {
    const std::size_t size = file.get(name).size();
    if (size != 0 && size != 4 * n) file.fail(name, "is not one 2 x 2 matrix per particle");
  }
  detector_state_.shape = unflatten<Mat2>(file.get("coupling/detector/shape"));
  detector_state_.previous_deformation =
      unflatten<Mat2>(file.get("coupling/detector/previous_deformation"));
  detector_state_.n_calls =
      static_cast<std::size_t>(file.integer("coupling/detector/n_calls", 0, 1L << 52));
  read_polylines(file, "coupling/detector/marker_", detector_state_.markers,
                 detector_state_.markers_closed);
  detector_state_.markers_placed = file.integer("coupling/detector/markers_placed", 0, 1) == 1;
  std::vector<std::vector<Vec2>> lines;
  std::vector<bool> closed;
  read_polylines(file, "coupling/boundary/", lines, closed);
  Detection detection;
  for (std::size_t k = 0; k < lines.size(); ++k) {
    Contour contour;
    contour.points = std::move(lines[k]);
    contour.closed = closed[k];
    detection.boundary.contours.push_back(std::move(contour));
  }
  detection.step = file.integer("coupling/detected_at_step", -1, step);
  if (!constraints_.empty()) {  // checkpoints of runs without constraints may lack it
    const std::vector<double>& targets =
        file.get("coupling/constraint_targets", 2 * constraints_.size());
    constraints_.set_target(unflatten<Vec2>(targets));
  }
  const std::size_t size = file.get("coupling/detected_positions").size();
  if (size != 0 && size != 2 * n)
    file.fail("coupling/detected_positions", "is not one position per particle");
  detection.positions = unflatten<Vec2>(file.get("coupling/detected_positions"));
  // A step of -1: the run had not detected yet.
  detection_.reset();
  if (detection.step >= 0) detection_ = std::move(detection);
  const std::vector<double>& ends = file.get("coupling/load_ends", 4 * loads_.size());
  for (std::size_t k = 0; k < loads_.size(); ++k) {
    for (int e = 0; e < 2; ++e) {
      const double id = ends[4 * k + static_cast<std::size_t>(e)];
      if (!(id >= -1.0 && id < static_cast<double>(n) && id == std::floor(id)))
        file.fail("coupling/load_ends", "a load's end particle is not a particle of the case");
    }
    loads_[k].end_particle = {static_cast<long>(ends[4 * k]), static_cast<long>(ends[4 * k + 1])};
    loads_[k].end_x0 = {ends[4 * k + 2], ends[4 * k + 3]};
  }
}

}  // namespace pfm

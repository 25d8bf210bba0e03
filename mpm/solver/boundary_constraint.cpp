#include "mpm/solver/boundary_constraint.hpp"

#include <cmath>

namespace pfm {

BoundaryConstraints::BoundaryConstraints(const Case& c)
    : grid_(c.grid),
      degree_(shape_degree(c.solver.shape_function)),
      n_loads_(c.loads.size()),
      specs_(c.constraints),
      integrator_(c.grid, degree_),
      target_(c.constraints.size(), Vec2::Zero()),
      reports_(c.constraints.size()) {
  const auto n = static_cast<std::size_t>(c.grid.n_nodes());
  if (specs_.empty()) return;
  node_weight_.assign(n, 0.0);
  node_displacement_.assign(n, Vec2::Zero());
  penalty_force_.assign(n, Vec2::Zero());
  stiffness_.assign(n, Mat2::Zero());
  target_rate_.assign(n, Vec2::Zero());
  touched_flag_.assign(n, 0);
  // A displacement starts at its time function's value at 0 (a velocity integrates from 0).
  for (std::size_t k = 0; k < specs_.size(); ++k) {
    if (!specs_[k].velocity) target_[k] = specs_[k].time_function.factor(0.0) * specs_[k].value;
  }
}

void BoundaryConstraints::functions_at(const Vec2& x) {
  stencil_ = degree_ > 1 ? bspline_stencil(grid_, degree_, x) : linear_stencil(grid_, x);
}

void BoundaryConstraints::project_displacement(const Particles& particles, std::size_t n_nodes) {
  std::fill(node_weight_.begin(), node_weight_.end(), 0.0);
  std::fill(node_displacement_.begin(), node_displacement_.end(), Vec2::Zero());
  const int nx = grid_.n_nodes_x();
  for (std::size_t p = 0; p < particles.size(); ++p) {
    const Vec2& x = particles.position[p];
    const Vec2 u = x - particles.reference_position[p];
    const Mat2 gradient = Mat2::Identity() - particles.deformation_gradient[p].inverse();
    const double m = particles.mass[p];
    functions_at(x);
    for (int b = 0; b < stencil_.width; ++b) {
      for (int a = 0; a < stencil_.width; ++a) {
        const double w = m * stencil_.value[static_cast<std::size_t>(b * stencil_.width + a)];
        if (w == 0.0) continue;
        const int i = stencil_.base_i + a, j = stencil_.base_j + b;
        const auto node = static_cast<std::size_t>(j * nx + i);
        node_weight_[node] += w;
        node_displacement_[node] += w * (u + gradient * (grid_.node_position(i, j) - x));
      }
    }
  }
  for (std::size_t node = 0; node < n_nodes; ++node) {
    if (node_weight_[node] > 0.0) node_displacement_[node] /= node_weight_[node];
  }
}

void BoundaryConstraints::apply_one(std::size_t k, const StepView& step, GridState& grid_state,
                                    std::vector<Vec2>& force,
                                    const std::vector<boundary::CompositeBezier>& curves) {
  const ConstraintSpec& spec = specs_[k];
  ConstraintReport& report = reports_[k];
  report = ConstraintReport{};
  const double dt = step.dt;
  // The prescribed displacement at the step's start and its rate over the step.
  Vec2 rate;
  if (spec.velocity) {
    rate = spec.time_function.factor(step.time + 0.5 * dt) * spec.value;
  } else {
    rate = (spec.time_function.factor(step.time + dt) * spec.value - target_[k]) / dt;
  }
  const Vec2 u_bar = target_[k];
  const double beta = spec.penalty;
  const int nx = grid_.n_nodes_x();

  integrator_.quadrature_points(curves, spec.part, points_);
  double gap_squared = 0.0;
  for (const boundary::CurvePoint& q : points_) {
    functions_at(q.x);
    // u_h(x): over the nodes the particles reach.
    Vec2 u = Vec2::Zero();
    double weight = 0.0;
    for (int s = 0; s < stencil_.width * stencil_.width; ++s) {
      const double value = stencil_.value[static_cast<std::size_t>(s)];
      const int i = stencil_.base_i + s % stencil_.width, j = stencil_.base_j + s / stencil_.width;
      const auto node = static_cast<std::size_t>(j * nx + i);
      if (value == 0.0 || !(node_weight_[node] > 0.0)) continue;
      u += value * node_displacement_[node];
      weight += value;
    }
    if (!(weight > 0.0)) continue;  // no material here
    u /= weight;
    Mat2 projector = Mat2::Identity();
    Vec2 target = u_bar, velocity = rate;
    if (spec.normal_only) {
      projector = q.normal * q.normal.transpose();
      target = u_bar.x() * q.normal;
      velocity = rate.x() * q.normal;
    }
    const Vec2 gap = projector * (u - target);
    gap_squared += q.weight * gap.squaredNorm();
    report.length += q.weight;
    for (int s = 0; s < stencil_.width * stencil_.width; ++s) {
      const double value = stencil_.value[static_cast<std::size_t>(s)];
      if (value == 0.0) continue;
      const int i = stencil_.base_i + s % stencil_.width, j = stencil_.base_j + s / stencil_.width;
      const auto node = static_cast<std::size_t>(j * nx + i);
      const double w = beta * q.weight * value;
      penalty_force_[node] -= w * gap;
      stiffness_[node] += w * projector;
      target_rate_[node] += w * (projector * velocity);
      if (!touched_flag_[node]) {
        touched_flag_[node] = 1;
        touched_.push_back(static_cast<int>(node));
      }
    }
  }
  report.rms_gap = report.length > 0.0 ? std::sqrt(gap_squared / report.length) : 0.0;

  // The semi-implicit update of each node (header comment), in node order.
  std::sort(touched_.begin(), touched_.end());
  const double tiny = 1e-12 * step.particles.mass.front();
  const std::size_t recorder_index = n_loads_ + k;
  for (const int index : touched_) {
    const auto node = static_cast<std::size_t>(index);
    const double m = grid_state.mass[node];
    const unsigned fixed = grid_state.fixed[node];
    if (m > tiny && fixed != kFixXY) {
      Mat2 stiffness = stiffness_[node];
      Vec2 rate_force = target_rate_[node];
      // A component held by a support stays at rest: it takes no constraint force.
      for (int c = 0; c < 2; ++c) {
        if (!(fixed & (c == 0 ? kFixX : kFixY))) continue;
        stiffness(c, 1 - c) = stiffness(1 - c, c) = 0.0;
        rate_force[c] = 0.0;
      }
      const Vec2 f = grid_state.internal_force[node] + force[node];
      const Vec2 rhs = grid_state.momentum[node] + dt * (f + penalty_force_[node]) +
                       dt * dt * rate_force;
      const Vec2 v_new = (m * Mat2::Identity() + dt * dt * stiffness).inverse() * rhs;
      Vec2 applied = penalty_force_[node] - dt * (stiffness * v_new - rate_force);
      if (fixed & kFixX) applied.x() = 0.0;
      if (fixed & kFixY) applied.y() = 0.0;
      force[node] += applied;
      report.force += applied;
      ++report.nodes;
      step.load_work.add(recorder_index, node, applied);
    }
    penalty_force_[node] = Vec2::Zero();
    stiffness_[node] = Mat2::Zero();
    target_rate_[node] = Vec2::Zero();
    touched_flag_[node] = 0;
  }
  touched_.clear();
  target_[k] = u_bar + dt * rate;
}

}  // namespace pfm

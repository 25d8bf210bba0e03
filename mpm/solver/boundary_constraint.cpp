#include "mpm/solver/boundary_constraint.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <optional>

namespace pfm {

BoundaryConstraints::BoundaryConstraints(const Case& c)
    : grid_(c.grid),
      degree_(shape_degree(c.solver.shape_function)),
      n_loads_(c.loads.size()),
      specs_(c.constraints),
      integrator_(c.grid, degree_),
      target_(c.constraints.size(), Vec2::Zero()),
      reports_(c.constraints.size()),
      points_(c.constraints.size()),
      terms_(c.constraints.size()) {
  if (specs_.empty()) return;
  const auto n = static_cast<std::size_t>(c.grid.n_nodes());
  moments_.assign(n, NodeMoments{});
  moments_flag_.assign(n, 0);
  terms_dense_.assign(n, NodeTerm{});
  terms_flag_.assign(n, 0);
  total_.assign(n, NodeTerm{});
  total_flag_.assign(n, 0);
  velocity_.assign(n, Vec2::Zero());
  // A displacement starts at its time function's value at 0 (a velocity integrates from 0).
  for (std::size_t k = 0; k < specs_.size(); ++k) {
    if (!specs_[k].velocity) target_[k] = specs_[k].time_function.factor(0.0) * specs_[k].value;
  }
}

void BoundaryConstraints::functions_at(const Vec2& x) {
  stencil_ = degree_ > 1 ? bspline_stencil(grid_, degree_, x) : linear_stencil(grid_, x);
}

template <class Visit>
void BoundaryConstraints::for_each_node(Visit&& visit) const {
  const int nx = grid_.n_nodes_x();
  for (int s = 0; s < stencil_.width * stencil_.width; ++s) {
    const double value = stencil_.value[static_cast<std::size_t>(s)];
    if (value == 0.0) continue;
    const int i = stencil_.base_i + s % stencil_.width, j = stencil_.base_j + s / stencil_.width;
    visit(static_cast<std::size_t>(j * nx + i), value, i, j);
  }
}

namespace {

/// Marks a node as holding a value (once) for the sparse clear.
inline void mark(std::vector<char>& flag, std::vector<int>& list, std::size_t node) {
  if (flag[node]) return;
  flag[node] = 1;
  list.push_back(static_cast<int>(node));
}

/// Whether x lies in the box [lo, hi] widened by `margin`.
inline bool in_box(const Vec2& x, const Vec2& lo, const Vec2& hi, double margin) {
  return x.x() >= lo.x() - margin && x.x() <= hi.x() + margin && x.y() >= lo.y() - margin &&
         x.y() <= hi.y() + margin;
}

}  // namespace

void BoundaryConstraints::project(const Particles& particles,
                                  std::span<const Vec2> detected_positions, const Vec2& lo,
                                  const Vec2& hi, const std::optional<Vec2>& x_range) {
  const bool moved = detected_positions.size() == particles.size();
  for (const int node : moments_list_) {
    moments_[static_cast<std::size_t>(node)] = NodeMoments{};
    moments_flag_[static_cast<std::size_t>(node)] = 0;
  }
  moments_list_.clear();
  const double margin = (degree_ + 2) * grid_.cell_size;
  const double fade_width = 0.5 * grid_.cell_size;
  for (std::size_t p = 0; p < particles.size(); ++p) {
    const Vec2& x = particles.position[p];
    if (!in_box(x, lo, hi, margin)) continue;
    // The particle's share in the part: 1 over the x_range, fading to 0 at its ends (header
    // comment); the rest is the material beside the part.
    const double share = boundary::part_share(x.x(), x_range, fade_width);
    functions_at(x);
    if (share < 1.0) {
      const double beside = (1.0 - share) * particles.mass[p];
      for_each_node([&](std::size_t node, double value, int, int) {
        moments_[node].beside += beside * value;
        mark(moments_flag_, moments_list_, node);
      });
      if (share == 0.0) continue;
    }
    const Stress& sigma = particles.stress[p];
    Fitted f;
    const Vec2 motion = moved ? Vec2(x - detected_positions[p]) : Vec2::Zero();
    f << x - particles.reference_position[p], motion, sigma[kXX], sigma[kYY], sigma[kXY];
    const double m = share * particles.mass[p];
    for_each_node([&](std::size_t node, double value, int i, int j) {
      const Vec2 d = x - grid_.node_position(i, j);
      const double w = m * value;
      NodeMoments& moments = moments_[node];
      moments.mass += w;
      moments.first += w * d;
      moments.second += w * d * d.transpose();
      moments.value += w * f;
      moments.cross += w * d * f.transpose();
      mark(moments_flag_, moments_list_, node);
    });
  }
}

double BoundaryConstraints::part_share(std::size_t node) const {
  const NodeMoments& m = moments_[node];
  if (m.beside == 0.0) return 1.0;
  return m.mass > 0.0 ? m.mass / (m.mass + m.beside) : 0.0;
}

BoundaryConstraints::Fitted BoundaryConstraints::material_state(const Vec2& x, double& mass) const {
  // The weighted least-squares fit f(x_p) ~ a + B (x_p - x) over the particles, weights
  // w_p = m_p sum_J N_J(x) N_J(x_p), from the nodes' moments shifted to x (e = x_J - x).
  double w = 0.0;
  Vec2 d = Vec2::Zero();
  Mat2 q = Mat2::Zero();
  Fitted f = Fitted::Zero();
  Eigen::Matrix<double, 2, 7> c = Eigen::Matrix<double, 2, 7>::Zero();
  for_each_node([&](std::size_t node, double value, int i, int j) {
    const NodeMoments& m = moments_[node];
    if (!(m.mass > 0.0)) return;
    const Vec2 e = grid_.node_position(i, j) - x;
    w += value * m.mass;
    d += value * (m.first + m.mass * e);
    q += value * (m.second + m.first * e.transpose() + e * m.first.transpose() +
                  m.mass * e * e.transpose());
    f += value * m.value;
    c += value * (m.cross + e * m.value.transpose());
  });
  mass = w;
  if (!(w > 0.0)) return Fitted::Zero();
  // The spread of the points about their centroid; too thin a spread (points on a line) leaves
  // the gradient undetermined: the weighted mean then.
  const Mat2 spread = q - d * d.transpose() / w;
  const double h2 = grid_.cell_size * grid_.cell_size;
  if (!(spread.determinant() > 1e-6 * (w * h2) * (w * h2))) return f / w;
  // [w d^T; d q] [a^T; B^T] = [f^T; c]: eliminate B^T = spread^-1 (c - d f^T / w).
  const Eigen::Matrix<double, 2, 7> gradient_t = spread.inverse() * (c - d * f.transpose() / w);
  return (f - gradient_t.transpose() * d) / w;
}

void BoundaryConstraints::gather(std::size_t k, const Vec2& rate) {
  const ConstraintSpec& spec = specs_[k];
  ConstraintReport& report = reports_[k];
  const Vec2 u_bar = target_[k];
  const double beta = spec.penalty;
  const bool nitsche = spec.method == ConstraintMethod::kNitsche;
  double gap_squared = 0.0;
  for (const boundary::CurvePoint& point : points_[k]) {
    if (!grid_.contains(point.x)) continue;
    functions_at(point.x);
    double mass = 0.0;
    Fitted state = material_state(point.x, mass);
    if (!(mass > 0.0)) continue;  // no material here
    // The boundary has moved with the material since it was detected: the point moves with the
    // material's motion along the normal (header comment).
    boundary::CurvePoint q = point;
    const Vec2 shift = q.normal.dot(state.segment<2>(kMotion)) * q.normal;
    if (shift != Vec2::Zero()) {
      q.x += shift;
      if (!grid_.contains(q.x)) continue;
      functions_at(q.x);
      state = material_state(q.x, mass);
      if (!(mass > 0.0)) continue;
    }
    const Vec2 u = state.segment<2>(kDisplacement);
    Mat2 projector = Mat2::Identity();
    Vec2 target = u_bar, velocity = rate;
    if (spec.normal_only) {
      // The face's direction where the part is a face (its normal window), else the curve's.
      const Vec2 n = spec.part.normal_window ? spec.part.normal_window->direction : q.normal;
      projector = n * n.transpose();
      target = u_bar.x() * n;
      velocity = rate.x() * n;
    }
    const Vec2 gap = projector * (u - target);
    gap_squared += q.weight * gap.squaredNorm();
    report.length += q.weight;
    // Nitsche's consistency term: the material's own traction on the constrained directions,
    // P sigma n (header comment).
    Vec2 traction = Vec2::Zero();
    if (nitsche) {
      const Mat2 sigma =
          (Mat2() << state[kStress], state[kStress + 2], state[kStress + 2], state[kStress + 1])
              .finished();
      traction = projector * (sigma * q.normal);
    }
    // The traction -beta g at the point (with Nitsche's, + P sigma n), shared by the nodes with
    // mass in proportion to N_I(x) r_I (header comment).
    double sum = 0.0;
    for_each_node([&](std::size_t node, double value, int, int) {
      if (node_mass_[node] > tiny_mass_) sum += value * part_share(node);
    });
    if (!(sum > 0.0)) continue;
    for_each_node([&](std::size_t node, double value, int, int) {
      if (!(node_mass_[node] > tiny_mass_)) return;
      const double weight = value * part_share(node) / sum;
      if (weight == 0.0) return;
      const double share = beta * q.weight * weight;
      NodeTerm& term = terms_dense_[node];
      term.force -= share * gap;
      if (nitsche) term.force += (q.weight * weight) * traction;
      term.stiffness += share * projector;
      term.rate += share * (projector * velocity);
      mark(terms_flag_, terms_list_, node);
    });
  }
  report.rms_gap = report.length > 0.0 ? std::sqrt(gap_squared / report.length) : 0.0;
}

void BoundaryConstraints::collect(std::size_t k) {
  std::sort(terms_list_.begin(), terms_list_.end());
  std::vector<std::pair<int, NodeTerm>>& terms = terms_[k];
  terms.clear();
  for (const int index : terms_list_) {
    const auto node = static_cast<std::size_t>(index);
    terms.emplace_back(index, terms_dense_[node]);
    NodeTerm& total = total_[node];
    total.force += terms_dense_[node].force;
    total.stiffness += terms_dense_[node].stiffness;
    total.rate += terms_dense_[node].rate;
    mark(total_flag_, total_list_, node);
    terms_dense_[node] = NodeTerm{};
    terms_flag_[node] = 0;
  }
  terms_list_.clear();
}

void BoundaryConstraints::apply_all(const StepView& step, GridState& grid_state,
                                    std::vector<Vec2>& force,
                                    std::span<const Vec2> detected_positions) {
  const double dt = step.dt;
  // The box of each part's points.
  std::vector<Vec2> part_lo(specs_.size()), part_hi(specs_.size());
  for (std::size_t k = 0; k < specs_.size(); ++k) {
    part_lo[k] = Vec2::Constant(std::numeric_limits<double>::infinity());
    part_hi[k] = -part_lo[k];
    for (const boundary::CurvePoint& q : points_[k]) {
      part_lo[k] = part_lo[k].cwiseMin(q.x);
      part_hi[k] = part_hi[k].cwiseMax(q.x);
    }
  }
  node_mass_ = grid_state.mass.data();
  tiny_mass_ = 1e-12 * step.particles.mass.front();
  std::vector<Vec2> rates(specs_.size());
  bool projected = false;
  std::optional<Vec2> projected_range;
  for (std::size_t k = 0; k < specs_.size(); ++k) {
    const ConstraintSpec& spec = specs_[k];
    reports_[k] = ConstraintReport{};
    // The particles' moments for the fit: those over the part's x_range if it has one (header
    // comment), around the parts that share this range (one projection serves them all).
    const std::optional<Vec2>& range = spec.part.x_range;
    if (!projected || range != projected_range) {
      Vec2 lo = Vec2::Constant(std::numeric_limits<double>::infinity()), hi = -lo;
      for (std::size_t other = 0; other < specs_.size(); ++other) {
        if (specs_[other].part.x_range != range) continue;
        lo = lo.cwiseMin(part_lo[other]);
        hi = hi.cwiseMax(part_hi[other]);
      }
      project(step.particles, detected_positions, lo, hi, range);
      projected = true;
      projected_range = range;
    }
    // The prescribed displacement's rate over the step.
    rates[k] =
        spec.velocity
            ? Vec2(spec.time_function.factor(step.time + 0.5 * dt) * spec.value)
            : Vec2((spec.time_function.factor(step.time + dt) * spec.value - target_[k]) / dt);
    gather(k, rates[k]);
    collect(k);
  }

  // Each node's velocity after the step with the penalty's stiffness implicit (header
  // comment), all constraints together.
  const double tiny = tiny_mass_;
  std::sort(total_list_.begin(), total_list_.end());
  for (const int index : total_list_) {
    const auto node = static_cast<std::size_t>(index);
    const double m = grid_state.mass[node];
    NodeTerm total = total_[node];
    // A component held by a support stays as the support has it.
    const unsigned fixed = grid_state.fixed[node];
    for (int c = 0; c < 2; ++c) {
      if (!(fixed & (c == 0 ? kFixX : kFixY))) continue;
      total.stiffness(c, 1 - c) = total.stiffness(1 - c, c) = 0.0;
      total.rate[c] = 0.0;
    }
    velocity_[node] = Vec2::Zero();
    if (m > tiny) {
      const Vec2 f = grid_state.internal_force[node] + force[node];
      const Vec2 rhs = grid_state.momentum[node] + dt * (f + total.force) + dt * dt * total.rate;
      velocity_[node] = (m * Mat2::Identity() + dt * dt * total.stiffness).inverse() * rhs;
    }
    total_[node] = NodeTerm{};
    total_flag_[node] = 0;
  }
  // Each constraint's force on its nodes.
  for (std::size_t k = 0; k < specs_.size(); ++k) {
    ConstraintReport& report = reports_[k];
    for (const auto& [index, term] : terms_[k]) {
      const auto node = static_cast<std::size_t>(index);
      const double m = grid_state.mass[node];
      if (!(m > tiny)) continue;  // nothing there to push
      const unsigned fixed = grid_state.fixed[node];
      Vec2 applied = term.force - dt * (term.stiffness * velocity_[node] - term.rate);
      if (fixed & kFixX) applied.x() = 0.0;
      if (fixed & kFixY) applied.y() = 0.0;
      if (applied == Vec2::Zero()) continue;
      force[node] += applied;
      report.force += applied;
      ++report.nodes;
      step.load_work.add(n_loads_ + k, node, applied);
    }
    target_[k] += dt * rates[k];
  }
  total_list_.clear();
}

}  // namespace pfm

#include "mpm/solver/mpm_solver.hpp"

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <sstream>

#include "mpm/core/json_input.hpp"
#include "mpm/core/kinematics.hpp"
#include "mpm/solver/body_fill.hpp"

namespace pfm {

namespace {

using Clock = std::chrono::steady_clock;
double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

// Stencil storage per particle: W values along x, W along y, then W x-derivatives, W
// y-derivatives (1D factors; the 2D functions are their tensor products).
template <int W>
struct StencilView {
  const double* f;
  double nx(int a) const { return f[a]; }
  double ny(int b) const { return f[W + b]; }
  double dx(int a) const { return f[2 * W + a]; }
  double dy(int b) const { return f[3 * W + b]; }
};

std::string describe_particle(const Particles& particles, std::size_t p) {
  std::ostringstream s;
  s << "particle " << p << " at (" << particles.position[p].x() << ", " << particles.position[p].y()
    << ")";
  return s.str();
}

}  // namespace

MpmSolver::MpmSolver(const Case& c) : case_(c) {
  particles_ = fill_bodies(case_);
  if (particles_.size() == 0) {
    throw InputError(case_.file + ": /bodies: the bodies hold no material point (each body must " +
                     "contain at least one point of its cells' placement)");
  }
  const int n_nodes = case_.grid.n_nodes();
  grid_.mass.assign(static_cast<std::size_t>(n_nodes), 0.0);
  grid_.momentum.assign(static_cast<std::size_t>(n_nodes), Vec2::Zero());
  grid_.internal_force.assign(static_cast<std::size_t>(n_nodes), Vec2::Zero());
  grid_.external_force.assign(static_cast<std::size_t>(n_nodes), Vec2::Zero());
  grid_.velocity.assign(static_cast<std::size_t>(n_nodes), Vec2::Zero());
  grid_.acceleration.assign(static_cast<std::size_t>(n_nodes), Vec2::Zero());
  grid_.fixed.assign(static_cast<std::size_t>(n_nodes), kFixNone);
  velocity_before_update_.assign(static_cast<std::size_t>(n_nodes), Vec2::Zero());
  remapped_velocity_.assign(static_cast<std::size_t>(n_nodes), Vec2::Zero());
  build_constraints();

  // Critical time step from the P-wave speed of the stiffest material (thesis eq. 3.24 is
  // conditionally stable: dt <= h / c_p).
  const double g = case_.gravity.g > 0.0 ? case_.gravity.g : 9.81;
  for (const MaterialRecord& m : case_.materials) {
    const double density = m.unit_weight / g;
    if (density <= 0.0) continue;
    max_wave_speed_ = std::max(
        max_wave_speed_, std::sqrt(elastic_parameters(m.model).constrained_modulus() / density));
  }
  if (max_wave_speed_ <= 0.0) {
    throw InputError(case_.file + ": /materials: every material has zero unit weight, so the " +
                     "critical time step is undefined");
  }
  critical_dt_ = case_.grid.cell_size / max_wave_speed_;
  if (case_.time.dt) {
    if (*case_.time.dt > critical_dt_) {
      throw InputError(
          case_.file + ": /time/dt: " + std::to_string(*case_.time.dt) +
          " s exceeds the critical time step h / c_p = " + std::to_string(critical_dt_) + " s");
    }
    dt_ = *case_.time.dt;
  } else {
    dt_ = case_.time.cfl * critical_dt_;
  }
  damping_ = case_.solver.damping;
  build_top_node_loads();
  internal_work_increment_.assign(particles_.size(), 0.0);
  stencil_.resize(particles_.size());
  stencil_base_.resize(particles_.size());
  particle_cell_.resize(particles_.size());
  sorted_.resize(particles_.size());
}

void MpmSolver::set_dt(double dt) {
  if (!(dt > 0.0) || dt > critical_dt_) {
    throw SimulationError("time step " + std::to_string(dt) + " s outside (0, " +
                          std::to_string(critical_dt_) + "]");
  }
  dt_ = dt;
}

void MpmSolver::build_constraints() {
  const Grid& grid = case_.grid;
  for (const BoundaryCondition& bc : case_.boundary_conditions) {
    for (int j = 0; j < grid.n_nodes_y(); ++j) {
      for (int i = 0; i < grid.n_nodes_x(); ++i) {
        bool selected = false;
        if (bc.where == "left") {
          selected = i == 0;
        } else if (bc.where == "right") {
          selected = i == grid.n_nodes_x() - 1;
        } else if (bc.where == "bottom") {
          selected = j == 0;
        } else if (bc.where == "top") {
          selected = j == grid.n_nodes_y() - 1;
        } else {
          for (const NodeSet& set : case_.node_sets) {
            if (set.name != bc.where) continue;
            const Vec2 x = grid.node_position(i, j);
            const double tol = 1e-9 * grid.cell_size;
            selected = x.x() >= set.box_min.x() - tol && x.x() <= set.box_max.x() + tol &&
                       x.y() >= set.box_min.y() - tol && x.y() <= set.box_max.y() + tol;
          }
        }
        if (selected) grid_.fixed[static_cast<std::size_t>(grid.node_index(i, j))] |= bc.fix;
      }
    }
  }
}

void MpmSolver::build_top_node_loads() {
  const Grid& grid = case_.grid;
  std::vector<char> occupied(static_cast<std::size_t>(grid.n_cells()), 0);
  for (const Vec2& x : particles_.position) {
    occupied[static_cast<std::size_t>(grid.cell_index(grid.cell_i(x.x()), grid.cell_j(x.y())))] = 1;
  }
  // Top node of each node column: the highest node that is a top corner of an occupied cell.
  std::vector<int> top(static_cast<std::size_t>(grid.n_nodes_x()), -1);
  for (int i = 0; i < grid.n_nodes_x(); ++i) {
    for (int j = grid.n_cells_y - 1; j >= 0 && top[static_cast<std::size_t>(i)] < 0; --j) {
      for (const int ci : {i - 1, i}) {
        if (ci >= 0 && ci < grid.n_cells_x &&
            occupied[static_cast<std::size_t>(grid.cell_index(ci, j))]) {
          top[static_cast<std::size_t>(i)] = j + 1;
        }
      }
    }
  }
  const double h = grid.cell_size;
  for (const LoadSpec& load : case_.loads) {
    TopNodeLoad entry;
    if (load.apply_on == LoadTarget::kGridTopNodes) {
      for (int i = 0; i < grid.n_nodes_x(); ++i) {
        if (top[static_cast<std::size_t>(i)] < 0) continue;
        // Integral of the node's hat function over [x0, x1] (consistent nodal force).
        const double xn = grid.origin.x() + i * h;
        double integral = 0.0;
        const double pieces[2][2] = {{xn - h, xn}, {xn, xn + h}};
        for (const auto& piece : pieces) {
          const double a = std::max(piece[0], load.x0), b = std::min(piece[1], load.x1);
          if (b <= a) continue;
          // hat(x) = 1 - |x - xn| / h, integrated exactly (linear on each piece).
          const double ha = 1.0 - std::abs(a - xn) / h, hb = 1.0 - std::abs(b - xn) / h;
          integral += 0.5 * (ha + hb) * (b - a);
        }
        if (integral > 0.0) {
          entry.node.push_back(grid.node_index(i, top[static_cast<std::size_t>(i)]));
          entry.vertical_force_per_kpa.push_back(integral);
        }
      }
    }
    top_loads_.push_back(std::move(entry));
  }
}

double MpmSolver::gravity_factor(double t) const {
  if (gravity_full_ || case_.gravity.ramp_time <= 0.0) return 1.0;
  return std::min(1.0, t / case_.gravity.ramp_time);
}

void MpmSolver::step() {
  if (case_.solver.shape_function == ShapeFunctionKind::kLinear) {
    run_step<2>();
  } else {
    run_step<3>();
  }
}

template <int W>
void MpmSolver::run_step() {
  auto t0 = Clock::now();
  locate_particles<W>();
  times_.locate += seconds_since(t0);

  t0 = Clock::now();
  particles_to_grid<W>(false);
  times_.particles_to_grid += seconds_since(t0);

  t0 = Clock::now();
  external_forces();
  times_.external_forces += seconds_since(t0);

  t0 = Clock::now();
  update_grid();
  times_.update_grid += seconds_since(t0);
  if (velocity_hook_) velocity_hook_(time_, dt_, grid_);

  t0 = Clock::now();
  grid_to_particles<W>();
  times_.grid_to_particles += seconds_since(t0);

  if (case_.solver.scheme == Scheme::kMUSL) {
    t0 = Clock::now();
    particles_to_grid<W>(true);
    const std::size_t n_nodes = grid_.mass.size();
    const double tiny = 1e-12 * particles_.mass.front();
#pragma omp parallel for schedule(static)
    for (std::size_t n = 0; n < n_nodes; ++n) {
      Vec2 v = Vec2::Zero();
      if (grid_.mass[n] > tiny) v = grid_.momentum[n] / grid_.mass[n];
      if (grid_.fixed[n] & kFixX) v.x() = 0.0;
      if (grid_.fixed[n] & kFixY) v.y() = 0.0;
      remapped_velocity_[n] = v;
    }
    times_.remap += seconds_since(t0);
    t0 = Clock::now();
    update_stress<W>(remapped_velocity_);
  } else {
    t0 = Clock::now();
    update_stress<W>(grid_.velocity);
  }
  times_.stress += seconds_since(t0);

  time_ += dt_;
  ++step_;
  check_particles();
}

template <int W>
void MpmSolver::locate_particles() {
  const Grid& grid = case_.grid;
  const std::size_t n = particles_.size();
  const double h = grid.cell_size;
  const double inv_h = 1.0 / h;
  long outside = -1;
#pragma omp parallel for schedule(static) reduction(max : outside)
  for (std::size_t p = 0; p < n; ++p) {
    const Vec2& x = particles_.position[p];
    const int ci = grid.cell_i(x.x()), cj = grid.cell_j(x.y());
    if (ci < 0 || cj < 0 || ci >= grid.n_cells_x || cj >= grid.n_cells_y) {
      outside = std::max(outside, static_cast<long>(p));
      particle_cell_[p] = 0;
      continue;
    }
    particle_cell_[p] = grid.cell_index(ci, cj);
    const double xi = (x.x() - grid.origin.x()) * inv_h - ci;
    const double eta = (x.y() - grid.origin.y()) * inv_h - cj;
    double* f = stencil_[p].data();
    if constexpr (W == 2) {
      stencil_base_[p] = {ci, cj};
      f[0] = 1.0 - xi;
      f[1] = xi;
      f[2] = 1.0 - eta;
      f[3] = eta;
      f[4] = -inv_h;
      f[5] = inv_h;
      f[6] = -inv_h;
      f[7] = inv_h;
    } else {
      const int bi = xi < 0.5 ? ci - 1 : ci;
      const int bj = eta < 0.5 ? cj - 1 : cj;
      stencil_base_[p] = {bi, bj};
      const Vec2& lp = particles_.half_length[p];
      for (int a = 0; a < 3; ++a) {
        const double node_x = grid.origin.x() + (bi + a) * h;
        const double node_y = grid.origin.y() + (bj + a) * h;
        f[a] = gimp_1d(x.x() - node_x, h, lp.x(), f[6 + a]);
        f[3 + a] = gimp_1d(x.y() - node_y, h, lp.y(), f[9 + a]);
      }
      // A node off the grid must carry no weight (the particle domain stays on the grid).
      bool off = false;
      for (int a = 0; a < 3; ++a) {
        if ((bi + a < 0 || bi + a >= grid.n_nodes_x()) && (f[a] != 0.0 || f[6 + a] != 0.0))
          off = true;
        if ((bj + a < 0 || bj + a >= grid.n_nodes_y()) && (f[3 + a] != 0.0 || f[9 + a] != 0.0))
          off = true;
      }
      if (off) outside = std::max(outside, static_cast<long>(p));
    }
  }
  if (outside >= 0) {
    const auto p = static_cast<std::size_t>(outside);
    throw SimulationError(describe_particle(particles_, p) + " at t = " + std::to_string(time_) +
                          " s (step " + std::to_string(step_) +
                          ") has left the grid or its GIMP domain reaches past the grid edge");
  }

  // Bin particles by cell: a stable counting sort, so ids ascend within each cell.
  const int n_cells = grid.n_cells();
  cell_start_.assign(static_cast<std::size_t>(n_cells) + 1, 0);
  for (std::size_t p = 0; p < n; ++p)
    ++cell_start_[static_cast<std::size_t>(particle_cell_[p]) + 1];
  for (int c = 0; c < n_cells; ++c) {
    cell_start_[static_cast<std::size_t>(c) + 1] += cell_start_[static_cast<std::size_t>(c)];
  }
  {
    std::vector<int>& next = occupied_cells_;  // reused as a cursor array
    next.assign(cell_start_.begin(), cell_start_.end() - 1);
    for (std::size_t p = 0; p < n; ++p) {
      sorted_[static_cast<std::size_t>(next[static_cast<std::size_t>(particle_cell_[p])]++)] =
          static_cast<int>(p);
    }
  }
  // Occupied cells by colour class: (i mod s, j mod s), s = 2 (linear) or 4 (GIMP).
  constexpr int s = W == 2 ? 2 : 4;
  for (auto& list : colour_cells_) list.clear();
  for (int c = 0; c < n_cells; ++c) {
    if (cell_start_[static_cast<std::size_t>(c) + 1] == cell_start_[static_cast<std::size_t>(c)])
      continue;
    const int i = c % grid.n_cells_x, j = c / grid.n_cells_x;
    colour_cells_[static_cast<std::size_t>((j % s) * s + (i % s))].push_back(c);
  }
}

template <int W>
void MpmSolver::particles_to_grid(bool momentum_only) {
  const int nnx = case_.grid.n_nodes_x();
  const std::size_t n_nodes = grid_.mass.size();
  if (momentum_only) {
    std::fill(grid_.momentum.begin(), grid_.momentum.end(), Vec2::Zero());
  } else {
    std::fill(grid_.mass.begin(), grid_.mass.end(), 0.0);
    std::fill(grid_.momentum.begin(), grid_.momentum.end(), Vec2::Zero());
    std::fill(grid_.internal_force.begin(), grid_.internal_force.end(), Vec2::Zero());
  }
  (void)n_nodes;
  constexpr int s = W == 2 ? 2 : 4;
#pragma omp parallel
  for (int colour = 0; colour < s * s; ++colour) {
    const std::vector<int>& cells = colour_cells_[static_cast<std::size_t>(colour)];
    const long n_list = static_cast<long>(cells.size());
#pragma omp for schedule(static)
    for (long k = 0; k < n_list; ++k) {
      const int c = cells[static_cast<std::size_t>(k)];
      for (int q = cell_start_[static_cast<std::size_t>(c)];
           q < cell_start_[static_cast<std::size_t>(c) + 1]; ++q) {
        const auto p = static_cast<std::size_t>(sorted_[static_cast<std::size_t>(q)]);
        const StencilView<W> f{stencil_[p].data()};
        const int bi = stencil_base_[p][0], bj = stencil_base_[p][1];
        const double m = particles_.mass[p];
        const Vec2 mv = m * particles_.velocity[p];
        if (momentum_only) {
          for (int b = 0; b < W; ++b) {
            for (int a = 0; a < W; ++a) {
              const double weight = f.nx(a) * f.ny(b);
              if (W == 3 && weight == 0.0) continue;
              grid_.momentum[static_cast<std::size_t>((bj + b) * nnx + bi + a)] += weight * mv;
            }
          }
          continue;
        }
        const double v = particles_.volume[p];
        const Stress& sig = particles_.stress[p];
        for (int b = 0; b < W; ++b) {
          for (int a = 0; a < W; ++a) {
            const double weight = f.nx(a) * f.ny(b);
            const double gx = f.dx(a) * f.ny(b), gy = f.nx(a) * f.dy(b);
            if (W == 3 && weight == 0.0 && gx == 0.0 && gy == 0.0) continue;
            const auto node = static_cast<std::size_t>((bj + b) * nnx + bi + a);
            grid_.mass[node] += weight * m;
            grid_.momentum[node] += weight * mv;
            // f_int = - integral sigma . grad N dV (tension positive).
            grid_.internal_force[node] -=
                v * Vec2(sig[kXX] * gx + sig[kXY] * gy, sig[kXY] * gx + sig[kYY] * gy);
          }
        }
      }
    }
  }
}

void MpmSolver::external_forces() {
  // Body force: sum_p N_I m_p g = m_I g.
  const double gy = -case_.gravity.g * gravity_factor(time_);
  const std::size_t n_nodes = grid_.mass.size();
  for (std::size_t n = 0; n < n_nodes; ++n) grid_.external_force[n] = Vec2(0.0, grid_.mass[n] * gy);
  if (!loads_active_) return;
  for (std::size_t k = 0; k < case_.loads.size(); ++k) {
    const LoadSpec& load = case_.loads[k];
    if (load.apply_on != LoadTarget::kGridTopNodes) continue;
    const double q = load.pressure * load.time_function.factor(time_);
    const TopNodeLoad& top = top_loads_[k];
    for (std::size_t i = 0; i < top.node.size(); ++i) {
      grid_.external_force[static_cast<std::size_t>(top.node[i])].y() -=
          q * top.vertical_force_per_kpa[i];
    }
  }
  if (hook_) hook_(time_, grid_, grid_.external_force);
}

void MpmSolver::update_grid() {
  const std::size_t n_nodes = grid_.mass.size();
  const double tiny = 1e-12 * particles_.mass.front();
  const double alpha = damping_;
  const double dt = dt_;
#pragma omp parallel for schedule(static)
  for (std::size_t n = 0; n < n_nodes; ++n) {
    const double m = grid_.mass[n];
    if (m <= tiny) {
      velocity_before_update_[n] = Vec2::Zero();
      grid_.velocity[n] = Vec2::Zero();
      grid_.acceleration[n] = Vec2::Zero();
      continue;
    }
    Vec2 v = grid_.momentum[n] / m;
    const Vec2 f = grid_.internal_force[n] + grid_.external_force[n];
    // Local (Cundall) damping: a force opposing the velocity, proportional to the unbalanced
    // force, per direction.
    Vec2 damping_force = Vec2::Zero();
    for (int d = 0; d < 2; ++d) {
      const double sign = v[d] > 0.0 ? 1.0 : (v[d] < 0.0 ? -1.0 : 0.0);
      damping_force[d] = -alpha * std::abs(f[d]) * sign;
    }
    Vec2 a = (f + damping_force) / m;
    const unsigned fixed = grid_.fixed[n];
    if (fixed & kFixX) a.x() = v.x() = 0.0;
    if (fixed & kFixY) a.y() = v.y() = 0.0;
    velocity_before_update_[n] = v;
    grid_.acceleration[n] = a;
    grid_.velocity[n] = v + a * dt;
  }
  // Work of the external and damping forces over the step (serial: a fixed summation order).
  double external = 0.0, damping = 0.0;
  for (std::size_t n = 0; n < n_nodes; ++n) {
    if (grid_.mass[n] <= tiny) continue;
    const Vec2 mid = 0.5 * (velocity_before_update_[n] + grid_.velocity[n]);
    external += grid_.external_force[n].dot(mid) * dt;
    const Vec2 f = grid_.internal_force[n] + grid_.external_force[n];
    const Vec2 a = grid_.acceleration[n];
    damping += (a * grid_.mass[n] - f).dot(mid) * dt;  // damping force (zero where fixed)
  }
  external_work_ += external;
  damping_work_ += damping;
}

template <int W>
void MpmSolver::grid_to_particles() {
  const int nnx = case_.grid.n_nodes_x();
  const std::size_t n = particles_.size();
  const double dt = dt_;
  long bad = -1;
  double max_speed = 0.0;
#pragma omp parallel for schedule(static) reduction(max : bad, max_speed)
  for (std::size_t p = 0; p < n; ++p) {
    const StencilView<W> f{stencil_[p].data()};
    const int bi = stencil_base_[p][0], bj = stencil_base_[p][1];
    Vec2 a = Vec2::Zero(), v = Vec2::Zero();
    for (int b = 0; b < W; ++b) {
      for (int a_ = 0; a_ < W; ++a_) {
        const double weight = f.nx(a_) * f.ny(b);
        if (W == 3 && weight == 0.0) continue;
        const auto node = static_cast<std::size_t>((bj + b) * nnx + bi + a_);
        a += weight * grid_.acceleration[node];
        v += weight * grid_.velocity[node];
      }
    }
    particles_.velocity[p] += dt * a;  // FLIP
    particles_.position[p] += dt * v;
    const double speed = particles_.velocity[p].norm();
    if (!(speed < 1e300) || !particles_.position[p].allFinite())
      bad = std::max(bad, static_cast<long>(p));
    max_speed = std::max(max_speed, speed);
  }
  bad_particle_ = bad;
  max_speed_ = max_speed;
}

template <int W>
void MpmSolver::update_stress(const std::vector<Vec2>& node_velocity) {
  const int nnx = case_.grid.n_nodes_x();
  const std::size_t n = particles_.size();
  const double dt = dt_;
  const std::vector<MaterialRecord>& materials = case_.materials;
  long bad = -1;
#pragma omp parallel for schedule(static) reduction(max : bad)
  for (std::size_t p = 0; p < n; ++p) {
    const StencilView<W> f{stencil_[p].data()};
    const int bi = stencil_base_[p][0], bj = stencil_base_[p][1];
    Mat2 l = Mat2::Zero();  // velocity gradient, L(i, j) = d v_i / d x_j
    for (int b = 0; b < W; ++b) {
      for (int a = 0; a < W; ++a) {
        const double gx = f.dx(a) * f.ny(b), gy = f.nx(a) * f.dy(b);
        if (W == 3 && gx == 0.0 && gy == 0.0) continue;
        const Vec2& v = node_velocity[static_cast<std::size_t>((bj + b) * nnx + bi + a)];
        l(0, 0) += v.x() * gx;
        l(0, 1) += v.x() * gy;
        l(1, 0) += v.y() * gx;
        l(1, 1) += v.y() * gy;
      }
    }
    const Strain de = strain_increment(l, dt);
    Stress& sig = particles_.stress[p];
    jaumann_rotate(l, dt, sig);
    const Stress rotated = sig;
    std::visit([&](const auto& model) { model.update(de, sig, particles_.state[p]); },
               materials[static_cast<std::size_t>(particles_.material[p])].model);
    const double volume_before = particles_.volume[p];
    particles_.deformation_gradient[p] =
        update_deformation_gradient(l, dt, particles_.deformation_gradient[p]);
    particles_.volume[p] =
        particles_.deformation_gradient[p].determinant() * particles_.initial_volume[p];
    const Stress mid = 0.5 * (rotated + sig);
    internal_work_increment_[p] = 0.5 * (volume_before + particles_.volume[p]) *
                                  (mid[kXX] * de[kXX] + mid[kYY] * de[kYY] + mid[kXY] * de[kXY]);
    if (!std::isfinite(internal_work_increment_[p])) bad = std::max(bad, static_cast<long>(p));
  }
  bad_particle_ = std::max(bad_particle_, bad);
  double work = 0.0;
  for (std::size_t p = 0; p < n; ++p) work += internal_work_increment_[p];
  internal_work_ += work;
}

void MpmSolver::check_particles() {
  // bad_particle_ and max_speed_ are gathered by grid_to_particles and update_stress.
  if (bad_particle_ >= 0) {
    throw SimulationError("non-finite value (NaN or inf) at " +
                          describe_particle(particles_, static_cast<std::size_t>(bad_particle_)) +
                          " at t = " + std::to_string(time_) + " s (step " + std::to_string(step_) +
                          ")");
  }
  // Courant condition with the material speed added to the wave speed.
  if ((max_wave_speed_ + max_speed_) * dt_ > case_.grid.cell_size) {
    throw SimulationError("CFL condition violated at t = " + std::to_string(time_) + " s (step " +
                          std::to_string(step_) + "): (c_p + |v|max) dt = " +
                          std::to_string((max_wave_speed_ + max_speed_) * dt_) +
                          " m > h = " + std::to_string(case_.grid.cell_size) + " m");
  }
}

EnergyBalance MpmSolver::energy() const {
  EnergyBalance e;
  for (std::size_t p = 0; p < particles_.size(); ++p) {
    e.kinetic_energy += 0.5 * particles_.mass[p] * particles_.velocity[p].squaredNorm();
    e.momentum += particles_.mass[p] * particles_.velocity[p];
  }
  e.external_work = external_work_;
  e.internal_work = internal_work_;
  e.damping_work = damping_work_;
  return e;
}

void MpmSolver::apply_k0_stress() {
  for (std::size_t p = 0; p < particles_.size(); ++p) {
    const BodySpec& body = case_.bodies[static_cast<std::size_t>(particles_.body[p])];
    const MaterialRecord& m = case_.materials[static_cast<std::size_t>(particles_.material[p])];
    const double nu = elastic_parameters(m.model).poisson_ratio;
    const double k0 = case_.initial_stress.k0 ? *case_.initial_stress.k0 : nu / (1.0 - nu);
    const Vec2& x = particles_.position[p];
    const double depth = polygon_top(body.polygon, x.x()) - x.y();
    const double sigma_v = -m.unit_weight * std::max(depth, 0.0);
    particles_.stress[p] = Stress(k0 * sigma_v, sigma_v, 0.0, k0 * sigma_v);
  }
}

void MpmSolver::initialise_stress() {
  switch (case_.initial_stress.method) {
    case InitialStressMethod::kZero:
      return;
    case InitialStressMethod::kK0:
      apply_k0_stress();
      gravity_full_ = true;
      return;
    case InitialStressMethod::kGravity:
      break;
  }
  // Gravity loading: full gravity on the unstressed body, heavily damped, no surface loads,
  // until the kinetic energy has decayed; then the velocities and displacements are reset.
  const double saved_damping = damping_;
  damping_ = case_.initial_stress.damping;
  gravity_full_ = true;
  loads_active_ = false;
  double peak = 0.0;
  while (true) {
    step();
    const double ke = energy().kinetic_energy;
    peak = std::max(peak, ke);
    if (step_ > 10 && peak > 0.0 && ke < case_.initial_stress.kinetic_energy_ratio * peak) break;
    if (time_ > case_.initial_stress.max_time) {
      throw SimulationError("gravity loading did not reach kinetic energy ratio " +
                            std::to_string(case_.initial_stress.kinetic_energy_ratio) + " within " +
                            std::to_string(case_.initial_stress.max_time) + " s (ratio now " +
                            std::to_string(ke / peak) + ")");
    }
  }
  damping_ = saved_damping;
  loads_active_ = true;
  for (std::size_t p = 0; p < particles_.size(); ++p) {
    particles_.velocity[p].setZero();
    particles_.reference_position[p] = particles_.position[p];
  }
  initial_stress_steps_ = step_;
  time_ = 0.0;
  step_ = 0;
  external_work_ = internal_work_ = damping_work_ = 0.0;
}

void MpmSolver::update_stress_from_grid_velocity(const std::vector<Vec2>& node_velocity) {
  if (node_velocity.size() != grid_.mass.size()) {
    throw std::invalid_argument("update_stress_from_grid_velocity: one velocity per grid node");
  }
  if (case_.solver.shape_function == ShapeFunctionKind::kLinear) {
    locate_particles<2>();
    update_stress<2>(node_velocity);
  } else {
    locate_particles<3>();
    update_stress<3>(node_velocity);
  }
}

template void MpmSolver::run_step<2>();
template void MpmSolver::run_step<3>();

}  // namespace pfm

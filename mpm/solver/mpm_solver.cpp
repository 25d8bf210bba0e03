#include "mpm/solver/mpm_solver.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include "mpm/boundary/surface_load.hpp"
#include "mpm/core/json_input.hpp"
#include "mpm/core/kinematics.hpp"
#include "mpm/step/body_fill.hpp"
#include "mpm/step/stage_timer.hpp"

namespace pfm {

namespace {

// Sums over particles or nodes (energies) are taken per fixed block of this many items, then
// over the blocks, both in index order: deterministic, and parallel over the blocks.
constexpr std::size_t kSumBlock = 1024;

// Every loop is shared out dynamically, by blocks (particle and node blocks, bands, chunks):
// a thread that the operating system holds back then delays the others by one block at most.
// Nodes per block of the plain node loops:
constexpr int kNodeChunk = 4096;

// Below this many particles + nodes a step takes some ten microseconds, less than the threads
// would spend meeting each other (and far more when they compete for the cores with other
// jobs), so the stages run on one thread; results do not depend on it.
constexpr std::size_t kMinParallelItems = 1024;

std::string describe_particle(const Particles& particles, std::size_t p) {
  std::ostringstream s;
  s << "particle " << p << " at (" << particles.position[p].x() << ", " << particles.position[p].y()
    << ")";
  return s.str();
}

}  // namespace

MpmSolver::MpmSolver(const Case& c) : case_(c) {
  if (c.solver.type != SolverType::kExplicit) {
    throw InputError(c.file + ": /solver/type: the explicit MPM takes \"explicit\" cases; " +
                     "pfm-mpm run gives an \"implicit\" one to the implicit solver");
  }
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
  grid_.body_force.assign(static_cast<std::size_t>(n_nodes), Vec2::Zero());
  grid_.velocity.assign(static_cast<std::size_t>(n_nodes), Vec2::Zero());
  grid_.acceleration.assign(static_cast<std::size_t>(n_nodes), Vec2::Zero());
  grid_.fixed.assign(static_cast<std::size_t>(n_nodes), kFixNone);
  grid_.reaction.assign(static_cast<std::size_t>(n_nodes), Vec2::Zero());
  node_energy_.assign((static_cast<std::size_t>(n_nodes) + kSumBlock - 1) / kSumBlock, {});
  remapped_velocity_.assign(static_cast<std::size_t>(n_nodes), Vec2::Zero());
  remapped_momentum_.assign(static_cast<std::size_t>(n_nodes), Vec2::Zero());
  if (case_.solver.xpic_order > 1) {
    for (std::vector<Vec2>* field : {&xpic_term_, &xpic_iterate_, &xpic_sum_}) {
      field->assign(static_cast<std::size_t>(n_nodes), Vec2::Zero());
    }
  }
  // The loads' nodal forces, then the constraints' (boundary_constraint.hpp).
  load_work_recorder_ = LoadWorkRecorder(case_.loads.size() + case_.constraints.size());
  counters_.energy.load_work_by_load.assign(case_.loads.size(), 0.0);
  build_constraints();

  // Critical time step from the P-wave speed of the stiffest material (thesis eq. 3.24 is
  // conditionally stable: dt <= h / c_p).
  max_wave_speed_ = largest_wave_speed(case_);
  critical_dt_ = case_.grid.cell_size / max_wave_speed_;
  if (case_.time.dt) {
    if (*case_.time.dt > critical_dt_) {
      throw InputError(
          case_.file + ": /time/dt: " + std::to_string(*case_.time.dt) +
          " s exceeds the critical time step h / c_p = " + std::to_string(critical_dt_) + " s");
    }
    counters_.dt = *case_.time.dt;
  } else {
    counters_.dt = case_.time.cfl * critical_dt_;
  }
  counters_.damping = case_.solver.damping;
  const double fraction = case_.solver.outer_node_fraction;
  if (fraction > 0.0) {
    extension_ = BasisExtension(case_.grid, case_.solver.shape_function, fraction);
    extension_density_ = largest_density(particles_);
  }
  top_loads_ = GridTopLoads(case_, particles_);
  point_energy_blocks_.assign((particles_.size() + kSumBlock - 1) / kSumBlock, {});
  kinetic_blocks_.assign(point_energy_blocks_.size(), 0.0);
  for (const MaterialRecord& m : case_.materials) {
    material_constants_.push_back(material_constants(m.model));
  }

  // Work arrays. Bands: about 128 of them on the grid (enough for load balance, a function of
  // the grid alone so that results do not depend on the thread count), at least 1 cell row
  // (linear) or 3 (GIMP and B-splines: a particle in cell row j reaches node rows j - 1 to
  // j + 2 at most, and two bands of one parity must share no node).
  const std::size_t n = particles_.size();
  const int width = stencil_width(case_.solver.shape_function);
  if (width == 2) {
    linear_stencil_.resize(n);
  } else {
    stencil_factors_.resize(n * 4 * static_cast<std::size_t>(width));
    stencil_base_.resize(n);
  }
  const int n_rows = case_.grid.n_cells_y;
  band_rows_ = std::max(width > 2 ? 3 : 1, (n_rows + 127) / 128);
  n_bands_ = (n_rows + band_rows_ - 1) / band_rows_;
  n_chunks_ = static_cast<int>(std::clamp<std::size_t>(n / 4096, 1, 64));
  parallel_ = n + static_cast<std::size_t>(n_nodes) >= kMinParallelItems;
  if (case_.solver.mean_dilatation) {
    particle_cell_.assign(n, 0);
    velocity_gradient_.assign(n, Mat2::Zero());
    cell_volume_.assign(static_cast<std::size_t>(case_.grid.n_cells()), 0.0);
    cell_trace_.assign(static_cast<std::size_t>(case_.grid.n_cells()), 0.0);
  }
  particle_band_.resize(n);
  chunk_offsets_.resize(static_cast<std::size_t>(n_chunks_) * static_cast<std::size_t>(n_bands_));
  band_start_.resize(static_cast<std::size_t>(n_bands_) + 1);
  sorted_.resize(n);
}

void MpmSolver::set_dt(double dt) {
  if (!(dt > 0.0) || dt > critical_dt_) {
    throw SimulationError("time step " + std::to_string(dt) + " s outside (0, " +
                          std::to_string(critical_dt_) + "]");
  }
  counters_.dt = dt;
}

void MpmSolver::build_constraints() {
  const Grid& grid = case_.grid;
  prescribed_ = PrescribedVelocity(case_.boundary_conditions, grid_.fixed.size());
  std::vector<unsigned> moving(grid_.fixed.size(), kFixNone);  // components a moving one fixes
  for (std::size_t k = 0; k < case_.boundary_conditions.size(); ++k) {
    const BoundaryCondition& bc = case_.boundary_conditions[k];
    for (int j = 0; j < grid.n_nodes_y(); ++j) {
      for (int i = 0; i < grid.n_nodes_x(); ++i) {
        if (!grid_node_held(case_, bc, i, j)) continue;
        grid_.fixed[static_cast<std::size_t>(grid.node_index(i, j))] |= bc.fix;
        if (bc.moving) moving[static_cast<std::size_t>(grid.node_index(i, j))] |= bc.fix;
        prescribed_.add(k, static_cast<std::size_t>(grid.node_index(i, j)));
      }
    }
  }
  std::vector<unsigned> at_zero(grid_.fixed.size());
  for (std::size_t node = 0; node < at_zero.size(); ++node) {
    at_zero[node] = grid_.fixed[node] & ~moving[node];
  }
  mirror_ = WallMirror(grid, case_.solver.shape_function, at_zero);
}

double MpmSolver::gravity_factor(double t) const {
  if (counters_.gravity_full || case_.gravity.ramp_time <= 0.0) return 1.0;
  return std::min(1.0, t / case_.gravity.ramp_time);
}

void MpmSolver::step() {
  switch (stencil_width(case_.solver.shape_function)) {
    case 2:
      run_step<2>();
      break;
    case 3:
      run_step<3>();
      break;
    default:
      run_step<4>();
  }
}

template <int W>
void MpmSolver::run_step() {
  {
    StageTimer timer(times_.locate);
    locate_particles<W>(true);
  }
  // The stages in the scheme's order (step_scheme.hpp). The grid-velocity hook (the surface
  // markers' advection) runs within the grid update's time.
  struct Stages {
    MpmSolver& s;
    void particles_to_grid() {
      s.particles_to_grid<W>();
      s.tie_outer_nodes();
    }
    void external_forces() { s.external_forces(); }
    void update_grid() {
      s.update_grid();
      if (s.velocity_hook_) s.velocity_hook_(s.step_view(), s.grid_);
    }
    void grid_to_particles(bool musl) {
      if (musl) {
        s.grid_to_particles<W, true>();
      } else {
        s.grid_to_particles<W, false>();
      }
    }
    void remap() { s.remap(); }
    void update_stress(bool musl) {
      s.update_stress<W>(musl ? s.remapped_velocity_ : s.grid_.velocity);
    }
  };
  run_stages(case_.solver.scheme, Stages{*this}, times_);
  counters_.time += counters_.dt;
  ++counters_.step;
  check_particles();
}

// A particle's shape functions as 1D factors (the 2D functions are their tensor products):
// values nx, ny and derivatives dx, dy along x and y of the W x W nodes from the base node,
// whose index is node0 (node (a, b) of the stencil is node0 + b * n_nodes_x + a).
template <int W>
struct MpmSolver::Shape {
  double nx[W], ny[W], dx[W], dy[W];
  std::size_t node0;
};

// Reads the stored stencils (raw pointers: the kernels below store through Eigen packets, which
// may alias anything, so vector members would be reloaded at every particle).
template <int W>
struct MpmSolver::StencilReader {
  const LinearStencil* linear;
  const double* factors;  ///< 4 W per particle
  const std::array<int, 2>* base;
  int nnx;
  double inv_h;

  Shape<W> operator()(std::size_t p) const {
    Shape<W> s;
    if constexpr (W == 2) {
      const LinearStencil& l = linear[p];
      s.nx[0] = 1.0 - l.xi;
      s.nx[1] = l.xi;
      s.ny[0] = 1.0 - l.eta;
      s.ny[1] = l.eta;
      s.dx[0] = s.dy[0] = -inv_h;
      s.dx[1] = s.dy[1] = inv_h;
      s.node0 = static_cast<std::size_t>(l.j * nnx + l.i);
    } else {
      // Storage: W values along x, W along y, W x-derivatives, W y-derivatives.
      const double* f = factors + 4 * W * p;
      for (int a = 0; a < W; ++a) {
        s.nx[a] = f[a];
        s.ny[a] = f[W + a];
        s.dx[a] = f[2 * W + a];
        s.dy[a] = f[3 * W + a];
      }
      s.node0 = static_cast<std::size_t>(base[p][1] * nnx + base[p][0]);
    }
    return s;
  }
};

template <int W>
MpmSolver::StencilReader<W> MpmSolver::stencil_reader() const {
  return {linear_stencil_.data(), stencil_factors_.data(), stencil_base_.data(),
          case_.grid.n_nodes_x(), 1.0 / case_.grid.cell_size};
}

template <int W>
void MpmSolver::locate_particles(bool clear_grid) {
  const Grid& grid = case_.grid;
  const std::size_t n = particles_.size();
  const double h = grid.cell_size;
  const double inv_h = 1.0 / h;
  const double x0 = grid.origin.x(), y0 = grid.origin.y();
  const double n_cells_x = grid.n_cells_x, n_cells_y = grid.n_cells_y;
  const int n_bands = n_bands_, n_chunks = n_chunks_, band_rows = band_rows_;
  const Vec2* position = particles_.position.data();
  const Vec2* half_length = particles_.half_length.data();
  LinearStencil* linear = linear_stencil_.data();
  double* factors = stencil_factors_.data();
  std::array<int, 2>* stencil_base = stencil_base_.data();
  const bool gimp = case_.solver.shape_function == ShapeFunctionKind::kGimp;
  const int degree = shape_degree(case_.solver.shape_function);
  int* particle_band = particle_band_.data();
  int* particle_cell = particle_cell_.data();  // null without the mean dilatation
  const int n_cells_row = grid.n_cells_x;
  int* chunk_offsets = chunk_offsets_.data();
  std::fill(chunk_offsets_.begin(), chunk_offsets_.end(), 0);
  const std::size_t n_nodes = grid_.mass.size();
  double* mass = grid_.mass.data();
  Vec2* momentum = grid_.momentum.data();
  Vec2* force = grid_.internal_force.data();
  Vec2* body = case_.manufactured ? grid_.body_force.data() : nullptr;
  long outside = -1;
#pragma omp parallel reduction(max : outside) if (parallel_)
  {
    // The nodal sums of particles_to_grid start from zero (cleared here, where the threads have
    // to meet anyway).
    if (clear_grid) {
#pragma omp for schedule(dynamic, kNodeChunk) nowait
      for (std::size_t node = 0; node < n_nodes; ++node) {
        mass[node] = 0.0;
        momentum[node].setZero();
        force[node].setZero();
        if (body) body[node].setZero();
      }
    }
    // Shape functions and band of every particle, counted per band in fixed chunks of particles.
#pragma omp for schedule(dynamic, 1) nowait
    for (int k = 0; k < n_chunks; ++k) {
      int* count = chunk_offsets + static_cast<std::size_t>(k) * n_bands;
      const std::size_t begin =
          n * static_cast<std::size_t>(k) / static_cast<std::size_t>(n_chunks);
      const std::size_t end =
          n * static_cast<std::size_t>(k + 1) / static_cast<std::size_t>(n_chunks);
      for (std::size_t p = begin; p < end; ++p) {
        const Vec2 x = position[p];
        // The cell as Grid::cell_i / cell_j: floor((x - x0) / h), here as a truncation of a
        // value checked to lie in [0, n_cells) first (also false for NaN).
        const double tx = (x.x() - x0) / h, ty = (x.y() - y0) / h;
        if (!(tx >= 0.0 && tx < n_cells_x && ty >= 0.0 && ty < n_cells_y)) {
          outside = std::max(outside, static_cast<long>(p));
          particle_band[p] = 0;
          continue;
        }
        const int ci = static_cast<int>(tx), cj = static_cast<int>(ty);
        const int band = cj / band_rows;
        particle_band[p] = band;
        if (particle_cell) particle_cell[p] = cj * n_cells_row + ci;
        ++count[band];
        const double xi = (x.x() - x0) * inv_h - ci;
        const double eta = (x.y() - y0) * inv_h - cj;
        if constexpr (W == 2) {
          linear[p] = {xi, eta, ci, cj};
        } else if (!gimp) {
          // B-splines: W values along x, W along y, W d/dx, W d/dy.
          double* f = factors + 4 * W * p;
          const int bi = bspline_1d(degree, grid.n_cells_x, tx, f, f + 2 * W);
          const int bj = bspline_1d(degree, grid.n_cells_y, ty, f + W, f + 3 * W);
          for (int a = 0; a < 2 * W; ++a) f[2 * W + a] *= inv_h;
          stencil_base[p] = {bi, bj};
        } else {
          double* f = factors + 4 * W * p;
          const int bi = xi < 0.5 ? ci - 1 : ci;
          const int bj = eta < 0.5 ? cj - 1 : cj;
          stencil_base[p] = {bi, bj};
          const Vec2& lp = half_length[p];
          for (int a = 0; a < 3; ++a) {
            const double node_x = x0 + (bi + a) * h;
            const double node_y = y0 + (bj + a) * h;
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
    }
  }
  if (outside >= 0) {
    const auto p = static_cast<std::size_t>(outside);
    throw SimulationError(describe_particle(particles_, p) +
                          " at t = " + std::to_string(counters_.time) + " s (step " +
                          std::to_string(counters_.step) +
                          ") has left the grid or its GIMP domain reaches past the grid edge");
  }

  // Stable bucket sort by band: ids ascend within each band (the result is unique, so it does
  // not depend on how the chunks are shared out). Counts become write cursors.
  int offset = 0;
  for (int b = 0; b < n_bands; ++b) {
    band_start_[static_cast<std::size_t>(b)] = offset;
    for (int k = 0; k < n_chunks; ++k) {
      int& c = chunk_offsets[static_cast<std::size_t>(k) * n_bands + b];
      const int count = c;
      c = offset;
      offset += count;
    }
  }
  band_start_[static_cast<std::size_t>(n_bands)] = offset;
  int* sorted = sorted_.data();
#pragma omp parallel for schedule(dynamic, 1) if (parallel_)
  for (int k = 0; k < n_chunks; ++k) {
    int* cursor = chunk_offsets + static_cast<std::size_t>(k) * n_bands;
    const std::size_t begin = n * static_cast<std::size_t>(k) / static_cast<std::size_t>(n_chunks);
    const std::size_t end =
        n * static_cast<std::size_t>(k + 1) / static_cast<std::size_t>(n_chunks);
    for (std::size_t p = begin; p < end; ++p) {
      sorted[cursor[particle_band[p]]++] = static_cast<int>(p);
    }
  }
}

template <int W>
void MpmSolver::particles_to_grid() {
  const std::size_t nnx = static_cast<std::size_t>(case_.grid.n_nodes_x());
  const std::size_t n_nodes = grid_.mass.size();
  const StencilReader<W> stencil = stencil_reader<W>();
  double* mass = grid_.mass.data();  // cleared by locate_particles
  Vec2* momentum = grid_.momentum.data();
  Vec2* force = grid_.internal_force.data();
  Vec2* remapped_momentum = remapped_momentum_.data();
  Vec2* external = grid_.external_force.data();
  Vec2* body = grid_.body_force.data();  // cleared by locate_particles when manufactured
  const double gravity = -case_.gravity.g * gravity_factor(counters_.time);  // along y
  const ManufacturedSolution* manufactured = case_.manufactured ? &*case_.manufactured : nullptr;
  const double time = counters_.time;
  const Vec2* reference_position = particles_.reference_position.data();
  const bool musl = case_.solver.scheme == Scheme::kMUSL;
  const double* particle_mass = particles_.mass.data();
  const Vec2* particle_velocity = particles_.velocity.data();
  const double* particle_volume = particles_.volume.data();
  const Stress* particle_stress = particles_.stress.data();
  const int* band_start = band_start_.data();
  const int* sorted = sorted_.data();
  const int n_bands = n_bands_;
  const bool mean_dilatation = case_.solver.mean_dilatation;
  const int* particle_cell = particle_cell_.data();
  double* cell_volume = cell_volume_.data();
  double* cell_trace = cell_trace_.data();
  auto scatter_band = [&](int band) {
    if (mean_dilatation) {
      // The cells' mean in-plane stress trace over their particles (B-bar's internal force).
      clear_band_cells(band);
      for (int q = band_start[band]; q < band_start[band + 1]; ++q) {
        const auto p = static_cast<std::size_t>(sorted[q]);
        const auto c = static_cast<std::size_t>(particle_cell[p]);
        cell_volume[c] += particle_volume[p];
        cell_trace[c] += particle_volume[p] * (particle_stress[p][kXX] + particle_stress[p][kYY]);
      }
    }
    for (int q = band_start[band]; q < band_start[band + 1]; ++q) {
      const auto p = static_cast<std::size_t>(sorted[q]);
      const Shape<W> f = stencil(p);
      const double m = particle_mass[p];
      Stress sig = particle_stress[p];
      if (mean_dilatation) {
        const auto c = static_cast<std::size_t>(particle_cell[p]);
        sig = mean_dilatation_stress(sig, cell_trace[c] / cell_volume[c]);
      }
      // A manufactured solution's body force m_p b(X_p, t) at the start of the step.
      const PointShare share{m,
                             m * particle_velocity[p],
                             particle_volume[p],
                             Vec2(sig[kXX], sig[kXY]),
                             Vec2(sig[kXY], sig[kYY]),
                             manufactured
                                 ? Vec2(m * manufactured->body_force(reference_position[p], time))
                                 : Vec2::Zero()};
      for (int b = 0; b < W; ++b) {
        for (int a = 0; a < W; ++a) {
          const double weight = f.nx[a] * f.ny[b];
          const double gx = f.dx[a] * f.ny[b], gy = f.nx[a] * f.dy[b];
          if (W > 2 && weight == 0.0 && gx == 0.0 && gy == 0.0) continue;
          const std::size_t node = f.node0 + static_cast<std::size_t>(b) * nnx + a;
          add_to_node(share, weight, gx, gy, manufactured != nullptr, mass[node], momentum[node],
                      force[node], body[node]);
        }
      }
    }
  };
#pragma omp parallel if (parallel_)
  {
    // The MUSL remap sums start from zero too (grid_to_particles).
    if (musl) {
#pragma omp for schedule(dynamic, kNodeChunk) nowait
      for (std::size_t node = 0; node < n_nodes; ++node) remapped_momentum[node].setZero();
    }
    // Even bands, then odd bands: bands of one parity share no node.
#pragma omp for schedule(dynamic, 1)
    for (int band = 0; band < n_bands; band += 2) scatter_band(band);
#pragma omp for schedule(dynamic, 1)
    for (int band = 1; band < n_bands; band += 2) scatter_band(band);
      // Body force on the finished masses: sum_p N_I m_p g = m_I g (external_forces adds the
      // surface loads).
#pragma omp for schedule(dynamic, kNodeChunk) nowait
    for (std::size_t node = 0; node < n_nodes; ++node) {
      // A manufactured solution has no gravity (case.cpp): its body force stays as summed.
      if (!manufactured) body[node] = Vec2(0.0, mass[node] * gravity);
      external[node] = body[node];
    }
  }
}

void MpmSolver::external_forces() {
  // The body force is in place (particles_to_grid); the surface loads are added to it.
  load_work_recorder_.clear();
  if (!counters_.loads_active) return;
  for (std::size_t k = 0; k < case_.loads.size(); ++k) {
    const LoadSpec& load = case_.loads[k];
    if (load.apply_on != LoadTarget::kGridTopNodes) continue;
    const double q = load.pressure * load.time_function.factor(counters_.time);
    top_loads_.apply(
        k, q, particles_, extension_.enabled(),
        [&](std::size_t node) { return grid_.mass[node] <= top_loads_.light_node_mass(); },
        [&](std::size_t node, const Vec2& force) {
          grid_.external_force[node] += force;
          load_work_recorder_.add(k, node, force);
        });
  }
  if (hook_) hook_(step_view(), grid_, grid_.external_force);
  mirror_.gather_added(std::span<Vec2>(grid_.external_force));
  load_work_recorder_.mirror(mirror_);
  if (extension_.enabled()) {
    // A load on a node that no particle reaches (its boundary within the node's support) goes
    // through a tie as well.
    loaded_massless_.clear();
    for (std::size_t node = 0; node < grid_.mass.size(); ++node) {
      if (!(grid_.mass[node] > 0.0) && extension_.tie_of(static_cast<int>(node)) < 0 &&
          grid_.external_force[node] != grid_.body_force[node]) {
        loaded_massless_.push_back(static_cast<int>(node));
      }
    }
    if (!loaded_massless_.empty()) {
      extension_.tie_massless(loaded_massless_, grid_.fixed, prescribed_.start(),
                              prescribed_.end());
    }
    extension_.gather(std::span<Vec2>(grid_.external_force));
    load_work_recorder_.tie(extension_);
  }
}

void MpmSolver::tie_outer_nodes() {
  if (extension_.enabled()) {
    grid_.ties = &extension_.ties();  // set anew each step: the solver may have been moved
    prescribed_.update(counters_.time, counters_.dt);
    extension_.classify(grid_.mass, extension_density_, grid_.fixed, prescribed_.start(),
                        prescribed_.end());
  }
  // What the particles gave the nodes, gathered by the mirrors first (a node behind a wall may
  // be tied too, by its free component), then by the ties.
  const std::array<std::vector<Vec2>*, 4> gathered = {&grid_.momentum, &grid_.internal_force,
                                                      &grid_.body_force, &grid_.external_force};
  if (!mirror_.empty()) {
    mirror_.prepare(grid_.mass, extension_.enabled() ? &extension_ : nullptr);
    for (std::vector<Vec2>* values : gathered) mirror_.gather(std::span<Vec2>(*values));
  }
  if (extension_.enabled()) {
    extension_.gather(std::span<double>(grid_.mass));
    for (std::vector<Vec2>* values : gathered) extension_.gather(std::span<Vec2>(*values));
  }
  // The loads come next (external_forces): the mirrors gather what they add.
  mirror_.hold(grid_.external_force);
}

void MpmSolver::update_grid() {
  prescribed_.update(counters_.time, counters_.dt);
  const std::size_t n_nodes = grid_.mass.size();
  const double tiny = 1e-12 * particles_.mass.front();
  const double alpha = counters_.damping;
  const double dt = counters_.dt;
  NodeEnergy* node_energy = node_energy_.data();
  const std::size_t n_blocks = node_energy_.size();
#pragma omp parallel for schedule(dynamic, 1) if (parallel_)
  for (std::size_t k = 0; k < n_blocks; ++k) {
    // The ledger terms of the grid update, per block of nodes (energy_ledger.hpp).
    NodeEnergy block;
    update_nodes(grid_, k * kSumBlock, std::min(n_nodes, (k + 1) * kSumBlock), prescribed_.start(),
                 prescribed_.end(), tiny, alpha, case_.solver.damping_form, dt, block);
    node_energy[k] = block;
  }
  // The outer nodes move as the extended functions say (basis_extension.hpp).
  extension_.extrapolate(std::span<Vec2>(grid_.velocity));
  extension_.extrapolate(std::span<Vec2>(grid_.acceleration));
  mirror_.extrapolate(std::span<Vec2>(grid_.velocity));
  mirror_.extrapolate(std::span<Vec2>(grid_.acceleration));
  NodeEnergy step;
  for (std::size_t k = 0; k < n_blocks; ++k) step.add(node_energy[k]);
  if (kinetic_stale_) counters_.energy.particle_kinetic = particle_kinetic_energy();
  kinetic_stale_ = false;
  counters_.energy.add_grid_update(step);
  grid_kinetic_after_ = step.kinetic_after;
  step_work_.assign(case_.loads.size() + case_.constraints.size(), 0.0);
  load_work_recorder_.book(counters_.dt, tiny, grid_.mass, grid_.momentum, grid_.velocity,
                           grid_.fixed, prescribed_.start(), step_work_);
  EnergyLedger& ledger = counters_.energy;
  for (std::size_t k = 0; k < case_.loads.size(); ++k) ledger.load_work_by_load[k] += step_work_[k];
  // The constraints' forces went to the grid as external forces, so update_node booked their
  // work as load work: it is the constraints'.
  for (std::size_t k = case_.loads.size(); k < step_work_.size(); ++k) {
    ledger.load_work -= step_work_[k];
    ledger.constraint_work += step_work_[k];
  }
}

template <int W>
void MpmSolver::xpic_extrapolation() {
  const std::size_t nnx = static_cast<std::size_t>(case_.grid.n_nodes_x());
  const std::size_t n_nodes = grid_.mass.size();
  const double dt = counters_.dt;
  const double tiny = 1e-12 * particles_.mass.front();
  const StencilReader<W> stencil = stencil_reader<W>();
  const double* particle_mass = particles_.mass.data();
  const int* band_start = band_start_.data();
  const int* sorted = sorted_.data();
  const int n_bands = n_bands_;
  const double* mass = grid_.mass.data();
  const unsigned* fixed = grid_.fixed.data();
  const Vec2* start = prescribed_.start().data();
  Vec2* sum = xpic_sum_.data();
  // g_1: the grid velocity of the step's start, v' - dt a (the prescribed velocity at the
  // start on the fixed components, the extrapolated one on the tied nodes).
  Vec2* first = xpic_iterate_.data();
#pragma omp parallel for schedule(dynamic, kNodeChunk) if (parallel_)
  for (std::size_t node = 0; node < n_nodes; ++node) {
    first[node] = grid_.velocity[node] - dt * grid_.acceleration[node];
  }
  // S+ S: interpolated to the particles, summed back with their masses.
  auto project = [&](std::span<Vec2> iterate) {
    auto scatter_band = [&](int band) {
      for (int q = band_start[band]; q < band_start[band + 1]; ++q) {
        const auto p = static_cast<std::size_t>(sorted[q]);
        const Shape<W> f = stencil(p);
        Vec2 u = Vec2::Zero();
        for (int b = 0; b < W; ++b) {
          for (int a = 0; a < W; ++a) {
            const double weight = f.nx[a] * f.ny[b];
            if (W > 2 && weight == 0.0) continue;
            u += weight * iterate[f.node0 + static_cast<std::size_t>(b) * nnx + a];
          }
        }
        const Vec2 mu = particle_mass[p] * u;
        for (int b = 0; b < W; ++b) {
          for (int a = 0; a < W; ++a) {
            const double weight = f.nx[a] * f.ny[b];
            if (W > 2 && weight == 0.0) continue;
            sum[f.node0 + static_cast<std::size_t>(b) * nnx + a] += weight * mu;
          }
        }
      }
    };
    // Cleared, then the even bands, then the odd bands, as in particles_to_grid.
#pragma omp parallel if (parallel_)
    {
#pragma omp for schedule(dynamic, kNodeChunk)
      for (std::size_t node = 0; node < n_nodes; ++node) sum[node].setZero();
#pragma omp for schedule(dynamic, 1)
      for (int band = 0; band < n_bands; band += 2) scatter_band(band);
#pragma omp for schedule(dynamic, 1)
      for (int band = 1; band < n_bands; band += 2) scatter_band(band);
    }
    // The sums go to the nodes as the particles' momentum does (remap()).
    mirror_.gather(std::span<Vec2>(xpic_sum_));
    extension_.gather(std::span<Vec2>(xpic_sum_));
#pragma omp parallel for schedule(dynamic, kNodeChunk) if (parallel_)
    for (std::size_t node = 0; node < n_nodes; ++node) {
      iterate[node] = node_velocity(mass[node], sum[node], fixed[node], start[node], tiny);
    }
    extension_.extrapolate(iterate);
    mirror_.extrapolate(iterate);
  };
  xpic_grid_term(case_.solver.xpic_order, std::span<Vec2>(xpic_iterate_),
                 std::span<Vec2>(xpic_term_), project);
}

template <int W, bool kScatterMomentum>
void MpmSolver::grid_to_particles() {
  const std::size_t nnx = static_cast<std::size_t>(case_.grid.n_nodes_x());
  const std::size_t n = particles_.size();
  const double dt = counters_.dt;
  const double pic_fraction = case_.solver.pic_fraction;
  // XPIC(m): the PIC part interpolates v' + (G - g_1) (xpic_extrapolation()).
  const bool xpic = case_.solver.xpic_order > 1;
  if (xpic) xpic_extrapolation<W>();
  const Vec2* xpic_term = xpic_term_.data();
  const int n_bands = n_bands_;
  const StencilReader<W> stencil = stencil_reader<W>();
  const Vec2* acceleration = grid_.acceleration.data();
  const Vec2* velocity = grid_.velocity.data();
  Vec2* momentum = remapped_momentum_.data();  // cleared by particles_to_grid
  Vec2* particle_velocity = particles_.velocity.data();
  Vec2* particle_position = particles_.position.data();
  const double* particle_mass = particles_.mass.data();
  const int* band_start = band_start_.data();
  const int* sorted = sorted_.data();
  long bad = -1;
  double max_speed = 0.0;
  // FLIP velocity and position of one particle; with kScatterMomentum its new momentum goes to
  // the grid at once (the MUSL remap). bad_p and max_speed_p are the calling thread's.
  auto update = [&](std::size_t p, long& bad_p, double& max_speed_p) {
    const Shape<W> f = stencil(p);
    Vec2 a = Vec2::Zero(), v = Vec2::Zero(), c = Vec2::Zero();
    for (int b = 0; b < W; ++b) {
      for (int a_ = 0; a_ < W; ++a_) {
        const double weight = f.nx[a_] * f.ny[b];
        if (W > 2 && weight == 0.0) continue;
        const std::size_t node = f.node0 + static_cast<std::size_t>(b) * nnx + a_;
        a += weight * acceleration[node];
        v += weight * velocity[node];
        if (xpic) c += weight * xpic_term[node];
      }
    }
    const Vec2 vp =
        flip_pic_velocity(particle_velocity[p], a, xpic ? Vec2(v + c) : v, dt, pic_fraction);
    const Vec2 xp = particle_position[p] + dt * v;
    particle_velocity[p] = vp;
    particle_position[p] = xp;
    const double speed = vp.norm();
    if (!(speed < 1e300) || !xp.allFinite()) bad_p = std::max(bad_p, static_cast<long>(p));
    max_speed_p = std::max(max_speed_p, speed);
    if constexpr (kScatterMomentum) {
      const Vec2 mv = particle_mass[p] * vp;
      for (int b = 0; b < W; ++b) {
        for (int a_ = 0; a_ < W; ++a_) {
          const double weight = f.nx[a_] * f.ny[b];
          if (W > 2 && weight == 0.0) continue;
          momentum[f.node0 + static_cast<std::size_t>(b) * nnx + a_] += weight * mv;
        }
      }
    }
  };
  if constexpr (kScatterMomentum) {
    auto update_band = [&](int band, long& bad_p, double& max_speed_p) {
      for (int q = band_start[band]; q < band_start[band + 1]; ++q) {
        update(static_cast<std::size_t>(sorted[q]), bad_p, max_speed_p);
      }
    };
#pragma omp parallel reduction(max : bad, max_speed) if (parallel_)
    {
      // Even bands, then odd bands, as in particles_to_grid.
#pragma omp for schedule(dynamic, 1)
      for (int band = 0; band < n_bands; band += 2) update_band(band, bad, max_speed);
#pragma omp for schedule(dynamic, 1) nowait
      for (int band = 1; band < n_bands; band += 2) update_band(band, bad, max_speed);
    }
  } else {
    (void)n_bands;
    (void)momentum;
    (void)particle_mass;
    (void)band_start;
    (void)sorted;
#pragma omp parallel for schedule(dynamic, kSumBlock) reduction(max : bad, max_speed) if (parallel_)
    for (std::size_t p = 0; p < n; ++p) update(p, bad, max_speed);
  }
  bad_particle_ = bad;
  max_speed_ = max_speed;
}

void MpmSolver::remap() {
  const std::size_t n_nodes = grid_.mass.size();
  const double tiny = 1e-12 * particles_.mass.front();
  const Vec2* end = prescribed_.end().data();
  mirror_.gather(std::span<Vec2>(remapped_momentum_));
  extension_.gather(std::span<Vec2>(remapped_momentum_));
#pragma omp parallel for schedule(dynamic, kNodeChunk) if (parallel_)
  for (std::size_t node = 0; node < n_nodes; ++node) {
    const Vec2 p = remapped_momentum_[node];
    grid_.momentum[node] = p;  // the grid state shows the remapped momentum
    remapped_velocity_[node] =
        node_velocity(grid_.mass[node], p, grid_.fixed[node], end[node], tiny);
  }
  extension_.extrapolate(std::span<Vec2>(remapped_velocity_));
  mirror_.extrapolate(std::span<Vec2>(remapped_velocity_));
}

template <int W>
void MpmSolver::update_stress(const std::vector<Vec2>& node_velocity) {
  const std::size_t nnx = static_cast<std::size_t>(case_.grid.n_nodes_x());
  const std::size_t n = particles_.size();
  const double dt = counters_.dt;
  const StencilReader<W> stencil = stencil_reader<W>();
  const MaterialRecord* materials = case_.materials.data();
  const MaterialConstants* constants = material_constants_.data();
  const Vec2* vel = node_velocity.data();
  Stress* particle_stress = particles_.stress.data();
  PointState* particle_state = particles_.state.data();
  Mat2* particle_deformation = particles_.deformation_gradient.data();
  double* particle_volume = particles_.volume.data();
  const double* initial_volume = particles_.initial_volume.data();
  const int* particle_material = particles_.material.data();
  PointEnergy* energy_blocks = point_energy_blocks_.data();
  double* kinetic_blocks = kinetic_blocks_.data();
  const Vec2* particle_velocity = particles_.velocity.data();
  const double* particle_mass = particles_.mass.data();
  long bad = -1, inverted = -1;
  const std::size_t n_blocks = point_energy_blocks_.size();
  const bool mean_dilatation = case_.solver.mean_dilatation;
  const int* band_start = band_start_.data();
  const int* sorted = sorted_.data();
  const int n_bands = n_bands_;
  const int* particle_cell = particle_cell_.data();
  double* cell_volume = cell_volume_.data();
  double* cell_trace = cell_trace_.data();
  Mat2* stored_gradient = velocity_gradient_.data();
  // Velocity gradient L(i, j) = d v_i / d x_j of particle p, summed by columns: (L00, L10) and
  // (L01, L11).
  auto velocity_gradient = [&](std::size_t p) {
    const Shape<W> f = stencil(p);
    Vec2 column_x = Vec2::Zero(), column_y = Vec2::Zero();
    for (int b = 0; b < W; ++b) {
      for (int a = 0; a < W; ++a) {
        const double gx = f.dx[a] * f.ny[b], gy = f.nx[a] * f.dy[b];
        if (W > 2 && gx == 0.0 && gy == 0.0) continue;
        const Vec2& v = vel[f.node0 + static_cast<std::size_t>(b) * nnx + a];
        column_x += gx * v;
        column_y += gy * v;
      }
    }
    Mat2 l;
    l << column_x.x(), column_y.x(), column_x.y(), column_y.y();
    return l;
  };
#pragma omp parallel reduction(max : bad, inverted) if (parallel_)
  {
    if (mean_dilatation) {
      // Every particle's L, and each cell's volume-weighted sum of tr L, band by band (a band
      // owns the cells of its rows).
#pragma omp for schedule(dynamic, 1)
      for (int band = 0; band < n_bands; ++band) {
        clear_band_cells(band);
        for (int q = band_start[band]; q < band_start[band + 1]; ++q) {
          const auto p = static_cast<std::size_t>(sorted[q]);
          const Mat2 l = velocity_gradient(p);
          stored_gradient[p] = l;
          const auto c = static_cast<std::size_t>(particle_cell[p]);
          cell_volume[c] += particle_volume[p];
          cell_trace[c] += particle_volume[p] * l.trace();
        }
      }
    }
#pragma omp for schedule(dynamic, 1) nowait
    for (std::size_t k = 0; k < n_blocks; ++k) {
      // The ledger terms of the stress update and the particles' kinetic energy after the step,
      // per block of particles.
      PointEnergy block;
      double kinetic = 0.0;
      for (std::size_t p = k * kSumBlock; p < std::min(n, (k + 1) * kSumBlock); ++p) {
        Mat2 l;
        if (mean_dilatation) {
          const auto c = static_cast<std::size_t>(particle_cell[p]);
          l = mean_dilatation_gradient(stored_gradient[p], cell_trace[c] / cell_volume[c]);
        } else {
          l = velocity_gradient(p);
        }
        const Stress before = particle_stress[p];
        Stress sig = before, rotated;  // a local copy: no store-to-load stalls
        const auto mi = static_cast<std::size_t>(particle_material[p]);
        const Strain de = update_point_stress(l, dt, materials[mi].model, constants[mi], sig,
                                              particle_state[p], rotated);
        particle_stress[p] = sig;
        const double volume_before = particle_volume[p];
        const Mat2 deformation = update_deformation_gradient(l, dt, particle_deformation[p]);
        particle_deformation[p] = deformation;
        const double volume = deformation.determinant() * initial_volume[p];
        particle_volume[p] = volume;
        if (volume <= 0.0) inverted = std::max(inverted, static_cast<long>(p));
        const double work = add_stress_update_energy(constants[mi], before, rotated, sig, de,
                                                     volume_before, volume, block);
        if (!std::isfinite(work)) bad = std::max(bad, static_cast<long>(p));
        kinetic += 0.5 * particle_mass[p] * particle_velocity[p].squaredNorm();
      }
      energy_blocks[k] = block;
      kinetic_blocks[k] = kinetic;
    }
  }
  bad_particle_ = std::max(bad_particle_, bad);
  inverted_particle_ = inverted;
  PointEnergy step;
  double kinetic = 0.0;
  for (std::size_t k = 0; k < n_blocks; ++k) {
    step.add(energy_blocks[k]);
    kinetic += kinetic_blocks[k];
  }
  EnergyLedger& e = counters_.energy;
  e.add_stress_update(step);
  e.transfer_to_particles += kinetic - grid_kinetic_after_;
  e.particle_kinetic = kinetic;
}

void MpmSolver::clear_band_cells(int band) {
  const auto row = static_cast<std::size_t>(case_.grid.n_cells_x);
  const auto first = static_cast<std::size_t>(band * band_rows_) * row;
  const auto last =
      static_cast<std::size_t>(std::min((band + 1) * band_rows_, case_.grid.n_cells_y)) * row;
  std::fill(cell_volume_.begin() + static_cast<std::ptrdiff_t>(first),
            cell_volume_.begin() + static_cast<std::ptrdiff_t>(last), 0.0);
  std::fill(cell_trace_.begin() + static_cast<std::ptrdiff_t>(first),
            cell_trace_.begin() + static_cast<std::ptrdiff_t>(last), 0.0);
}

void MpmSolver::check_particles() {
  // bad_particle_ and max_speed_ are gathered by grid_to_particles and update_stress.
  if (bad_particle_ >= 0) {
    throw SimulationError("non-finite value (NaN or inf) at " +
                          describe_particle(particles_, static_cast<std::size_t>(bad_particle_)) +
                          " at t = " + std::to_string(counters_.time) + " s (step " +
                          std::to_string(counters_.step) + ")");
  }
  if (inverted_particle_ >= 0) {
    const auto p = static_cast<std::size_t>(inverted_particle_);
    const Mat2& f = particles_.deformation_gradient[p];
    std::ostringstream det;
    det << f.determinant() << ", F = [[" << f(0, 0) << ", " << f(0, 1) << "], [" << f(1, 0) << ", "
        << f(1, 1) << "]]";
    throw SimulationError(describe_particle(particles_, p) + " inverted (det F = " + det.str() +
                          ": its material folded over) at t = " + std::to_string(counters_.time) +
                          " s (step " + std::to_string(counters_.step) +
                          "): the deformation is not resolved by the grid and the time step");
  }
  // Courant condition with the material speed added to the wave speed.
  if ((max_wave_speed_ + max_speed_) * counters_.dt > case_.grid.cell_size) {
    throw SimulationError("CFL condition violated at t = " + std::to_string(counters_.time) +
                          " s (step " + std::to_string(counters_.step) + "): (c_p + |v|max) dt = " +
                          std::to_string((max_wave_speed_ + max_speed_) * counters_.dt) +
                          " m > h = " + std::to_string(case_.grid.cell_size) +
                          " m: a unit mistake? (E and stresses in kPa, unit weight in kN/m^3, "
                          "lengths in m)");
  }
}

double MpmSolver::particle_kinetic_energy() const {
  // By the blocks of update_stress, in the same order: bitwise its ledger's particle_kinetic.
  const std::size_t n = particles_.size();
  double kinetic = 0.0;
  for (std::size_t b = 0; b < n; b += kSumBlock) {
    double block = 0.0;
    for (std::size_t p = b; p < std::min(n, b + kSumBlock); ++p)
      block += 0.5 * particles_.mass[p] * particles_.velocity[p].squaredNorm();
    kinetic += block;
  }
  return kinetic;
}

EnergyBalance MpmSolver::energy() const {
  return energy_balance(particles_, material_constants_, particle_kinetic_energy(),
                        counters_.energy, prescribed_.reactions(grid_.reaction));
}

void MpmSolver::initialise_stress() {
  pfm::initialise_stress(
      case_, particles_, counters_, [this] { step(); },
      [this] { return particle_kinetic_energy(); });
  // The ledger starts from the state reached.
  start_ledger(counters_.energy, energy(), case_.loads.size());
}

void MpmSolver::update_stress_from_grid_velocity(const std::vector<Vec2>& node_velocity) {
  if (node_velocity.size() != grid_.mass.size()) {
    throw std::invalid_argument("update_stress_from_grid_velocity: one velocity per grid node");
  }
  switch (stencil_width(case_.solver.shape_function)) {
    case 2:
      locate_particles<2>(false);
      update_stress<2>(node_velocity);
      break;
    case 3:
      locate_particles<3>(false);
      update_stress<3>(node_velocity);
      break;
    default:
      locate_particles<4>(false);
      update_stress<4>(node_velocity);
  }
  check_particles();
}

template void MpmSolver::run_step<2>();
template void MpmSolver::run_step<3>();
template void MpmSolver::run_step<4>();

}  // namespace pfm

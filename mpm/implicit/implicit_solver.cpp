#include "mpm/implicit/implicit_solver.hpp"

#include <omp.h>

#include <Eigen/Sparse>
#include <Eigen/UmfPackSupport>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <string>
#include <utility>

#include "mpm/boundary/bezier.hpp"
#include "mpm/boundary/surface_load.hpp"
#include "mpm/core/json_input.hpp"
#include "mpm/core/kinematics.hpp"
#include "mpm/core/wall_mirror.hpp"
#include "mpm/implicit/implicit_internal.hpp"
#include "mpm/step/body_fill.hpp"
#include "mpm/step/prescribed_velocity.hpp"
#include "mpm/step/step_view.hpp"

namespace pfm {

using implicit_detail::Affine;
using implicit_detail::grid_nodes;
using implicit_detail::NodeStrain;
using implicit_detail::NodeWeight;
using implicit_detail::SparseMatrix;
using implicit_detail::Vector;

namespace {

// B_I of a node whose function has gradient g at the point.
Eigen::Matrix<double, 4, 2> strain_operator(const Vec2& g) {
  Eigen::Matrix<double, 4, 2> b = Eigen::Matrix<double, 4, 2>::Zero();
  b(kXX, 0) = g.x();
  b(kYY, 1) = g.y();
  b(kXY, 0) = g.y();
  b(kXY, 1) = g.x();
  return b;
}

// Below this many particles a load step's evaluations run on one thread.
constexpr std::size_t kMinParallelParticles = 2000;

// A step that converges in at most kFastIterations lets the next one grow by kGrowth.
constexpr int kFastIterations = 4;
constexpr double kGrowth = 1.5;

// A number as %g with 6 significant digits.
std::string format_number(double v) {
  char text[32];
  std::snprintf(text, sizeof text, "%g", v);
  return text;
}

[[noreturn]] void refuse(const Case& c, const std::string& path, const std::string& why) {
  throw InputError(c.file + ": " + path + ": " + why);
}

}  // namespace

ImplicitSolver::ImplicitSolver(const Case& c, std::unique_ptr<ImplicitMesh> mesh)
    : case_(c), mesh_(std::move(mesh)), settings_(c.implicit) {
  for (const char* key : {"scheme", "damping", "damping_form", "pic_fraction", "xpic_order"}) {
    if (c.source.contains("solver") && c.source["solver"].contains(key)) {
      refuse(c, std::string("/solver/") + key,
             "belongs to the explicit step; the implicit solver is quasi-static");
    }
  }
  for (const char* key : {"cfl", "dt"}) {
    if (c.source.contains("time") && c.source["time"].contains(key)) {
      refuse(c, std::string("/time/") + key,
             "belongs to the explicit step; the implicit solver's steps are "
             "implicit.load_steps");
    }
  }
  if (c.manufactured && c.manufactured->kind == ManufacturedKind::kUniformDilatation) {
    refuse(c, "/manufactured_solution/type",
           "\"uniform_dilatation\" is a free body: without supports a quasi-static step's "
           "stiffness is singular (the implicit solver takes \"standing_wave\")");
  }
  if (mesh_ && !c.constraints.empty()) {
    refuse(c, "/constraints",
           "a mesh prescribes motion on its nodes (a node set in boundary_conditions with "
           "\"velocity\"), not on a detected boundary");
  }
  particles_ = mesh_ ? mesh_->material_points() : fill_bodies(c);
  if (!mesh_) top_loads_ = GridTopLoads(c, particles_);
  if (particles_.size() == 0) refuse(c, "/bodies", "the bodies hold no material point");
  if (c.initial_stress.method == InitialStressMethod::kK0) apply_k0_stress(c, particles_);
  for (const MaterialRecord& m : c.materials) {
    models_.push_back(m.model);
    constants_.push_back(material_constants(m.model));
    hooke_inverse_.push_back(elastic_tangent(constants_.back()).inverse());
  }
  ghost_modulus_ = largest_constrained_modulus(c.materials);

  const Grid& grid = c.grid;
  n_nodes_ = mesh_ ? mesh_->n_nodes() : static_cast<std::size_t>(grid.n_nodes());
  const std::size_t n_nodes = n_nodes_;
  fixed_.assign(n_nodes, kFixNone);
  prescribed_ = PrescribedVelocity(c.boundary_conditions, n_nodes);
  std::vector<unsigned> at_zero(n_nodes, kFixNone);
  for (std::size_t k = 0; k < c.boundary_conditions.size(); ++k) {
    const BoundaryCondition& bc = c.boundary_conditions[k];
    for (std::size_t n = 0; mesh_ && n < n_nodes; ++n) {
      if (!mesh_->holds(bc, n)) continue;
      fixed_[n] |= bc.fix;
      prescribed_.add(k, n);
    }
    for (int j = 0; !mesh_ && j < grid.n_nodes_y(); ++j) {
      for (int i = 0; i < grid.n_nodes_x(); ++i) {
        if (!grid_node_held(c, bc, i, j)) continue;
        const auto n = static_cast<std::size_t>(grid.node_index(i, j));
        fixed_[n] |= bc.fix;
        if (!bc.moving) at_zero[n] |= bc.fix;
        prescribed_.add(k, n);
      }
    }
  }
  if (!mesh_) mirror_ = WallMirror(grid, c.solver.shape_function, at_zero);
  if (!mesh_ && c.solver.outer_node_fraction > 0.0) {
    extension_ = BasisExtension(grid, c.solver.shape_function, c.solver.outer_node_fraction);
  }
  initial_spacing_ = initial_particle_spacing(c);
  constraint_reports_.assign(c.constraints.size(), ConstraintReport{});
  constraint_target_.assign(c.constraints.size(), Vec2::Zero());
  // A displacement starts at its time function's value at 0 (a velocity integrates from 0).
  for (std::size_t k = 0; k < c.constraints.size(); ++k) {
    const ConstraintSpec& spec = c.constraints[k];
    if (!spec.velocity) constraint_target_[k] = spec.time_function.factor(0.0) * spec.value;
  }
}

double ImplicitSolver::gravity_factor(double t) const {
  // A K0 stress or the gravity loading's is the weight's at full gravity: its ramp is over.
  if (case_.initial_stress.method != InitialStressMethod::kZero) return 1.0;
  const double ramp = case_.gravity.ramp_time;
  return ramp <= 0.0 ? 1.0 : std::min(1.0, t / ramp);
}

void ImplicitSolver::initialise_stress() {
  if (initialised_) return;
  initialised_ = true;
  if (case_.initial_stress.method == InitialStressMethod::kGravity) settle_under_gravity();
}

void ImplicitSolver::settle_under_gravity() {
  // The case with its gravity alone, ramped over a pseudo-second: no loads, no constraints, no
  // strength reduction, the moving supports held where they are.
  Case settling_case = case_;
  settling_case.loads.clear();
  settling_case.constraints.clear();
  settling_case.initial_stress = InitialStressSpec{};
  settling_case.implicit.strength_reduction.reset();
  settling_case.gravity.ramp_time = 1.0;
  settling_case.time.end_time = 1.0;
  for (BoundaryCondition& bc : settling_case.boundary_conditions) {
    bc.velocity.setZero();
    bc.moving = false;
  }
  ImplicitSolver settling(settling_case, std::move(mesh_));
  try {
    settling.run_to(1.0);
  } catch (const ImplicitDivergence& e) {
    throw ImplicitDivergence(std::string("gravity loading (initial_stress \"gravity\"): ") +
                             e.what());
  }
  mesh_ = std::move(settling.mesh_);
  initial_log_ = settling.log_;
  particles_ = settling.particles_;
  for (std::size_t p = 0; p < particles_.size(); ++p) {
    particles_.velocity[p].setZero();
    particles_.reference_position[p] = particles_.position[p];
  }
  if (mesh_) mesh_->reset_reference();
}

void ImplicitSolver::run_to(double end_time) {
  while (time_ < end_time * (1.0 - 1e-12) && !collapsed()) advance(end_time);
}

double ImplicitSolver::strength_factor() const {
  const auto& reduction = settings_.strength_reduction;
  return reduction ? reduction->factor(time_, case_.time.end_time) : 1.0;
}

void ImplicitSolver::reduce_strength(double t) {
  const auto& reduction = settings_.strength_reduction;
  const double factor = reduction ? reduction->factor(t, case_.time.end_time) : 1.0;
  if (factor == strength_factor_) return;
  strength_factor_ = factor;
  for (std::size_t m = 0; m < models_.size(); ++m) {
    models_[m] = reduced_strength(case_.materials[m].model, factor);
    constants_[m] = material_constants(models_[m]);
  }
}

void ImplicitSolver::advance(double end_time) {
  initialise_stress();
  if (collapsed()) return;
  if (first_step_ == 0.0) {
    first_step_ = end_time / settings_.load_steps;
    step_size_ = first_step_;
  }
  for (int cut = 0;; ++cut) {
    double dt = std::min(step_size_, end_time - time_);
    if (end_time - time_ - dt < 1e-9 * first_step_) dt = end_time - time_;  // no sliver left
    if (try_step(dt)) {
      const int iterations = static_cast<int>(log_.back().residuals.size()) - 1;
      if (iterations <= kFastIterations) step_size_ = std::min(first_step_, step_size_ * kGrowth);
      return;
    }
    // In a strength reduction the step's size is the answer's resolution: no step after its
    // start is cut below the first step / 2^max_cuts, however many steps converged since the
    // last cut (else the run creeps towards the collapse in ever smaller steps).
    const auto& reduction = settings_.strength_reduction;
    const bool reducing = reduction && time_ + dt > reduction->start_time;
    const double smallest = std::ldexp(first_step_, -settings_.max_cuts);
    if (cut == settings_.max_cuts || (reducing && 0.5 * dt < smallest * (1.0 - 1e-9))) {
      if (reducing) {
        failed_factor_ = strength_factor_;
        return;
      }
      throw ImplicitDivergence(divergence_message(dt, cut));
    }
    step_size_ = 0.5 * dt;
  }
}

std::string ImplicitSolver::divergence_message(double dt, int cut) const {
  std::string history;
  for (const double r : log_.back().residuals) {
    char text[32];
    std::snprintf(text, sizeof text, "%s%.3e", history.empty() ? "" : ", ", r);
    history += text;
  }
  // The step's number and what it asked for at its end: gravity's factor, each load's (its time
  // function), each constraint's prescribed displacement.
  const long number =
      1 + std::count_if(log_.begin(), log_.end(), [](const LoadStepLog& e) { return e.converged; });
  const double t_end = time_ + dt;
  std::string asked = "gravity factor " + format_number(gravity_factor(t_end));
  if (settings_.strength_reduction)
    asked += ", strength reduction factor " + format_number(strength_factor_);
  for (std::size_t k = 0; k < case_.loads.size(); ++k) {
    asked += ", load " + std::to_string(k) + " factor " +
             format_number(case_.loads[k].time_function.factor(t_end));
  }
  for (std::size_t k = 0; k < case_.constraints.size(); ++k) {
    const Vec2 u = constraint_target(k, dt);
    asked += ", constraint " + std::to_string(k) + " displacement ";
    if (case_.constraints[k].normal_only) {
      asked += format_number(u.x()) + " m (normal)";
    } else {
      asked += '(';
      asked += format_number(u.x()) + ", " + format_number(u.y()) + ") m";
    }
  }
  return "load step " + std::to_string(number) + " from t = " + format_number(time_) + " s to " +
         format_number(t_end) + " s (" + asked + "; after " + std::to_string(cut) +
         " halvings) did not converge; relative residuals " + history;
}

Vec2 ImplicitSolver::constraint_target(std::size_t k, double dt) const {
  const ConstraintSpec& spec = case_.constraints[k];
  if (!spec.velocity) return spec.time_function.factor(time_ + dt) * spec.value;
  return constraint_target_[k] + dt * spec.time_function.factor(time_ + 0.5 * dt) * spec.value;
}

void ImplicitSolver::locate(Prepared& s) const {
  const Case& c = case_;
  const Grid& grid = c.grid;
  const std::size_t n_particles = particles_.size();
  s.nodes.resize(n_particles);
  s.material.assign(n_nodes_, 0.0);
  for (std::size_t p = 0; p < n_particles; ++p) {
    const Vec2& x = particles_.position[p];
    if (mesh_) {
      s.nodes[p] = mesh_->functions(p);
    } else if (!grid.contains(x)) {
      throw SimulationError("particle " + std::to_string(p) +
                            " left the grid at t = " + std::to_string(time_) + " s");
    } else {
      s.nodes[p] =
          grid_nodes(grid, stencil(c.solver.shape_function, grid, x, particles_.half_length[p]));
    }
    for (const NodeWeight& w : s.nodes[p])
      s.material[static_cast<std::size_t>(w.node)] += w.value * particles_.volume[p];
  }
}

void ImplicitSolver::hold_and_tie(Prepared& s) {
  prescribed_.update(time_, s.dt);
  s.tied = extension_.enabled();
  if (s.tied) {
    extension_.classify(s.material, 1.0, fixed_, prescribed_.start(), prescribed_.end());
    // The ghost penalty (header comment) on the nodes between the tie fraction and twice it.
    const double gamma = case_.solver.ghost_penalty;
    const double upto = 2.0 * case_.solver.outer_node_fraction;
    if (gamma > 0.0) {
      s.ghosts = extension_.light_arrays(s.material, 1.0, upto, fixed_, prescribed_.start(),
                                         prescribed_.end());
      for (const int j : s.ghosts.outer) {
        const double f = s.material[static_cast<std::size_t>(j)] / extension_.support(j);
        s.ghost_stiffness.push_back(gamma * ghost_modulus_ * (1.0 - f / upto));
      }
    }
  }
}

void ImplicitSolver::apply_external_force(Prepared& s) {
  const Case& c = case_;
  const Grid& grid = c.grid;
  const std::size_t n_particles = particles_.size();
  const std::size_t n_nodes = n_nodes_;
  s.external.assign(n_nodes, Vec2::Zero());
  const double g = c.gravity.g * gravity_factor(s.t_end);
  for (std::size_t p = 0; p < n_particles; ++p) {
    for (const NodeWeight& w : s.nodes[p])
      s.external[static_cast<std::size_t>(w.node)].y() -= w.value * particles_.mass[p] * g;
  }
  if (c.manufactured) {
    // A manufactured solution (gravity off): sum_p N_I m_p b(X_p, t_n+1), its static body force.
    for (std::size_t p = 0; p < n_particles; ++p) {
      const Vec2 b = particles_.mass[p] *
                     c.manufactured->static_body_force(particles_.reference_position[p], s.t_end);
      for (const NodeWeight& w : s.nodes[p])
        s.external[static_cast<std::size_t>(w.node)] += w.value * b;
    }
  }
  if (c.loads.empty()) return;  // also while settling under gravity (settle_under_gravity)
  if (mesh_) {
    mesh_->add_loads(s.t_end, s.external);
    return;
  }
  const double h = grid.cell_size;
  const double light = boundary::BoundaryLoadSpec{}.min_node_mass_fraction * h * h;  // m^2
  std::vector<Vec2> load(n_nodes, Vec2::Zero());
  boundary::BoundaryLoadIntegrator integrator(grid, shape_degree(c.solver.shape_function));
  for (std::size_t k = 0; k < c.loads.size(); ++k) {
    const LoadSpec& l = c.loads[k];
    const double factor = l.time_function.factor(s.t_end);
    if (l.apply_on == LoadTarget::kGridTopNodes) {
      // The explicit step's grid-top load (mpm/step/grid_top_loads.hpp): a node with little
      // material under it, sum N V <= 0.01 h^2, passes its share down (B-splines without ties).
      top_loads_.apply(
          k, l.pressure * factor, particles_, s.tied,
          [&](std::size_t node) { return s.material[node] <= light; },
          [&](std::size_t node, const Vec2& force) { load[node] += force; });
      continue;
    }
    boundary::BoundaryLoadSpec spec = *l.surface;
    spec.min_node_mass = spec.min_node_mass_fraction * h * h;
    std::span<const double> carriers = s.material;
    if (s.tied) {
      spec.redistribute_lost_load = false;  // the ties carry every node's load
      carriers = {};
    }
    const auto curves = boundary::make_composite_beziers(detected(s).contours, spec.curve);
    integrator.integrate(curves, spec, factor, carriers, load);
  }
  std::vector<int> loaded_without_mass;
  for (std::size_t n = 0; n < n_nodes; ++n) {
    if (load[n].isZero()) continue;
    s.external[n] += load[n];
    if (s.material[n] <= 0.0) loaded_without_mass.push_back(static_cast<int>(n));
  }
  if (s.tied && !loaded_without_mass.empty()) {
    extension_.tie_massless(loaded_without_mass, fixed_, prescribed_.start(), prescribed_.end());
  }
}

const DetectedBoundary& ImplicitSolver::detected(Prepared& s) {
  if (!s.detected) {
    ParticleCloud cloud{particles_.position, particles_.volume, particles_.deformation_gradient,
                        initial_spacing_};
    s.boundary = detect(cloud, case_.grid, case_.detection->detector, detector_state_);
    s.detected = true;
  }
  return s.boundary;
}

void ImplicitSolver::number_unknowns(Prepared& s) {
  const std::size_t n_nodes = n_nodes_;
  s.map.assign(2 * n_nodes, Affine{});
  for (std::size_t n = 0; n < n_nodes; ++n) {
    if (s.material[n] <= 0.0 || (s.tied && extension_.tie_of(static_cast<int>(n)) >= 0)) continue;
    for (int d = 0; d < 2; ++d) {
      Affine& a = s.map[2 * n + static_cast<std::size_t>(d)];
      a.used = true;
      if (fixed_[n] & (d == 0 ? kFixX : kFixY)) {
        a.offset = 0.5 * (prescribed_.start()[n][d] + prescribed_.end()[n][d]) * s.dt;
      } else {
        a.terms.emplace_back(s.n_dofs++, 1.0);
      }
    }
  }
  if (s.tied) {
    const NodeTies& ties = extension_.ties();
    for (std::size_t k = 0; k < ties.size(); ++k) {
      const auto j = static_cast<std::size_t>(ties.outer[k]);
      for (int d = 0; d < 2; ++d) {
        Affine& a = s.map[2 * j + static_cast<std::size_t>(d)];
        a = Affine{};
        a.used = true;
        for (int t = ties.start[k]; t < ties.start[k + 1]; ++t) {
          const auto inner = static_cast<std::size_t>(ties.inner[static_cast<std::size_t>(t)]);
          a.add_scaled(s.map[2 * inner + static_cast<std::size_t>(d)],
                       ties.weight[static_cast<std::size_t>(t)]);
        }
      }
    }
  }
  // The nodes behind a wall inside the grid mirror the node in front of it (B-splines,
  // mpm/core/wall_mirror.hpp): I's component takes w times J's where the mirror acts, after the
  // ties (as the explicit step extrapolates: the ties from I's own value, then the mirror).
  if (!mirror_.empty()) {
    mirror_.prepare(s.material, s.tied ? &extension_ : nullptr);
    for (std::size_t k = 0; k < mirror_.images().size(); ++k) {
      if (!mirror_.active(k)) continue;
      const WallMirror::Image& image = mirror_.images()[k];
      const auto d = static_cast<std::size_t>(image.component);
      const Affine front = s.map[2 * static_cast<std::size_t>(image.node) + d];
      for (const WallMirror::Source& source : image.sources) {
        Affine& behind = s.map[2 * static_cast<std::size_t>(source.behind) + d];
        behind = Affine{};
        behind.used = true;
        behind.add_scaled(front, source.weight);
      }
    }
  }
  s.external_reduced = Vector::Zero(s.n_dofs);
  for (std::size_t n = 0; n < n_nodes; ++n) {
    for (int d = 0; d < 2; ++d) {
      for (const auto& [dof, w] : s.map[2 * n + static_cast<std::size_t>(d)].terms)
        s.external_reduced[dof] += w * s.external[n][d];
    }
  }
}

void ImplicitSolver::build_strain_operators(Prepared& s) const {
  const Case& c = case_;
  const Grid& grid = c.grid;
  const std::size_t n_particles = particles_.size();
  s.strain.resize(n_particles);
  const bool bbar = c.solver.mean_dilatation;
  for (std::size_t p = 0; p < n_particles; ++p) {
    for (const NodeWeight& w : s.nodes[p])
      s.strain[p].push_back({w.node, strain_operator(w.gradient)});
  }
  if (bbar) {
    // The cell's volume-weighted mean of each node's dilatation gradient b_I = grad N_I, and
    // B-bar_I = B_I + 1/2 m (b-bar_I - b_I)^T with m = (1, 1, 0, 0); on a mesh, the element's.
    const auto n_cells = mesh_ ? mesh_->n_elements() : static_cast<std::size_t>(grid.n_cells());
    std::vector<int> cell_of(n_particles);
    std::vector<double> cell_volume(n_cells, 0.0);
    std::vector<std::vector<std::pair<int, Vec2>>> mean(n_cells);
    for (std::size_t p = 0; p < n_particles; ++p) {
      const Vec2& x = particles_.position[p];
      const int cell = mesh_
                           ? static_cast<int>(mesh_->element_of(p))
                           : grid.cell_index(std::clamp(grid.cell_i(x.x()), 0, grid.n_cells_x - 1),
                                             std::clamp(grid.cell_j(x.y()), 0, grid.n_cells_y - 1));
      cell_of[p] = cell;
      cell_volume[static_cast<std::size_t>(cell)] += particles_.volume[p];
      auto& list = mean[static_cast<std::size_t>(cell)];
      for (const NodeStrain& ns : s.strain[p]) {
        const Vec2 b(ns.b(kXX, 0), ns.b(kYY, 1));
        auto it = std::find_if(list.begin(), list.end(),
                               [&](const auto& e) { return e.first == ns.node; });
        if (it == list.end()) {
          list.emplace_back(ns.node, particles_.volume[p] * b);
        } else {
          it->second += particles_.volume[p] * b;
        }
      }
    }
    for (std::size_t p = 0; p < n_particles; ++p) {
      const auto cell = static_cast<std::size_t>(cell_of[p]);
      std::vector<NodeStrain> with_mean;
      for (const auto& [node, sum] : mean[cell]) {
        NodeStrain ns{node, Eigen::Matrix<double, 4, 2>::Zero()};
        Vec2 own = Vec2::Zero();
        for (const NodeStrain& e : s.strain[p]) {
          if (e.node != node) continue;
          ns.b = e.b;
          own = Vec2(e.b(kXX, 0), e.b(kYY, 1));
        }
        const Vec2 shift = 0.5 * (sum / cell_volume[cell] - own);
        ns.b.row(kXX) += shift.transpose();
        ns.b.row(kYY) += shift.transpose();
        with_mean.push_back(ns);
      }
      s.strain[p] = std::move(with_mean);
    }
  }
}

void ImplicitSolver::evaluate_particle(const Prepared& s, std::size_t p, bool tangent, Iterate& it,
                                       double* values, Vec2* internal,
                                       std::vector<double>& local) const {
  Strain de = Strain::Zero();
  for (const NodeStrain& ns : s.strain[p])
    de += ns.b * it.increment[static_cast<std::size_t>(ns.node)];
  // The increment gradient with B-bar's dilatation: G_bar such that sym(G_bar) = de; its
  // spin from the plain gradient.
  Mat2 plain = Mat2::Zero();
  for (const NodeWeight& w : s.nodes[p])
    plain += it.increment[static_cast<std::size_t>(w.node)] * w.gradient.transpose();
  Mat2 g_bar = plain;
  g_bar(0, 0) = de[kXX];
  g_bar(1, 1) = de[kYY];
  it.gradient[p] = g_bar;
  Stress sigma = particles_.stress[p];
  jaumann_rotate(g_bar, 1.0, sigma);
  PointState point = particles_.state[p];
  Tangent d;
  const auto mi = static_cast<std::size_t>(particles_.material[p]);
  const Strain increment = strain_increment(g_bar, 1.0);
  update_with_tangent(models_[mi], constants_[mi], increment, sigma, point, d);
  // A point that yielded in the last step and has no increment yet (the first iterate) would
  // take the elastic tangent, though it goes on yielding as a rule: its tangent is probed with
  // 1e-6 of the last step's increment instead (the consistent tangent of a vanishing plastic
  // increment, the continuum one). Only the tangent changes, not the stress.
  if (tangent && increment.isZero(0.0) && !yielding_.empty() && !yielding_[p].isZero(0.0)) {
    Stress probe_sigma = sigma;
    PointState probe_state = particles_.state[p];
    update_with_tangent(models_[mi], constants_[mi], 1e-6 * yielding_[p], probe_sigma, probe_state,
                        d);
  }
  it.stress[p] = sigma;
  it.state[p] = point;
  const double volume = particles_.volume[p];
  for (const NodeStrain& ns : s.strain[p])
    internal[static_cast<std::size_t>(ns.node)] += volume * ns.b.transpose() * sigma;
  if (!tangent) return;
  // The Jaumann rotation's part: sigma_n turned by w = (G01 - G10) / 2 changes the trial
  // stress by turn x dw, dw / du_I = (dN_I/dy, -dN_I/dx) / 2, and the update passes a
  // change of the trial stress on by d sigma / d trial = D_alg D^-1.
  const Stress& before = particles_.stress[p];
  const Stress turn(2.0 * before[kXY], -2.0 * before[kXY], before[kYY] - before[kXX], 0.0);
  const Stress turned = d * (hooke_inverse_[mi] * turn);
  const std::size_t m = s.unknowns[p].size();
  local.assign(m * m, 0.0);
  const std::vector<std::pair<int, double>>& terms = s.terms[p];
  const std::vector<int>& start = s.start[p];
  // Adds the 2 x 2 block of strain nodes (row, col) over their components' unknowns.
  const auto add_block = [&](std::size_t row, std::size_t col, const Mat2& block) {
    for (std::size_t da = 0; da < 2; ++da) {
      for (int ti = start[2 * row + da]; ti < start[2 * row + da + 1]; ++ti) {
        const auto [a, wa] = terms[static_cast<std::size_t>(ti)];
        double* line = local.data() + static_cast<std::size_t>(a) * m;
        for (std::size_t db = 0; db < 2; ++db) {
          const double k = wa * block(static_cast<Eigen::Index>(da), static_cast<Eigen::Index>(db));
          if (k == 0.0) continue;
          for (int tj = start[2 * col + db]; tj < start[2 * col + db + 1]; ++tj) {
            const auto [b, wb] = terms[static_cast<std::size_t>(tj)];
            line[b] += k * wb;
          }
        }
      }
    }
  };
  const std::vector<NodeStrain>& strain = s.strain[p];
  const bool turning = !(before[kXY] == 0.0 && before[kXX] == before[kYY]);
  for (std::size_t r = 0; r < strain.size(); ++r) {
    const Eigen::Matrix<double, 2, 4> left = volume * strain[r].b.transpose() * d;
    for (std::size_t c = 0; c < strain.size(); ++c) add_block(r, c, left * strain[c].b);
    if (!turning) continue;
    const Vec2 force = volume * strain[r].b.transpose() * turned;
    for (std::size_t k = 0; k < s.nodes[p].size(); ++k) {
      const Vec2& g = s.nodes[p][k].gradient;
      const Vec2 spin(0.5 * g.y(), -0.5 * g.x());
      add_block(r, static_cast<std::size_t>(s.stencil_in_strain[p][k]), force * spin.transpose());
    }
  }
  const std::vector<int>& where = s.positions[static_cast<std::size_t>(s.position_of[p])];
  for (std::size_t k = 0; k < m * m; ++k) values[where[k]] += local[k];
  if (!s.fitted.empty() && s.fitted[p]) {
    // d sigma_p / d (its unknowns), for Nitsche's term: D B plus the rotation's part.
    Eigen::MatrixXd& jacobian = it.stress_jacobian[p];
    jacobian.setZero(4, static_cast<Eigen::Index>(m));
    const auto add_column = [&](std::size_t node, std::size_t da, const Stress& change) {
      for (int ti = start[2 * node + da]; ti < start[2 * node + da + 1]; ++ti) {
        const auto [a, wa] = terms[static_cast<std::size_t>(ti)];
        jacobian.col(a) += wa * change;
      }
    };
    for (std::size_t c = 0; c < strain.size(); ++c) {
      const Eigen::Matrix<double, 4, 2> db = d * strain[c].b;
      for (std::size_t da = 0; da < 2; ++da) add_column(c, da, db.col(static_cast<int>(da)));
    }
    for (std::size_t k = 0; turning && k < s.nodes[p].size(); ++k) {
      const Vec2& g = s.nodes[p][k].gradient;
      const auto c = static_cast<std::size_t>(s.stencil_in_strain[p][k]);
      add_column(c, 0, 0.5 * g.y() * turned);
      add_column(c, 1, -0.5 * g.x() * turned);
    }
  }
}

Vector ImplicitSolver::evaluate(const Prepared& s, const Vector& at, bool tangent,
                                Iterate& it) const {
  const std::size_t n_particles = particles_.size();
  const std::size_t n_nodes = n_nodes_;
  for (std::size_t n = 0; n < n_nodes; ++n) {
    for (int d = 0; d < 2; ++d) {
      const Affine& a = s.map[2 * n + static_cast<std::size_t>(d)];
      double v = a.offset;
      for (const auto& [dof, w] : a.terms) v += w * at[dof];
      it.increment[n][d] = v;
    }
  }
  std::fill(it.internal.begin(), it.internal.end(), Vec2::Zero());
  if (tangent) std::fill_n(it.tangent.valuePtr(), it.tangent.nonZeros(), 0.0);
  // The particles in contiguous ranges, one per thread of the team (as many as OpenMP gives):
  // each thread adds into its own copy of the tangent's values and of the internal forces (the
  // first into it's), and the copies are added in thread order, so a thread count gives the
  // same bytes at every run.
  const int requested = n_particles >= kMinParallelParticles ? omp_get_max_threads() : 1;
  const auto n_values = static_cast<std::size_t>(it.tangent.nonZeros());
  it.thread_values.resize(static_cast<std::size_t>(requested - 1));
  it.thread_internal.resize(static_cast<std::size_t>(requested - 1));
  std::size_t team = 1;
#pragma omp parallel num_threads(requested)
  {
    const auto t = static_cast<std::size_t>(omp_get_thread_num());
    const auto threads = static_cast<std::size_t>(omp_get_num_threads());
    if (t == 0) team = threads;
    double* values = nullptr;
    Vec2* internal = it.internal.data();
    if (t > 0) {
      it.thread_internal[t - 1].assign(n_nodes, Vec2::Zero());
      internal = it.thread_internal[t - 1].data();
    }
    if (tangent) {
      if (t > 0) it.thread_values[t - 1].assign(n_values, 0.0);
      values = t > 0 ? it.thread_values[t - 1].data() : it.tangent.valuePtr();
    }
    std::vector<double> local;  // a particle's T^T K T over its unknowns, row-major
    for (std::size_t p = n_particles * t / threads; p < n_particles * (t + 1) / threads; ++p)
      evaluate_particle(s, p, tangent, it, values, internal, local);
  }
  for (std::size_t t = 0; t + 1 < team; ++t) {
    for (std::size_t n = 0; n < n_nodes; ++n) it.internal[n] += it.thread_internal[t][n];
    if (!tangent) continue;
    double* values = it.tangent.valuePtr();
    for (std::size_t k = 0; k < n_values; ++k) values[k] += it.thread_values[t][k];
  }
  if (!s.ghosts.empty()) add_ghost_penalty(s, tangent, it);
  Vector residual = s.external_reduced;
  it.internal_norm = 0.0;
  for (std::size_t n = 0; n < n_nodes; ++n) {
    for (int d = 0; d < 2; ++d) {
      const Affine& a = s.map[2 * n + static_cast<std::size_t>(d)];
      if (!a.used) continue;
      it.internal_norm += it.internal[n][d] * it.internal[n][d];
      for (const auto& [dof, w] : a.terms) residual[dof] -= w * it.internal[n][d];
    }
  }
  it.internal_norm = std::sqrt(it.internal_norm);
  if (!s.points.empty()) add_constraints(s, tangent, it, residual);
  return residual;
}

double ImplicitSolver::relative(const Prepared& s, const Iterate& it, const Vector& residual) {
  const double scale = std::max(it.internal_norm, s.external_reduced.norm());
  return scale > 0.0 ? residual.norm() / scale : residual.norm();
}

bool ImplicitSolver::newton(const Prepared& s, Iterate& it, LoadStepLog& entry) const {
  Vector x = Vector::Zero(s.n_dofs);
  Vector residual = evaluate(s, x, true, it);
  entry.residuals.push_back(relative(s, it, residual));
  double last_correction = std::numeric_limits<double>::infinity();
  // A step that asks for no motion (its increment at round-off: a load held, a strength not yet
  // reached) has no increment to compare its correction with: a correction of tolerance x h per
  // unknown is nothing to ask for.
  const double floor =
      settings_.tolerance * case_.grid.cell_size * std::sqrt(static_cast<double>(s.n_dofs));
  const auto converged = [&] {
    return s.n_dofs == 0 ||
           (entry.residuals.back() <= settings_.tolerance &&
            last_correction <= std::max(std::sqrt(settings_.tolerance) * x.norm(), floor));
  };
  for (int iteration = 0; iteration < settings_.max_iterations && !converged(); ++iteration) {
    Eigen::UmfPackLU<SparseMatrix> solver;
    solver.compute(it.tangent);
    if (solver.info() != Eigen::Success) break;
    const Vector correction = solver.solve(residual);
    if (solver.info() != Eigen::Success || !correction.allFinite()) break;
    // Backtracking: the full correction unless it raises |R|, then halves of it.
    double alpha = 1.0;
    Vector trial = x + correction;
    Vector trial_residual = evaluate(s, trial, true, it);
    for (int halving = 0; halving < 4 && trial_residual.norm() > residual.norm(); ++halving) {
      alpha *= 0.5;
      trial = x + alpha * correction;
      trial_residual = evaluate(s, trial, true, it);
    }
    last_correction = alpha * correction.norm();
    x = trial;
    residual = trial_residual;
    entry.residuals.push_back(relative(s, it, residual));
    if (!std::isfinite(entry.residuals.back())) break;
    // Within the residual's tolerance, the correction the iterate would still ask for, by this
    // factorisation: small, it ends the iteration without another tangent.
    if (entry.residuals.back() <= settings_.tolerance) {
      const Vector next = solver.solve(residual);
      if (solver.info() == Eigen::Success && next.allFinite())
        last_correction = std::min(last_correction, next.norm());
    }
  }
  return converged();
}

void ImplicitSolver::commit(const Prepared& s, const Iterate& it) {
  const std::size_t n_particles = particles_.size();
  yielding_.resize(n_particles);
  for (std::size_t p = 0; p < n_particles; ++p) {
    yielding_[p] = it.state[p].plastic_strain > particles_.state[p].plastic_strain
                       ? strain_increment(it.gradient[p], 1.0)
                       : Strain::Zero();
    Vec2 du = Vec2::Zero();
    for (const NodeWeight& w : s.nodes[p])
      du += w.value * it.increment[static_cast<std::size_t>(w.node)];
    particles_.velocity[p] = du / s.dt;
    particles_.stress[p] = it.stress[p];
    particles_.state[p] = it.state[p];
    particles_.deformation_gradient[p] =
        update_deformation_gradient(it.gradient[p], 1.0, particles_.deformation_gradient[p]);
    if (mesh_) continue;  // the mesh's motion sets the position and the volume (below)
    particles_.position[p] += du;
    particles_.volume[p] =
        particles_.deformation_gradient[p].determinant() * particles_.initial_volume[p];
    if (!(particles_.volume[p] > 0.0)) {
      throw SimulationError("particle " + std::to_string(p) +
                            " inverted (det F <= 0) at t = " + std::to_string(s.t_end) + " s");
    }
  }
  // On a mesh the nodes move, and the points' positions and volumes are the moved mesh's (its
  // det J, which also judges an inverted element).
  if (mesh_) mesh_->move(it.increment, particles_);
  // The supports' reactions: at a held node the force the support adds to balance it,
  // internal - external (on the step's start geometry, where the iteration balanced it).
  std::vector<Vec2> node_reaction(n_nodes_, Vec2::Zero());
  for (std::size_t n = 0; n < n_nodes_; ++n) {
    if (fixed_[n] != kFixNone) node_reaction[n] = it.internal[n] - s.external[n];
  }
  support_reactions_ = prescribed_.reactions(node_reaction);
  constraint_target_ = s.constraint_target;
  constraint_reports_ = it.reports;
  carried_gaps_.assign(case_.constraints.size(), {});
  for (const implicit_detail::ConstraintPoint& q : s.points) {
    Vec2 du = Vec2::Zero();
    for (const auto& [node, value] : q.nodes)
      du += value * it.increment[static_cast<std::size_t>(node)];
    carried_gaps_[static_cast<std::size_t>(q.constraint)].push_back(
        {q.x + du, q.offset + q.projector * du});
  }
  time_ = s.t_end;
}

void ImplicitSolver::build_pattern(Prepared& s) const {
  const std::size_t n_particles = particles_.size();
  s.unknowns.resize(n_particles);
  s.position_of.resize(n_particles);
  // The distinct sets of unknowns, each with its index: one set's pairs enter the pattern once.
  std::map<std::vector<int>, int> sets;
  s.terms.resize(n_particles);
  s.start.resize(n_particles);
  s.stencil_in_strain.resize(n_particles);
  std::vector<Eigen::Triplet<double>> pairs;
  for (std::size_t p = 0; p < n_particles; ++p) {
    std::vector<int>& own = s.unknowns[p];
    for (const NodeStrain& ns : s.strain[p]) {
      for (int d = 0; d < 2; ++d) {
        for (const auto& [dof, w] :
             s.map[2 * static_cast<std::size_t>(ns.node) + static_cast<std::size_t>(d)].terms)
          own.push_back(dof);
      }
    }
    std::sort(own.begin(), own.end());
    own.erase(std::unique(own.begin(), own.end()), own.end());
    const auto [set, added] = sets.emplace(own, static_cast<int>(sets.size()));
    s.position_of[p] = set->second;
    if (added) {
      for (const int i : own)
        for (const int j : own) pairs.emplace_back(i, j, 0.0);
    }
    std::vector<std::pair<int, double>>& terms = s.terms[p];
    std::vector<int>& start = s.start[p];
    start.assign(1, 0);
    for (const NodeStrain& ns : s.strain[p]) {
      for (int d = 0; d < 2; ++d) {
        for (const auto& [dof, w] :
             s.map[2 * static_cast<std::size_t>(ns.node) + static_cast<std::size_t>(d)].terms) {
          const auto place = std::lower_bound(own.begin(), own.end(), dof) - own.begin();
          terms.emplace_back(static_cast<int>(place), w);
        }
        start.push_back(static_cast<int>(terms.size()));
      }
    }
    for (const NodeWeight& w : s.nodes[p]) {
      const auto& strain = s.strain[p];
      const auto k = std::find_if(strain.begin(), strain.end(),
                                  [&](const NodeStrain& e) { return e.node == w.node; });
      s.stencil_in_strain[p].push_back(static_cast<int>(k - strain.begin()));
    }
  }
  add_constraint_pairs(s, pairs);
  add_ghost_pairs(s, pairs);
  s.pattern.resize(s.n_dofs, s.n_dofs);
  s.pattern.setFromTriplets(pairs.begin(), pairs.end());
  s.pattern.makeCompressed();
  s.positions.resize(sets.size());
  for (const auto& [own, index] : sets) {
    std::vector<int>& where = s.positions[static_cast<std::size_t>(index)];
    where.resize(own.size() * own.size());
    for (std::size_t a = 0; a < own.size(); ++a) {
      for (std::size_t b = 0; b < own.size(); ++b)
        where[a * own.size() + b] = implicit_detail::place(s.pattern, own[a], own[b]);
    }
  }
  place_constraint_pairs(s);
  place_ghost_pairs(s);
}

namespace {

/// Calls add(node, coefficient) for ghost g's node (1) and its array (minus the weights).
template <class Add>
void for_each_ghost_node(const NodeTies& ghosts, std::size_t g, Add&& add) {
  add(ghosts.outer[g], 1.0);
  for (int e = ghosts.start[g]; e < ghosts.start[g + 1]; ++e) {
    add(ghosts.inner[static_cast<std::size_t>(e)], -ghosts.weight[static_cast<std::size_t>(e)]);
  }
}

}  // namespace

void ImplicitSolver::add_ghost_pairs(Prepared& s, std::vector<Eigen::Triplet<double>>& pairs) {
  s.ghost_unknowns.assign(s.ghosts.size(), {});
  for (std::size_t g = 0; g < s.ghosts.size(); ++g) {
    std::vector<int>& own = s.ghost_unknowns[g];
    for_each_ghost_node(s.ghosts, g, [&](int node, double) {
      for (std::size_t d = 0; d < 2; ++d) {
        for (const auto& [dof, w] : s.map[2 * static_cast<std::size_t>(node) + d].terms)
          own.push_back(dof);
      }
    });
    std::sort(own.begin(), own.end());
    own.erase(std::unique(own.begin(), own.end()), own.end());
    for (const int i : own)
      for (const int j : own) pairs.emplace_back(i, j, 0.0);
  }
}

void ImplicitSolver::place_ghost_pairs(Prepared& s) {
  s.ghost_where.assign(s.ghosts.size(), {});
  for (std::size_t g = 0; g < s.ghosts.size(); ++g) {
    const std::vector<int>& own = s.ghost_unknowns[g];
    for (const int column : own) {
      for (const int row : own)
        s.ghost_where[g].push_back(implicit_detail::place(s.pattern, row, column));
    }
  }
}

void ImplicitSolver::add_ghost_penalty(const Prepared& s, bool tangent, Iterate& it) {
  // Per light node j and component d, the energy k g^2 / 2 of its deviation from the
  // extrapolation of its array, g = du_j - sum_i e_ij du_i: the force k g (1, -e_ij) on the
  // nodes, the stiffness k c c^T over the unknowns.
  std::vector<double> c;
  for (std::size_t g = 0; g < s.ghosts.size(); ++g) {
    const double k = s.ghost_stiffness[g];
    const std::vector<int>& own = s.ghost_unknowns[g];
    for (std::size_t d = 0; d < 2; ++d) {
      double gap = 0.0;
      for_each_ghost_node(s.ghosts, g, [&](int node, double w) {
        gap += w * it.increment[static_cast<std::size_t>(node)][static_cast<Eigen::Index>(d)];
      });
      for_each_ghost_node(s.ghosts, g, [&](int node, double w) {
        it.internal[static_cast<std::size_t>(node)][static_cast<Eigen::Index>(d)] += k * w * gap;
      });
      if (!tangent) continue;
      c.assign(own.size(), 0.0);
      for_each_ghost_node(s.ghosts, g, [&](int node, double w) {
        for (const auto& [dof, v] : s.map[2 * static_cast<std::size_t>(node) + d].terms)
          c[static_cast<std::size_t>(std::lower_bound(own.begin(), own.end(), dof) -
                                     own.begin())] += w * v;
      });
      double* values = it.tangent.valuePtr();
      const std::vector<int>& where = s.ghost_where[g];
      for (std::size_t b = 0; b < own.size(); ++b) {
        for (std::size_t a = 0; a < own.size(); ++a)
          values[where[b * own.size() + a]] += k * c[a] * c[b];
      }
    }
  }
}

bool ImplicitSolver::try_step(double dt) {
  const std::size_t n_particles = particles_.size();
  const std::size_t n_nodes = n_nodes_;
  Prepared s;
  s.dt = dt;
  s.t_end = time_ + dt;
  reduce_strength(s.t_end);
  locate(s);
  hold_and_tie(s);
  apply_external_force(s);
  number_unknowns(s);
  build_strain_operators(s);
  place_constraints(s);
  build_pattern(s);
  Iterate it;
  it.tangent = std::move(s.pattern);  // the values are the iterations'; s keeps the places
  it.increment.assign(n_nodes, Vec2::Zero());
  it.internal.assign(n_nodes, Vec2::Zero());
  it.gradient.resize(n_particles);
  it.stress.resize(n_particles);
  it.state.resize(n_particles);
  if (!s.fitted.empty()) it.stress_jacobian.resize(n_particles);
  it.reports.assign(case_.constraints.size(), ConstraintReport{});
  LoadStepLog entry;
  entry.time = s.t_end;
  entry.dt = dt;
  entry.converged = newton(s, it, entry);
  log_.push_back(entry);
  if (entry.converged) commit(s, it);
  return entry.converged;
}

}  // namespace pfm

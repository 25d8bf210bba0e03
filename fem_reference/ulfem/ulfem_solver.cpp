#include "fem_reference/ulfem/ulfem_solver.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>

#include "mpm/core/json_input.hpp"
#include "mpm/core/kinematics.hpp"
#include "mpm/core/shape_functions.hpp"
#include "mpm/step/body_fill.hpp"
#include "mpm/step/stage_timer.hpp"

namespace pfm::ulfem {

namespace {

// Below this many elements a parallel region costs more than it saves (and a busy machine can
// deschedule a team member for milliseconds).
constexpr std::size_t kParallelElements = 2048;
std::string fmt(double v) {
  char buffer[32];
  std::snprintf(buffer, sizeof buffer, "%.6g", v);
  return buffer;
}

}  // namespace

UlFemSolver::UlFemSolver(const Case& c) : UlFemSolver(c, mesh_case(c)) {}

namespace {

/// The UL-FEM's mesh has its boundary on its nodes: a displacement is prescribed there, by
/// boundary_conditions on a node set, not by constraints on a detected boundary.
const Case& without_constraints(const Case& c) {
  if (!c.constraints.empty()) {
    throw InputError(c.file +
                     ": /constraints: the UL-FEM prescribes motion on mesh nodes (a node set in "
                     "boundary_conditions with \"velocity\"), not on a detected boundary");
  }
  return c;
}

}  // namespace

UlFemSolver::UlFemSolver(const Case& c, QuadMesh mesh)
    : case_(without_constraints(c)), mesh_(std::move(mesh)) {
  if (c.solver.type != SolverType::kExplicit) {
    throw InputError(c.file + ": /solver/type: the UL-FEM is explicit; it takes \"explicit\" " +
                     "cases");
  }
  node_position_ = mesh_.node_position;
  node_reference_ = mesh_.node_position;
  const std::size_t n_nodes = mesh_.n_nodes();
  nodes_.mass.assign(n_nodes, 0.0);
  nodes_.momentum.assign(n_nodes, Vec2::Zero());
  nodes_.internal_force.assign(n_nodes, Vec2::Zero());
  nodes_.external_force.assign(n_nodes, Vec2::Zero());
  nodes_.body_force.assign(n_nodes, Vec2::Zero());
  nodes_.velocity.assign(n_nodes, Vec2::Zero());
  nodes_.acceleration.assign(n_nodes, Vec2::Zero());
  nodes_.fixed.assign(n_nodes, kFixNone);
  nodes_.reaction.assign(n_nodes, Vec2::Zero());
  remapped_velocity_.assign(n_nodes, Vec2::Zero());
  if (case_.solver.xpic_order > 1) {
    for (std::vector<Vec2>* field : {&xpic_term_, &xpic_iterate_, &xpic_sum_}) {
      field->assign(n_nodes, Vec2::Zero());
    }
  }
  for (std::size_t k = 0; k < 4; ++k) {
    shape_value_[k] = gauss_slots()[k].value;
    shape_natural_gradient_[k] = gauss_slots()[k].natural_gradient;
  }
  gradient_.resize(4 * mesh_.n_elements());
  det_jacobian_.resize(4 * mesh_.n_elements());
  compute_geometry();
  particles_ = material_points(case_, mesh_, node_position_);
  build_constraints();
  edge_loading_ = EdgeLoading(case_, mesh_);
  load_work_recorder_ = LoadWorkRecorder(case_.loads.size());
  counters_.energy.load_work_by_load.assign(case_.loads.size(), 0.0);

  // Critical time step h_min / c_p, h_min = smallest (area / longest edge) of the mesh (h for a
  // square cell, as the MPM's h / c_p).
  max_wave_speed_ = largest_wave_speed(case_);
  critical_dt_ = min_element_length_ / max_wave_speed_;
  if (case_.time.dt) {
    if (*case_.time.dt > critical_dt_) {
      throw InputError(case_.file + ": /time/dt: " + std::to_string(*case_.time.dt) +
                       " s exceeds the critical time step of the mesh h_min / c_p = " +
                       std::to_string(critical_dt_) + " s");
    }
    base_dt_ = *case_.time.dt;
  } else {
    base_dt_ = case_.time.cfl * critical_dt_;
  }
  counters_.dt = base_dt_;
  counters_.damping = case_.solver.damping;
  point_energy_.assign(particles_.size(), {});
  for (const MaterialRecord& m : case_.materials)
    material_constants_.push_back(material_constants(m.model));
}

void UlFemSolver::set_dt(double dt) {
  if (!(dt > 0.0) || dt > critical_dt_) {
    throw SimulationError("time step " + std::to_string(dt) + " s outside (0, " +
                          std::to_string(critical_dt_) + "]");
  }
  base_dt_ = counters_.dt = dt;
}

void UlFemSolver::build_constraints() {
  prescribed_ = PrescribedVelocity(case_.boundary_conditions, mesh_.n_nodes());
  for (std::size_t k = 0; k < case_.boundary_conditions.size(); ++k) {
    const BoundaryCondition& bc = case_.boundary_conditions[k];
    for (std::size_t n = 0; n < mesh_.n_nodes(); ++n) {
      if (!mesh_node_held(case_, bc, node_reference_[n])) continue;
      nodes_.fixed[n] |= bc.fix;
      prescribed_.add(k, n);
    }
  }
}

void UlFemSolver::compute_geometry(bool account_energy) {
  const std::size_t n_elements = mesh_.n_elements();
  long inverted = -1;
  double min_length = std::numeric_limits<double>::infinity();
#pragma omp parallel for schedule(static) reduction(max         \
                                                    : inverted) \
    reduction(min                                               \
              : min_length) if (n_elements >= kParallelElements)
  for (std::size_t e = 0; e < n_elements; ++e) {
    Eigen::Matrix<double, 4, 2> x;  // row a = current position of node a
    for (std::size_t a = 0; a < 4; ++a) {
      x.row(static_cast<Eigen::Index>(a)) =
          node_position_[static_cast<std::size_t>(mesh_.element_nodes[e][a])].transpose();
    }
    for (std::size_t k = 0; k < 4; ++k) {
      // J(i, j) = d x_i / d xi_j = sum_a x_a,i dN_a/dxi_j; grad N_a = J^-T (dN_a/dxi).
      const Mat2 jacobian = x.transpose() * shape_natural_gradient_[k];
      const double det = jacobian.determinant();
      det_jacobian_[4 * e + k] = det;
      if (!(det > 0.0)) {
        inverted = std::max(inverted, static_cast<long>(4 * e + k));
        continue;
      }
      gradient_[4 * e + k] = shape_natural_gradient_[k] * jacobian.inverse();
    }
    double area = 0.0, longest = 0.0;
    for (std::size_t a = 0; a < 4; ++a) {
      const Vec2 p = x.row(static_cast<Eigen::Index>(a)).transpose();
      const Vec2 q = x.row(static_cast<Eigen::Index>((a + 1) % 4)).transpose();
      area += 0.5 * (p.x() * q.y() - q.x() * p.y());
      longest = std::max(longest, (q - p).norm());
    }
    min_length = std::min(min_length, area / longest);
  }
  if (inverted >= 0) {
    const auto p = static_cast<std::size_t>(inverted);
    const std::size_t e = p / 4;
    Vec2 centre = Vec2::Zero();
    for (int n : mesh_.element_nodes[e])
      centre += 0.25 * node_position_[static_cast<std::size_t>(n)];
    throw SimulationError("element inverted: " + describe_element(mesh_, e, centre) +
                          ", det J = " + fmt(det_jacobian_[p]) + " m^2 <= 0 at its Gauss point " +
                          std::to_string(p % 4) + " at t = " + std::to_string(counters_.time) +
                          " s (step " + std::to_string(counters_.step) + ")");
  }
  min_element_length_ = min_length;
  // Current volumes of the material points: det J x weight (1). After a step's move the
  // elastic energy V psi changes by (V' - V) psi at the updated stress (the ledger's
  // volume_work; the stress update works at the volume of the start of the step).
  double volume_work = 0.0;
  for (std::size_t p = 0; p < particles_.size(); ++p) {
    if (account_energy) {
      const auto mi = static_cast<std::size_t>(particles_.material[p]);
      volume_work += (det_jacobian_[p] - particles_.volume[p]) *
                     elastic_energy_density(material_constants_[mi], particles_.stress[p]);
    }
    particles_.volume[p] = det_jacobian_[p];
  }
  counters_.energy.volume_work += volume_work;
}

double UlFemSolver::gravity_factor(double t) const {
  if (counters_.gravity_full || case_.gravity.ramp_time <= 0.0) return 1.0;
  return std::min(1.0, t / case_.gravity.ramp_time);
}

void UlFemSolver::step() {
  // The mesh is never reset, so crushed elements lower the stable time step: the step is the
  // base step, reduced to cfl x (smallest current element length) / (c_p + |v|max) when that
  // is smaller (explicit FE practice; the MPM keeps its cells and needs no such reduction).
  counters_.dt = std::min(
      base_dt_, case_.time.cfl * min_element_length_ / (max_wave_speed_ + max_particle_speed_));
  // The stages in the scheme's order (step_scheme.hpp); the mesh moves after them.
  struct Stages {
    UlFemSolver& s;
    void particles_to_grid() { s.particles_to_nodes(false); }
    void external_forces() { s.external_forces(); }
    void update_grid() { s.update_nodes(); }
    void grid_to_particles(bool) { s.nodes_to_particles(); }
    void remap() { s.remap(); }
    void update_stress(bool musl) {
      s.update_stress(musl ? s.remapped_velocity_ : s.nodes_.velocity);
    }
  };
  run_stages(case_.solver.scheme, Stages{*this}, times_);
  counters_.time += counters_.dt;
  ++counters_.step;
  {
    StageTimer timer(times_.locate);
    move_mesh();
  }
  check_particles();
}

void UlFemSolver::remap() {
  particles_to_nodes(true);
  const std::size_t n_nodes = nodes_.mass.size();
  const double tiny = 1e-12 * particles_.mass.front();
  for (std::size_t n = 0; n < n_nodes; ++n) {
    remapped_velocity_[n] = node_velocity(nodes_.mass[n], nodes_.momentum[n], nodes_.fixed[n],
                                          prescribed_.end()[n], tiny);
  }
}

void UlFemSolver::particles_to_nodes(bool momentum_only) {
  std::fill(nodes_.momentum.begin(), nodes_.momentum.end(), Vec2::Zero());
  if (!momentum_only) {
    std::fill(nodes_.mass.begin(), nodes_.mass.end(), 0.0);
    std::fill(nodes_.internal_force.begin(), nodes_.internal_force.end(), Vec2::Zero());
    std::fill(nodes_.body_force.begin(), nodes_.body_force.end(), Vec2::Zero());
  }
  // Serial over elements in index order: every node receives its contributions in a fixed
  // order (bitwise reproducible).
  const std::size_t n_elements = mesh_.n_elements();
  for (std::size_t e = 0; e < n_elements; ++e) {
    const std::array<int, 4>& element = mesh_.element_nodes[e];
    // B-bar: the element's volume-weighted mean in-plane stress trace (mean_dilatation_stress).
    double mean_trace = 0.0;
    if (case_.solver.mean_dilatation && !momentum_only) {
      double volume = 0.0;
      for (std::size_t k = 0; k < 4; ++k) {
        const Stress& sig = particles_.stress[4 * e + k];
        volume += particles_.volume[4 * e + k];
        mean_trace += particles_.volume[4 * e + k] * (sig[kXX] + sig[kYY]);
      }
      mean_trace /= volume;
    }
    for (std::size_t k = 0; k < 4; ++k) {
      const std::size_t p = 4 * e + k;
      const double m = particles_.mass[p];
      const Vec2 mv = m * particles_.velocity[p];
      const Eigen::Vector4d& shape = shape_value_[k];
      if (momentum_only) {
        for (std::size_t a = 0; a < 4; ++a) {
          nodes_.momentum[static_cast<std::size_t>(element[a])] +=
              shape[static_cast<Eigen::Index>(a)] * mv;
        }
        continue;
      }
      const Stress sig = case_.solver.mean_dilatation
                             ? mean_dilatation_stress(particles_.stress[p], mean_trace)
                             : particles_.stress[p];
      // A manufactured solution's body force m_p b(X_p, t) at the start of the step.
      const PointShare q{m,
                         mv,
                         particles_.volume[p],
                         Vec2(sig[kXX], sig[kXY]),
                         Vec2(sig[kXY], sig[kYY]),
                         case_.manufactured
                             ? Vec2(m * case_.manufactured->body_force(
                                            particles_.reference_position[p], counters_.time))
                             : Vec2::Zero()};
      const Eigen::Matrix<double, 4, 2>& grad = gradient_[p];
      for (std::size_t a = 0; a < 4; ++a) {
        const auto node = static_cast<std::size_t>(element[a]);
        add_to_node(q, shape[static_cast<Eigen::Index>(a)], grad(static_cast<Eigen::Index>(a), 0),
                    grad(static_cast<Eigen::Index>(a), 1), case_.manufactured.has_value(),
                    nodes_.mass[node], nodes_.momentum[node], nodes_.internal_force[node],
                    nodes_.body_force[node]);
      }
    }
  }
}

void UlFemSolver::external_forces() {
  const double gy = -case_.gravity.g * gravity_factor(counters_.time);
  const std::size_t n_nodes = nodes_.mass.size();
  for (std::size_t n = 0; n < n_nodes; ++n) {
    // A manufactured solution has no gravity (case.cpp): its body force stays as summed.
    if (!case_.manufactured) nodes_.body_force[n] = Vec2(0.0, nodes_.mass[n] * gy);
    nodes_.external_force[n] = nodes_.body_force[n];
  }
  load_work_recorder_.clear();
  if (!counters_.loads_active) return;  // gravity loading of the initial stress: no loads, no hook
  apply_loads();
  if (hook_) {
    hook_({counters_.time, counters_.dt, counters_.step, particles_, load_work_recorder_}, nodes_,
          nodes_.external_force);
  }
}

void UlFemSolver::apply_loads() {
  edge_loading_.add(counters_.time, node_position_, node_reference_, nodes_.external_force,
                    load_diagnostics_, &load_work_recorder_);
}

void UlFemSolver::update_nodes() {
  // The node update the MPM's grid takes too (grid_stages.hpp), in node order.
  prescribed_.update(counters_.time, counters_.dt);
  const std::size_t n_nodes = nodes_.mass.size();
  const double tiny = 1e-12 * particles_.mass.front();
  NodeEnergy step;
  pfm::update_nodes(nodes_, 0, n_nodes, prescribed_.start(), prescribed_.end(), tiny,
                    counters_.damping, case_.solver.damping_form, counters_.dt, step);
  counters_.energy.add_grid_update(step);
  grid_kinetic_after_ = step.kinetic_after;
  load_work_recorder_.book(counters_.dt, tiny, nodes_.mass, nodes_.momentum, nodes_.velocity,
                           nodes_.fixed, prescribed_.start(), counters_.energy.load_work_by_load);
}

void UlFemSolver::xpic_extrapolation() {
  const std::size_t n_nodes = nodes_.mass.size();
  const std::size_t n_elements = mesh_.n_elements();
  const double dt = counters_.dt;
  const double tiny = 1e-12 * particles_.mass.front();
  // g_1: the nodes' velocity of the step's start (the prescribed one on fixed components).
  for (std::size_t n = 0; n < n_nodes; ++n) {
    xpic_iterate_[n] = nodes_.velocity[n] - dt * nodes_.acceleration[n];
  }
  // S+ S: interpolated to the points, summed back with their masses, serially over the
  // elements in index order as particles_to_nodes.
  auto project = [&](std::span<Vec2> iterate) {
    std::fill(xpic_sum_.begin(), xpic_sum_.end(), Vec2::Zero());
    for (std::size_t e = 0; e < n_elements; ++e) {
      const std::array<int, 4>& element = mesh_.element_nodes[e];
      for (std::size_t k = 0; k < 4; ++k) {
        const Eigen::Vector4d& shape = shape_value_[k];
        Vec2 u = Vec2::Zero();
        for (std::size_t a = 0; a < 4; ++a) {
          u += shape[static_cast<Eigen::Index>(a)] * iterate[static_cast<std::size_t>(element[a])];
        }
        const Vec2 mu = particles_.mass[4 * e + k] * u;
        for (std::size_t a = 0; a < 4; ++a) {
          xpic_sum_[static_cast<std::size_t>(element[a])] +=
              shape[static_cast<Eigen::Index>(a)] * mu;
        }
      }
    }
    for (std::size_t n = 0; n < n_nodes; ++n) {
      iterate[n] = node_velocity(nodes_.mass[n], xpic_sum_[n], nodes_.fixed[n],
                                 prescribed_.start()[n], tiny);
    }
  };
  xpic_grid_term(case_.solver.xpic_order, std::span<Vec2>(xpic_iterate_),
                 std::span<Vec2>(xpic_term_), project);
}

void UlFemSolver::nodes_to_particles() {
  const std::size_t n_elements = mesh_.n_elements();
  const double dt = counters_.dt;
  const double pic_fraction = case_.solver.pic_fraction;
  // XPIC(m): the PIC part interpolates v' + xpic_term_ (xpic_grid_term, grid_stages.hpp).
  const bool xpic = case_.solver.xpic_order > 1;
  if (xpic) xpic_extrapolation();
#pragma omp parallel for schedule(static) if (n_elements >= kParallelElements)
  for (std::size_t e = 0; e < n_elements; ++e) {
    for (std::size_t k = 0; k < 4; ++k) {
      Vec2 a = Vec2::Zero(), v = Vec2::Zero(), c = Vec2::Zero();
      for (std::size_t n = 0; n < 4; ++n) {
        const auto node = static_cast<std::size_t>(mesh_.element_nodes[e][n]);
        const double weight = shape_value_[k][static_cast<Eigen::Index>(n)];
        a += weight * nodes_.acceleration[node];
        v += weight * nodes_.velocity[node];
        if (xpic) c += weight * xpic_term_[node];
      }
      Vec2& vp = particles_.velocity[4 * e + k];
      vp = flip_pic_velocity(vp, a, xpic ? Vec2(v + c) : v, dt, pic_fraction);
    }
  }
}

void UlFemSolver::update_stress(const std::vector<Vec2>& node_velocity) {
  const std::size_t n_elements = mesh_.n_elements();
  const double dt = counters_.dt;
  const std::vector<MaterialRecord>& materials = case_.materials;
#pragma omp parallel for schedule(static) if (n_elements >= kParallelElements)
  for (std::size_t e = 0; e < n_elements; ++e) {
    std::array<Mat2, 4> gradients;  // velocity gradient, L(i, j) = d v_i / d x_j, per point
    double element_volume = 0.0, trace = 0.0;
    for (std::size_t k = 0; k < 4; ++k) {
      const std::size_t p = 4 * e + k;
      const Eigen::Matrix<double, 4, 2>& grad = gradient_[p];  // start-of-step geometry
      Mat2& l = gradients[k];
      l.setZero();
      for (std::size_t a = 0; a < 4; ++a) {
        const Vec2& v = node_velocity[static_cast<std::size_t>(mesh_.element_nodes[e][a])];
        const double gx = grad(static_cast<Eigen::Index>(a), 0);
        const double gy = grad(static_cast<Eigen::Index>(a), 1);
        l(0, 0) += v.x() * gx;
        l(0, 1) += v.x() * gy;
        l(1, 0) += v.y() * gx;
        l(1, 1) += v.y() * gy;
      }
      element_volume += particles_.volume[p];
      trace += particles_.volume[p] * l.trace();
    }
    for (std::size_t k = 0; k < 4; ++k) {
      const std::size_t p = 4 * e + k;
      const Mat2 l = case_.solver.mean_dilatation
                         ? mean_dilatation_gradient(gradients[k], trace / element_volume)
                         : gradients[k];
      Stress& sig = particles_.stress[p];
      const Stress before = sig;
      Stress rotated;
      const auto mi = static_cast<std::size_t>(particles_.material[p]);
      const Strain de = update_point_stress(l, dt, materials[mi].model, material_constants_[mi],
                                            sig, particles_.state[p], rotated);
      particles_.deformation_gradient[p] =
          update_deformation_gradient(l, dt, particles_.deformation_gradient[p]);
      // At the volume of the start of the step: the mesh moves after this (move_mesh, whose
      // geometry update books the volume change).
      const double volume = particles_.volume[p];
      point_energy_[p] = PointEnergy{};
      add_stress_update_energy(material_constants_[mi], before, rotated, sig, de, volume, volume,
                               point_energy_[p]);
    }
  }
  PointEnergy step;
  for (const PointEnergy& e : point_energy_) step.add(e);
  counters_.energy.add_stress_update(step);
}

void UlFemSolver::move_mesh() {
  const double dt = counters_.dt;
  for (std::size_t n = 0; n < node_position_.size(); ++n)
    node_position_[n] += dt * nodes_.velocity[n];
  // Material points stay at their natural coordinates.
  const std::size_t n_elements = mesh_.n_elements();
  for (std::size_t e = 0; e < n_elements; ++e) {
    for (std::size_t k = 0; k < 4; ++k)
      particles_.position[4 * e + k] = point_position(mesh_, node_position_, e, k);
  }
  compute_geometry(true);  // throws SimulationError on an inverted element
}

void UlFemSolver::displace_nodes(const std::vector<Vec2>& displacement) {
  if (displacement.size() != node_position_.size()) {
    throw std::invalid_argument("displace_nodes: one displacement per mesh node");
  }
  for (std::size_t n = 0; n < node_position_.size(); ++n) node_position_[n] += displacement[n];
  for (std::size_t e = 0; e < mesh_.n_elements(); ++e) {
    for (std::size_t k = 0; k < 4; ++k)
      particles_.position[4 * e + k] = point_position(mesh_, node_position_, e, k);
  }
  compute_geometry();
}

void UlFemSolver::update_stress_from_node_velocity(const std::vector<Vec2>& node_velocity) {
  if (node_velocity.size() != node_position_.size()) {
    throw std::invalid_argument("update_stress_from_node_velocity: one velocity per mesh node");
  }
  update_stress(node_velocity);
}

void UlFemSolver::check_particles() {
  const std::size_t n = particles_.size();
  long bad = -1;
  double max_speed = 0.0, kinetic = 0.0;  // kinetic: in particle_kinetic_energy()'s order
  for (std::size_t p = 0; p < n; ++p) {
    const bool finite = particles_.position[p].allFinite() && particles_.velocity[p].allFinite() &&
                        particles_.stress[p].allFinite();
    if (!finite) bad = std::max(bad, static_cast<long>(p));
    max_speed = std::max(max_speed, particles_.velocity[p].norm());
    kinetic += 0.5 * particles_.mass[p] * particles_.velocity[p].squaredNorm();
  }
  max_particle_speed_ = max_speed;
  counters_.energy.transfer_to_particles += kinetic - grid_kinetic_after_;
  counters_.energy.particle_kinetic = kinetic;
  if (bad >= 0) {
    const auto p = static_cast<std::size_t>(bad);
    throw SimulationError("non-finite value (NaN or inf) at material point " + std::to_string(p) +
                          " of " + describe_element(mesh_, p / 4, particles_.position[p]) +
                          " at t = " + std::to_string(counters_.time) + " s (step " +
                          std::to_string(counters_.step) + ")");
  }
  // Courant condition on the current mesh, material speed added to the wave speed.
  if ((max_wave_speed_ + max_speed) * counters_.dt > min_element_length_) {
    throw SimulationError("CFL condition violated at t = " + std::to_string(counters_.time) +
                          " s (step " + std::to_string(counters_.step) + "): (c_p + |v|max) dt = " +
                          std::to_string((max_wave_speed_ + max_speed) * counters_.dt) +
                          " m > smallest element length " + std::to_string(min_element_length_) +
                          " m: a unit mistake? (E and stresses in kPa, unit weight in kN/m^3, "
                          "lengths in m)");
  }
}

double UlFemSolver::particle_kinetic_energy() const {
  double kinetic = 0.0;
  for (std::size_t p = 0; p < particles_.size(); ++p)
    kinetic += 0.5 * particles_.mass[p] * particles_.velocity[p].squaredNorm();
  return kinetic;
}

EnergyBalance UlFemSolver::energy() const {
  return energy_balance(particles_, material_constants_, particle_kinetic_energy(),
                        counters_.energy, prescribed_.reactions(nodes_.reaction));
}

std::vector<Vec2> UlFemSolver::node_displacement() const {
  std::vector<Vec2> u(node_position_.size());
  for (std::size_t n = 0; n < u.size(); ++n) u[n] = node_position_[n] - node_reference_[n];
  return u;
}

void UlFemSolver::initialise_stress() {
  // As MpmSolver::initialise_stress; after gravity loading the nodes' reference positions are
  // reset with the particles'.
  const bool gravity_loaded = pfm::initialise_stress(
      case_, particles_, counters_, [this] { step(); },
      [this] { return particle_kinetic_energy(); });
  if (gravity_loaded) node_reference_ = node_position_;
  // The ledger starts from the state reached.
  start_ledger(counters_.energy, energy(), case_.loads.size());
}

}  // namespace pfm::ulfem

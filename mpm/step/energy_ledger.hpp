// The energy ledger of the explicit step, shared by the MPM and the updated-Lagrangian FEM.
//
// Every term is measured where it happens, in kJ per m thickness, accumulated from time 0 (the
// state after the initial stress procedure). One step of either solver (MUSL or USL) is:
//
//   particles -> nodes   nodal momentum p_I = sum_p N_Ip m_p v_p; the kinetic energy of the
//                        nodes, sum_I |p_I|^2 / (2 m_I) over the nodes with mass, minus that of
//                        the particles before the step is `transfer_to_grid` (<= 0: the
//                        projection loses the kinetic energy of the velocity field it cannot
//                        represent; momentum on nodes without mass is lost too);
//   constraints          the fixed velocity components are set to their prescribed values at
//                        the step's start, zero for a support (prescribed_velocity.hpp):
//                        `constraint_work` = sum m_I (v_I,prescribed^2 - v_I,fixed^2) / 2,
//                        and the reaction R_I = m_I a_I - f_I on them (a_I from the prescribed
//                        velocities at the start and end) adds its work R_I . v_mid dt (none at
//                        a support, where v_mid = 0); the constraints on the detected boundary
//                        (boundary_constraint.hpp) add their forces' work F_I . v_mid dt;
//   grid update          v_I' = v_I + dt a_I; exactly 1/2 m (|v'|^2 - |v|^2) = m a . v_mid dt
//                        with v_mid = (v + v') / 2, split by force: `internal_force_work` =
//                        sum f_int,I . v_mid dt, `gravity_work` = sum m_I g . v_mid dt (and
//                        a manufactured solution's body force, mpm/core/manufactured.hpp),
//                        `load_work` = sum f_load,I . v_mid dt (the surface loads: their nodal
//                        forces times the velocities of the step they act in), `damping_work`
//                        (local damping, <= 0);
//   nodes -> particles   FLIP: v_p' = v_p + dt sum_I N_Ip a_I; the particles' kinetic energy
//                        after it minus the nodes' after the grid update is
//                        `transfer_to_particles` (either sign);
//   stress update        per point, with the rotated (Jaumann) stress s_r, the updated s_1, the
//                        strain increment de and the volumes V_0, V_1 (V_m their mean):
//                        `stress_power` P = V_m (s_r + s_1) / 2 : de (the internal_work of the
//                        time series), `plastic_dissipation` D = V_m (s_r + s_1) / 2 : de_p
//                        with de_p = de - C^-1 (s_1 - s_r); the elastic energy V psi(s)
//                        (materials.hpp) then changes by exactly P - D + `rotation_work` +
//                        `volume_work`, rotation_work = V_m (psi(s_r) - psi(s_0)) (the
//                        first-order Jaumann update does not conserve psi) and volume_work =
//                        (V_1 - V_0) (psi(s_0) + psi(s_1)) / 2 (psi is per current volume).
//
// Summed, the kinetic and the elastic energy obey, to rounding, the identity
//   kinetic + elastic + plastic_dissipation = initial_energy + gravity_work + load_work
//     + damping_work + constraint_work + transfer_to_grid + transfer_to_particles
//     + internal_force_work + stress_power + rotation_work + volume_work,
// whose left minus right side is `energy_error`. internal_force_work + stress_power is the
// explicit scheme's own term: the internal forces act with the stress at the start of the step
// on the grid velocities v_mid, the stress update works with the mid-step stress on the
// velocities it is given (the remapped ones in MUSL); for a leapfrog step it is
// -V ds : de / 2 per point, which oscillates about zero.
//
// Units: kJ/m (kN m per m thickness).
#pragma once

#include <algorithm>
#include <array>
#include <cmath>
#include <span>
#include <string_view>
#include <vector>

#include "mpm/core/basis_extension.hpp"
#include "mpm/core/materials.hpp"
#include "mpm/core/types.hpp"
#include "mpm/core/wall_mirror.hpp"

namespace pfm {

/// The energy terms of one node's update (kJ/m), summed over nodes by the solvers.
struct NodeEnergy {
  double kinetic_before = 0.0;  ///< |p|^2 / (2 m), before the constraints
  double kinetic_after = 0.0;   ///< m |v'|^2 / 2
  double constraint = 0.0;
  double gravity = 0.0;
  double load = 0.0;
  double damping = 0.0;
  double internal = 0.0;
  void add(const NodeEnergy& o) {
    kinetic_before += o.kinetic_before;
    kinetic_after += o.kinetic_after;
    constraint += o.constraint;
    gravity += o.gravity;
    load += o.load;
    damping += o.damping;
    internal += o.internal;
  }
};

/// A node's velocity p / m (zero for a node of mass <= tiny, which the grid update leaves alone)
/// with its fixed components `prescribed`: the MUSL remap's velocity (the prescribed velocity at
/// the step's end) and the load work's start velocity (at its start).
inline Vec2 node_velocity(double m, const Vec2& p, unsigned fixed, const Vec2& prescribed,
                          double tiny) {
  Vec2 v = Vec2::Zero();
  if (m > tiny) v = p / m;
  if (fixed & kFixX) v.x() = prescribed.x();
  if (fixed & kFixY) v.y() = prescribed.y();
  return v;
}

/// The local damping's force at a node: Cundall's per axis, or along the velocity
/// (frame-invariant); see update_node(). The case's solver.damping_form.
enum class DampingForm { kPerAxis, kAlongVelocity };

/// The explicit update of one node with mass m > 0 (thesis eq. 3.24): velocity v = p / m, local
/// damping, a force opposing the velocity proportional to the unbalanced force f; a = (f +
/// f_damping) / m; v' = v + a dt. On the fixed components v is the prescribed velocity at the
/// step's start (`start`, zero for a support) and a = (end - start) / dt with `end` the one at
/// its end; `reaction` = m a - f there (the force holding the node; zero on free components).
/// `external` holds the body force and the loads; `body_force` is its body-force part (m g,
/// vertical, and a manufactured solution's sum_p N m_p b), whose work is `gravity_work`. Adds the
/// node's ledger terms to `e`. The damping force is Cundall's, per direction, -alpha |f_d|
/// sign(v_d) (DampingForm::kPerAxis), or -alpha |f| v / |v| over the free directions
/// (kAlongVelocity). Only the second is frame-invariant: per axis, a body turned to the grid
/// feels a moment (a free square turned 20 degrees, damped to rest at alpha = 0.1, turned
/// 9e-5 rad, against 1.4e-6 undamped; test_boundary_coupling).
inline void update_node(double m, const Vec2& momentum, const Vec2& internal, const Vec2& external,
                        const Vec2& body_force, unsigned fixed_x, unsigned fixed_y, double alpha,
                        DampingForm form, double dt, const Vec2& start, const Vec2& end,
                        Vec2& velocity, Vec2& acceleration, Vec2& reaction, NodeEnergy& e) {
  Vec2 v = momentum / m;
  e.kinetic_before += 0.5 * m * v.squaredNorm();
  const Vec2 f = internal + external;
  Vec2 damping_force;
  if (form == DampingForm::kPerAxis) {
    auto sign = [](double x) { return x > 0.0 ? 1.0 : (x < 0.0 ? -1.0 : 0.0); };
    damping_force =
        Vec2(-alpha * std::abs(f.x()) * sign(v.x()), -alpha * std::abs(f.y()) * sign(v.y()));
  } else {
    const Vec2 free(fixed_x ? 0.0 : 1.0, fixed_y ? 0.0 : 1.0);
    const Vec2 f_free = f.cwiseProduct(free), v_free = v.cwiseProduct(free);
    const double speed = v_free.norm();
    damping_force = speed > 0.0 ? Vec2(-alpha * f_free.norm() / speed * v_free) : Vec2::Zero();
  }
  Vec2 a = (f + damping_force) / m;
  // A support (start = end = 0) takes the same operations as before moving supports existed:
  // its terms below add zeros, so runs without them keep their bits.
  reaction = Vec2::Zero();
  if (fixed_x) {
    e.constraint -= 0.5 * m * v.x() * v.x();
    v.x() = start.x();
    e.constraint += 0.5 * m * v.x() * v.x();
    a.x() = (end.x() - start.x()) / dt;
    reaction.x() = m * a.x() - f.x();
  }
  if (fixed_y) {
    e.constraint -= 0.5 * m * v.y() * v.y();
    v.y() = start.y();
    e.constraint += 0.5 * m * v.y() * v.y();
    a.y() = (end.y() - start.y()) / dt;
    reaction.y() = m * a.y() - f.y();
  }
  acceleration = a;
  const Vec2 v_new = v + a * dt;
  velocity = v_new;
  e.kinetic_after += 0.5 * m * v_new.squaredNorm();
  const Vec2 mid = 0.5 * (v + v_new);
  e.gravity += body_force.dot(mid) * dt;
  e.load += (external - body_force).dot(mid) * dt;
  e.internal += internal.dot(mid) * dt;
  e.damping += (a * m - f - reaction).dot(mid) * dt;  // the damping force (zero where fixed)
  e.constraint += reaction.dot(mid) * dt;             // zero at a support (mid = 0 there)
}

/// The energy terms of one point's stress update (kJ/m), summed over points by the solvers.
struct PointEnergy {
  double stress_power = 0.0;
  double plastic_dissipation = 0.0;
  double rotation = 0.0;
  double volume = 0.0;
  void add(const PointEnergy& o) {
    stress_power += o.stress_power;
    plastic_dissipation += o.plastic_dissipation;
    rotation += o.rotation;
    volume += o.volume;
  }
};

/// The ledger terms of one stress update: stress s_0 before, s_r after the Jaumann rotation, s_1
/// after the constitutive update with strain increment de (xx, yy, gamma_xy, zz = 0); volume
/// V_0 before, V_1 after (see the header comment). Returns the stress power, which is also added
/// to `e`.
inline double add_stress_update_energy(const MaterialConstants& c, const Stress& s0,
                                       const Stress& rotated, const Stress& s1, const Strain& de,
                                       double v0, double v1, PointEnergy& e) {
  const Stress mid = 0.5 * (rotated + s1);
  const double v_mid = 0.5 * (v0 + v1);
  const double power = v_mid * (mid[kXX] * de[kXX] + mid[kYY] * de[kYY] + mid[kXY] * de[kXY]);
  const Strain plastic = de - elastic_compliance(c, s1 - rotated);
  const double psi0 = elastic_energy_density(c, s0);
  const double psi1 = elastic_energy_density(c, s1);
  e.stress_power += power;
  e.plastic_dissipation += v_mid * mid.dot(plastic);
  e.rotation += v_mid * (elastic_energy_density(c, rotated) - psi0);
  e.volume += (v1 - v0) * 0.5 * (psi0 + psi1);
  return power;
}

/// The accumulated terms of the ledger (kJ/m), and what the next step needs of the last.
struct EnergyLedger {
  double initial_energy = 0.0;    ///< kinetic + elastic energy at time 0
  double particle_kinetic = 0.0;  ///< kinetic energy of the particles after the last step
  double gravity_work = 0.0;
  double load_work = 0.0;
  double damping_work = 0.0;
  double constraint_work = 0.0;
  double transfer_to_grid = 0.0;
  double transfer_to_particles = 0.0;
  double internal_force_work = 0.0;
  double stress_power = 0.0;
  double plastic_dissipation = 0.0;
  double rotation_work = 0.0;
  double volume_work = 0.0;
  /// The work of each of the case's loads on its own, in the case's order (LoadWorkRecorder);
  /// their sum is load_work to rounding. Not a term of the identity (load_work is).
  std::vector<double> load_work_by_load;

  /// The accumulated terms by name (checkpoints; names as in timeseries.csv).
  static constexpr std::array<std::string_view, 13> kNames = {
      "initial_energy",      "particle_kinetic", "gravity_work",        "load_work",
      "damping_work",        "constraint_work",  "transfer_to_grid",    "transfer_to_particles",
      "internal_force_work", "stress_power",     "plastic_dissipation", "rotation_work",
      "volume_work"};
  std::array<double*, 13> fields() {
    return {&initial_energy,      &particle_kinetic, &gravity_work,        &load_work,
            &damping_work,        &constraint_work,  &transfer_to_grid,    &transfer_to_particles,
            &internal_force_work, &stress_power,     &plastic_dissipation, &rotation_work,
            &volume_work};
  }
  /// Books a grid update's node terms (summed over nodes); the particles' kinetic energy
  /// before the step is particle_kinetic.
  void add_grid_update(const NodeEnergy& step);
  /// Books a stress update's point terms (summed over points).
  void add_stress_update(const PointEnergy& step);
  /// Work of gravity and the surface loads.
  double external_work() const { return gravity_work + load_work; }
  /// Every input to the kinetic and elastic energy since time 0, initial energy included.
  double supplied() const {
    return initial_energy + gravity_work + load_work + damping_work + constraint_work +
           transfer_to_grid + transfer_to_particles + internal_force_work + stress_power +
           rotation_work + volume_work;
  }
};

inline void EnergyLedger::add_grid_update(const NodeEnergy& step) {
  transfer_to_grid += step.kinetic_before - particle_kinetic;
  constraint_work += step.constraint;
  gravity_work += step.gravity;
  load_work += step.load;
  damping_work += step.damping;
  internal_force_work += step.internal;
}

inline void EnergyLedger::add_stress_update(const PointEnergy& step) {
  stress_power += step.stress_power;
  plastic_dissipation += step.plastic_dissipation;
  rotation_work += step.rotation;
  volume_work += step.volume;
}

/// The work of each load on its own: the nodal forces of each load in a step, recorded before
/// the grid update (add), times the velocities v_mid = (v + v') / 2 of the nodes in that update
/// (book, after it), with v = p / m and the fixed components prescribed, as update_node: the works
/// of all loads add up to the ledger's load_work (to rounding: they are summed in another order).
class LoadWorkRecorder {
 public:
  explicit LoadWorkRecorder(std::size_t n_loads = 0) : forces_(n_loads) {}
  /// Forgets the forces of the last step.
  void clear() {
    for (auto& f : forces_) f.clear();
  }
  void add(std::size_t load, std::size_t node, const Vec2& force) {
    forces_[load].push_back({node, force});
  }
  /// Moves the forces recorded on outer nodes to the inner nodes they are tied to, as the grid's
  /// forces (BasisExtension::gather): each load's work is then booked on the nodes it acts on.
  void tie(const BasisExtension& extension) {
    const NodeTies& ties = extension.ties();
    if (ties.empty()) return;
    for (auto& entries : forces_) {
      const std::size_t n = entries.size();
      for (std::size_t e = 0; e < n; ++e) {
        const int k = extension.tie_of(static_cast<int>(entries[e].node));
        if (k < 0) continue;
        const Vec2 f = entries[e].force;
        entries[e].force.setZero();
        for (int t = ties.start[static_cast<std::size_t>(k)];
             t < ties.start[static_cast<std::size_t>(k) + 1]; ++t) {
          entries.push_back({static_cast<std::size_t>(ties.inner[static_cast<std::size_t>(t)]),
                             ties.weight[static_cast<std::size_t>(t)] * f});
        }
      }
    }
  }
  /// Moves the forces recorded on mirrored components of nodes behind a wall to their image
  /// nodes and scales the images' own, as the grid's forces (WallMirror::gather); before tie().
  void mirror(const WallMirror& mirror) {
    if (mirror.empty()) return;
    for (auto& entries : forces_) {
      const std::size_t n = entries.size();
      for (std::size_t e = 0; e < n; ++e) {
        const int node = static_cast<int>(entries[e].node);
        for (int d = 0; d < 2; ++d) {
          const int image = mirror.image_at(node, d);
          if (image >= 0 && mirror.active(static_cast<std::size_t>(image))) {
            entries[e].force[d] *= mirror.scale(static_cast<std::size_t>(image));
          }
          double w = 0.0;
          const int source = mirror.source_at(node, d, w);
          if (source < 0 || !mirror.active(static_cast<std::size_t>(source))) continue;
          const auto k = static_cast<std::size_t>(source);
          Vec2 moved = Vec2::Zero();
          moved[d] = mirror.scale(k) * w * entries[e].force[d];
          entries[e].force[d] = 0.0;
          entries.push_back({static_cast<std::size_t>(mirror.images()[k].node), moved});
        }
      }
    }
  }
  /// Adds each load's work over the grid update just made to work[load] (resized to the
  /// number of loads); nodes of mass <= tiny are not updated and take no work. `start`: the
  /// prescribed velocities at the step's start (PrescribedVelocity::start()).
  void book(double dt, double tiny, std::span<const double> mass, std::span<const Vec2> momentum,
            std::span<const Vec2> velocity, std::span<const unsigned> fixed,
            std::span<const Vec2> start, std::vector<double>& work) const {
    work.resize(forces_.size(), 0.0);
    for (std::size_t k = 0; k < forces_.size(); ++k) {
      double w = 0.0;
      for (const auto& [node, force] : forces_[k]) {
        const double m = mass[node];
        if (m <= tiny) continue;
        const Vec2 v = node_velocity(m, momentum[node], fixed[node], start[node], tiny);
        w += force.dot(0.5 * (v + velocity[node])) * dt;
      }
      work[k] += w;
    }
  }

 private:
  struct Entry {
    std::size_t node;
    Vec2 force;
  };
  std::vector<std::vector<Entry>> forces_;
};

/// A constraint on the detected boundary at the last step that applied it
/// (mpm/solver/boundary_constraint.hpp).
struct ConstraintReport {
  Vec2 force = Vec2::Zero();  ///< kN/m, the constraint's force on the body
  double rms_gap = 0.0;       ///< m, root mean square of |g| along the part (arc-length weighted)
  double length = 0.0;        ///< m, of the part
  int nodes = 0;              ///< nodes that took a force
};

/// What the time series and run.json report: the ledger with the energies of the state.
struct EnergyBalance {
  double kinetic_energy = 0.0;   ///< kJ/m, of the particles
  double elastic_energy = 0.0;   ///< kJ/m, sum V_p psi(sigma_p)
  Vec2 momentum = Vec2::Zero();  ///< t m/s per m
  EnergyLedger ledger;
  /// kN/m: the reaction of each moving boundary condition in the last step
  /// (PrescribedVelocity::reactions).
  std::vector<Vec2> reactions;
  double external_work() const { return ledger.external_work(); }
  double internal_work() const { return ledger.stress_power; }
  double damping_work() const { return ledger.damping_work; }
  /// kinetic + elastic + plastic dissipation - everything supplied (zero to rounding).
  double energy_error() const {
    return kinetic_energy + elastic_energy + ledger.plastic_dissipation - ledger.supplied();
  }
  /// The largest magnitude among the energies and ledger terms (the scale of energy_error).
  double largest_term() const {
    double largest = std::max({std::abs(kinetic_energy), std::abs(elastic_energy)});
    EnergyLedger copy = ledger;
    for (double* f : copy.fields()) largest = std::max(largest, std::abs(*f));
    return largest;
  }
};

/// The energies of a solver's material points (Particles: mass, velocity, volume, stress,
/// material) now, with `kinetic` their kinetic energy (as the solver sums it), the ledger and
/// the reactions of its moving supports: what both solvers' energy() return.
template <class Points>
EnergyBalance energy_balance(const Points& particles, std::span<const MaterialConstants> constants,
                             double kinetic, const EnergyLedger& ledger,
                             std::vector<Vec2> reactions) {
  EnergyBalance e;
  e.kinetic_energy = kinetic;
  for (std::size_t p = 0; p < particles.size(); ++p) {
    e.momentum += particles.mass[p] * particles.velocity[p];
    const auto mi = static_cast<std::size_t>(particles.material[p]);
    e.elastic_energy +=
        particles.volume[p] * elastic_energy_density(constants[mi], particles.stress[p]);
  }
  e.ledger = ledger;
  e.reactions = std::move(reactions);
  return e;
}

/// Starts the ledger from the state `e` reached by the initial stress procedure: its kinetic
/// and elastic energy, no work yet by any of `n_loads` loads.
inline void start_ledger(EnergyLedger& ledger, const EnergyBalance& e, std::size_t n_loads) {
  ledger.initial_energy = e.kinetic_energy + e.elastic_energy;
  ledger.load_work_by_load.assign(n_loads, 0.0);
  ledger.particle_kinetic = e.kinetic_energy;
}

}  // namespace pfm

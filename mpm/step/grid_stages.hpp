// What the MPM's background grid and the UL-FEM's Q4 mesh share of the explicit step (thesis
// 3.3, eq. 3.24): the nodal arrays, what a material point adds to a node in the particle-to-grid
// map, the update of the nodes, a point's velocity in the grid-to-particle map and its stress
// update. Each solver keeps its own loops (the MPM over its particles by bands of grid rows on
// the threads, with their stencils; the UL-FEM over its elements) and calls these for the
// arithmetic, so that the two do the same operations in the same order. Units: kN, m, s, t, kPa.
#pragma once

#include <cstddef>
#include <span>
#include <variant>
#include <vector>

#include "mpm/core/basis_extension.hpp"
#include "mpm/core/kinematics.hpp"
#include "mpm/core/materials.hpp"
#include "mpm/core/types.hpp"
#include "mpm/step/energy_ledger.hpp"

namespace pfm {

/// Nodal arrays of the background grid (Grid::node_index) or the mesh (node index).
struct GridState {
  std::vector<double> mass;          ///< t
  std::vector<Vec2> momentum;        ///< t m/s
  std::vector<Vec2> internal_force;  ///< kN
  std::vector<Vec2> external_force;  ///< kN (surface loads and body forces)
  /// kN, the body-force part of external_force: gravity m_I g, or a manufactured solution's
  /// sum_p N_Ip m_p b(X_p, t) (the ledger's gravity_work).
  std::vector<Vec2> body_force;
  std::vector<Vec2> velocity;      ///< m/s, after the grid update
  std::vector<Vec2> acceleration;  ///< m/s^2
  std::vector<unsigned> fixed;     ///< FixMask per node
  /// kN, the force holding the fixed components of each node in the last grid update
  /// (update_node; zero on free components).
  std::vector<Vec2> reaction;
  /// The outer nodes of this step and their ties (mpm/core/basis_extension.hpp; null or empty
  /// without them): their mass, momentum and forces so far have gone to the inner nodes; the
  /// forces added to them later go there before the update.
  const NodeTies* ties = nullptr;
};

/// What a material point carries to the nodes in the particle-to-grid map.
struct PointShare {
  double mass;    ///< m_p, t
  Vec2 momentum;  ///< m_p v_p, t m/s
  double volume;  ///< V_p, m^2
  /// The rows (sxx, sxy) and (sxy, syy) of the stress the internal force takes (B-bar's mean
  /// dilatation where it is on), kPa.
  Vec2 stress_x, stress_y;
  Vec2 body_force;  ///< m_p b(X_p, t) of a manufactured solution (zero without), kN
};

/// Adds a point's share to a node whose shape function has value `weight` and gradient
/// (gx, gy) at the point: mass, momentum, the internal force -V_p sigma grad N (tension
/// positive) and, with `manufactured`, the body force.
inline void add_to_node(const PointShare& q, double weight, double gx, double gy, bool manufactured,
                        double& mass, Vec2& momentum, Vec2& internal_force, Vec2& body_force) {
  mass += weight * q.mass;
  momentum += weight * q.momentum;
  internal_force -= q.volume * (gx * q.stress_x + gy * q.stress_y);
  if (manufactured) body_force += weight * q.body_force;
}

/// The grid update of nodes [begin, end) of `g` (update_node(): damping alpha of `form`, step
/// dt, the prescribed velocities at the step's start and end on the fixed components); a node of
/// mass <= tiny gets zero velocity, acceleration and reaction. Adds the ledger terms to `e`.
inline void update_nodes(GridState& g, std::size_t begin, std::size_t end,
                         std::span<const Vec2> start, std::span<const Vec2> end_velocity,
                         double tiny, double alpha, DampingForm form, double dt, NodeEnergy& e) {
  for (std::size_t n = begin; n < end; ++n) {
    const double m = g.mass[n];
    if (m <= tiny) {
      g.velocity[n].setZero();
      g.acceleration[n].setZero();
      g.reaction[n].setZero();
      continue;
    }
    update_node(m, g.momentum[n], g.internal_force[n], g.external_force[n], g.body_force[n],
                g.fixed[n] & kFixX, g.fixed[n] & kFixY, alpha, form, dt, start[n], end_velocity[n],
                g.velocity[n], g.acceleration[n], g.reaction[n], e);
  }
}

/// A point's velocity from the grid: FLIP, v_p + dt a(x_p), blended with PIC, v(x_p), by
/// pic_fraction (solver.pic_fraction).
inline Vec2 flip_pic_velocity(const Vec2& vp, const Vec2& a, const Vec2& v, double dt,
                              double pic_fraction) {
  const Vec2 flip = vp + dt * a;
  return pic_fraction == 0.0 ? flip : Vec2((1.0 - pic_fraction) * flip + pic_fraction * v);
}

/// XPIC(m)'s grid term (solver.xpic_order m > 1; Hammerquist and Nairn 2017), the recursion both
/// explicit solvers share. On entry `iterate` holds g_1, the grid velocity of the step's start;
/// `project(iterate)` replaces g_(r-1) there by g_r = S+ S g_(r-1): the solver's interpolation S
/// to its points, then their mass-weighted sum back to the nodes over the nodal mass, S+, as the
/// momentum goes (with the supports' velocities at the step's start). `term` becomes
/// sum_r=1..m (-1)^(r+1) C(m, r) g_r - g_1: a PIC part that interpolates v' + term makes the
/// particle update V_FLIP - beta (I - S S+)^m V, where m = 1 is the FLIP/PIC blend.
template <class Project>
void xpic_grid_term(int order, std::span<Vec2> iterate, std::span<Vec2> term, Project&& project) {
  for (std::size_t n = 0; n < term.size(); ++n) {
    term[n] = static_cast<double>(order - 1) * iterate[n];
  }
  double binomial = order;  // C(m, r)
  for (int r = 2; r <= order; ++r) {
    binomial = binomial * (order - r + 1) / r;
    const double coefficient = r % 2 == 0 ? -binomial : binomial;
    project(iterate);
    for (std::size_t n = 0; n < term.size(); ++n) term[n] += coefficient * iterate[n];
  }
}

/// The stress update of a material point with velocity gradient l over dt: the strain increment
/// (returned), the Jaumann rotation of `stress` (`rotated` takes the stress after it, for the
/// ledger's rotation work), then the material's update with its constants.
inline Strain update_point_stress(const Mat2& l, double dt, const Material& model,
                                  const MaterialConstants& constants, Stress& stress,
                                  PointState& state, Stress& rotated) {
  const Strain de = strain_increment(l, dt);
  jaumann_rotate(l, dt, stress);
  rotated = stress;
  if (const auto* elastic = std::get_if<LinearElastic>(&model)) {
    elastic->update(de, stress, state, constants);
  } else if (const auto* tresca = std::get_if<Tresca>(&model)) {
    tresca->update(de, stress, state, constants);
  } else {
    std::get<MohrCoulomb>(model).update(de, stress, state, constants);
  }
  return de;
}

}  // namespace pfm

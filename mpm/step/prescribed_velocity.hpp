// Velocities prescribed on constrained nodes (boundary_conditions[].velocity) and the reactions
// that hold them, for the MPM's grid nodes and the UL-FEM's mesh nodes alike. A node's fixed
// velocity components take the prescribed values in the grid update (update_node,
// energy_ledger.hpp): at the step's start, where the projected velocity is replaced (the
// kinetic energy changed goes to the ledger's constraint_work), and at its end, which sets the
// acceleration. The reaction is the force that acceleration needs beyond the internal and
// external forces, R = m a - f on the fixed components; its work is constraint_work too.
// Units: m/s, kN/m.
#pragma once

#include <span>
#include <string>
#include <vector>

#include "mpm/step/case.hpp"

namespace pfm {

/// Whether boundary condition `bc` of case `c` holds grid node (i, j): the grid's edge it names
/// (left, right, bottom, top) or the node set of its name (within 1e-9 h of it).
inline bool grid_node_held(const Case& c, const BoundaryCondition& bc, int i, int j) {
  const Grid& grid = c.grid;
  if (bc.where == "left") return i == 0;
  if (bc.where == "right") return i == grid.n_nodes_x() - 1;
  if (bc.where == "bottom") return j == 0;
  if (bc.where == "top") return j == grid.n_nodes_y() - 1;
  bool selected = false;
  for (const NodeSet& set : c.node_sets) {
    if (set.name == bc.where)
      selected = set.contains(grid.node_position(i, j), 1e-9 * grid.cell_size);
  }
  return selected;
}

class PrescribedVelocity {
 public:
  PrescribedVelocity() = default;
  /// The case's boundary conditions on `n_nodes` nodes; add() tells which nodes each holds.
  PrescribedVelocity(const std::vector<BoundaryCondition>& conditions, std::size_t n_nodes);
  /// Node `node` is held by condition `k`.
  void add(std::size_t k, std::size_t node);
  /// The velocities of a step from t to t + dt: per node, the components fixed by a moving
  /// condition at t (start) and t + dt (end); zero elsewhere. Where a moving condition and a
  /// support fix the same component of a node, the moving one holds; between two moving ones,
  /// the later in the case.
  void update(double t, double dt);
  std::span<const Vec2> start() const { return start_; }
  std::span<const Vec2> end() const { return end_; }
  /// The reaction of each moving condition (in the case's order): the sum over its nodes of
  /// node_reaction on the components it fixes, kN/m.
  std::vector<Vec2> reactions(std::span<const Vec2> node_reaction) const;

 private:
  std::vector<BoundaryCondition> conditions_;
  std::vector<std::vector<std::size_t>> nodes_;  // per condition
  std::vector<Vec2> start_, end_;                // per node
  bool moving_ = false;
};

inline PrescribedVelocity::PrescribedVelocity(const std::vector<BoundaryCondition>& conditions,
                                              std::size_t n_nodes)
    : conditions_(conditions),
      nodes_(conditions.size()),
      start_(n_nodes, Vec2::Zero()),
      end_(n_nodes, Vec2::Zero()) {
  for (const BoundaryCondition& bc : conditions) moving_ = moving_ || bc.moving;
}

inline void PrescribedVelocity::add(std::size_t k, std::size_t node) {
  if (conditions_[k].moving) nodes_[k].push_back(node);
}

inline void PrescribedVelocity::update(double t, double dt) {
  if (!moving_) return;
  for (std::size_t k = 0; k < conditions_.size(); ++k) {
    const BoundaryCondition& bc = conditions_[k];
    if (!bc.moving) continue;
    const Vec2 v0 = bc.velocity_at(t), v1 = bc.velocity_at(t + dt);
    for (const std::size_t n : nodes_[k]) {
      if (bc.fix & kFixX) {
        start_[n].x() = v0.x();
        end_[n].x() = v1.x();
      }
      if (bc.fix & kFixY) {
        start_[n].y() = v0.y();
        end_[n].y() = v1.y();
      }
    }
  }
}

inline std::vector<Vec2> PrescribedVelocity::reactions(std::span<const Vec2> node_reaction) const {
  std::vector<Vec2> out;
  for (std::size_t k = 0; k < conditions_.size(); ++k) {
    if (!conditions_[k].moving) continue;
    Vec2 sum = Vec2::Zero();
    for (const std::size_t n : nodes_[k]) sum += node_reaction[n];
    if (!(conditions_[k].fix & kFixX)) sum.x() = 0.0;
    if (!(conditions_[k].fix & kFixY)) sum.y() = 0.0;
    out.push_back(sum);
  }
  return out;
}

/// The time-series names of the moving conditions' reactions, in the case's order: the index
/// of each in boundary_conditions (reaction_<k>_fx, reaction_<k>_fy).
inline std::vector<std::string> reaction_names(const std::vector<BoundaryCondition>& conditions) {
  std::vector<std::string> out;
  for (std::size_t k = 0; k < conditions.size(); ++k)
    if (conditions[k].moving) out.push_back(std::to_string(k));
  return out;
}

}  // namespace pfm

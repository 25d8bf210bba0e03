// Extended grid functions: the functions of nodes that hold too little material are tied to
// their interior neighbours (the extended B-splines of Hoellig, Reif & Wipper, SIAM J. Numer.
// Anal. 39, 2001; in the MPM, Yamaguchi, Moriguchi & Terada, CMAME 2021). Shared by every
// solver on the background grid: the explicit MPM's step, and the implicit one's assembly.
//
// The rule. A node is *outer* in a step when its lumped mass is below `fraction` of the mass a
// full support would hold, fraction x rho_max x int N_I dOmega (rho_max the densest particle's
// density; the integral over the grid, h^2 inside it, less on the edge-modified functions at the
// grid's edges), and above zero; the others with mass are *inner*. An outer node j keeps no
// unknown of its own: its value is the extrapolation of an array of (q + 1) x (q + 1) inner
// nodes, v_j = sum_i e_ij v_i, with the tensor-product Lagrange weights in the node indices,
//   e_ij = prod_d prod_{m != i_d} (j_d - m) / (i_d - m),  m over the array's indices along d.
// q is the functions' degree p (1 for linear and uGIMP), lower where no array of that degree
// fits (a body thinner than p + 1 inner nodes) or where the tie's negative weights would leave
// an inner node with less than half its own mass (a lumped mass that stays positive keeps the
// explicit step stable). The array is the one nearest to j (the
// box distance in nodes, then its centre's distance, then the lower indices), at most two
// nodes away. Since the weights reproduce every polynomial of degree q in the indices, and the
// B-spline coefficients of a polynomial of degree <= p are such polynomials (away from the
// grid's edges; linear ones everywhere), the extended functions N_i + sum_j e_ij N_j keep the
// partition of unity, the exact linear fields, and the order of the functions, while every
// unknown left has material under it. With weights along one axis only when the array holds
// j's column or row (a flat top: j is extrapolated down its node column, with (1, -3, 3) for
// p = 2).
//
// In a step (the Galerkin method with the extended functions, lumped): what the particles and
// loads give each node is summed with the plain functions, then gathered, x_i += e_ij x_j for
// mass, momentum and forces, and the outer node emptied (a node without material that a load
// reaches, its boundary within the node's support, is tied as well: tie_massless); the inner nodes
// are updated; the outer nodes' velocity and acceleration are extrapolated from them, which is the
// velocity the extended functions give at every point. Every force then acts on a motion the
// particles see, and no node has a sliver of mass under a force of a full one.
//
// Constraints: a node with fixed components is outer only if every node of its array fixes the
// same components to the same prescribed velocities (a roller on the grid's edge: the node
// column below); otherwise it keeps its own unknown.
//
// Cost: one pass over the nodes per step to classify them, and work proportional to the
// outer nodes (the boundary) for the ties.
#pragma once

#include <span>
#include <type_traits>
#include <vector>

#include "mpm/core/grid.hpp"
#include "mpm/core/shape_functions.hpp"

namespace pfm {

/// The outer nodes of one step and their ties: outer node outer[k] takes the value
/// sum_{t in [start[k], start[k+1])} weight[t] x value[inner[t]].
struct NodeTies {
  std::vector<int> outer;
  std::vector<int> start{0};
  std::vector<int> inner;
  std::vector<double> weight;
  std::size_t size() const { return outer.size(); }
  bool empty() const { return outer.empty(); }
  void clear();
};

class BasisExtension {
 public:
  BasisExtension() = default;
  /// fraction in (0, 1): the share of a full support's mass below which a node is outer.
  BasisExtension(const Grid& grid, ShapeFunctionKind kind, double fraction);

  /// Classifies the nodes by `mass` (t) against the densest material's density (t/m^3) and
  /// ties the outer ones to inner arrays. fixed: FixMask per node; start, end: the prescribed
  /// velocities of the fixed components at the step's start and end.
  void classify(std::span<const double> mass, double density, std::span<const unsigned> fixed,
                std::span<const Vec2> start, std::span<const Vec2> end);

  /// Ties nodes without mass that have come to carry a force after classify() (a load whose
  /// boundary lies in the support of a node that no particle reaches): appended to ties(),
  /// with the arrays of classify() (degree p: they take no mass from their array). A node that
  /// no array within reach can take stays as it is: its load acts on nothing, as on any node
  /// without mass.
  void tie_massless(std::span<const int> nodes, std::span<const unsigned> fixed,
                    std::span<const Vec2> start, std::span<const Vec2> end);

  /// The ghost penalty's arrays (the implicit step, mpm/implicit/implicit_solver.hpp), after
  /// classify(): each node with material of at least fraction and less than `upto` of a full
  /// support, free in both components, with the array that classify's rule picks among the
  /// nodes holding at least `upto` (as a tie's: outer[k] the node; degree 1 or more, so that
  /// the node's deviation from the extrapolation vanishes on linear fields; a node that no
  /// such array within reach fits is left out).
  NodeTies light_arrays(std::span<const double> mass, double density, double upto,
                        std::span<const unsigned> fixed, std::span<const Vec2> start,
                        std::span<const Vec2> end);

  const NodeTies& ties() const { return ties_; }
  bool enabled() const { return fraction_ > 0.0; }
  /// int N_I dOmega over the grid, m^2.
  double support(int node) const;
  /// The index into ties() of an outer node, -1 for the others.
  int tie_of(int node) const { return tie_of_[static_cast<std::size_t>(node)]; }

  /// values[i] += e_ij values[j] for every tie, then values[j] = 0 (in the ties' order).
  template <class T>
  void gather(std::span<T> values) const {
    for (std::size_t k = 0; k < ties_.outer.size(); ++k) {
      const auto j = static_cast<std::size_t>(ties_.outer[k]);
      const T v = values[j];
      for (int t = ties_.start[k]; t < ties_.start[k + 1]; ++t) {
        values[static_cast<std::size_t>(ties_.inner[static_cast<std::size_t>(t)])] +=
            ties_.weight[static_cast<std::size_t>(t)] * v;
      }
      values[j] = zero<T>();
    }
  }
  /// values[j] = sum_i e_ij values[i] for every outer node j.
  template <class T>
  void extrapolate(std::span<T> values) const {
    for (std::size_t k = 0; k < ties_.outer.size(); ++k) {
      T v = zero<T>();
      for (int t = ties_.start[k]; t < ties_.start[k + 1]; ++t) {
        v += ties_.weight[static_cast<std::size_t>(t)] *
             values[static_cast<std::size_t>(ties_.inner[static_cast<std::size_t>(t)])];
      }
      values[static_cast<std::size_t>(ties_.outer[k])] = v;
    }
  }

 private:
  template <class T>
  static T zero() {
    if constexpr (std::is_arithmetic_v<T>) {
      return T(0);
    } else {
      return T::Zero();
    }
  }
  /// Ties node (jx, jy) to the nearest usable array of degree <= max_degree (and >=
  /// min_degree); false if none.
  bool tie(int jx, int jy, int max_degree, std::span<const unsigned> fixed,
           std::span<const Vec2> start, std::span<const Vec2> end, int min_degree = 0);

  Grid grid_;
  int degree_ = 1;
  double fraction_ = 0.0;
  std::vector<double> support_x_, support_y_;  ///< int N dx per node column / row, m
  std::vector<char> inner_;                    ///< per node, this step
  std::vector<int> tie_of_;                    ///< per node, this step
  std::vector<int> outer_;                     ///< the outer nodes of this step
  std::vector<int> degree_cap_;                ///< per outer node of this step
  std::vector<std::size_t> tied_;              ///< the outer node of each tie
  std::vector<double> gathered_;               ///< the masses after the ties
  NodeTies ties_;
};

}  // namespace pfm

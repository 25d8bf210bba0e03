// What the parts of an implicit load step share (implicit_solver.cpp, implicit_constraints.cpp):
// the affine map of the node components onto the unknowns, the particles' operators, the
// constraint points, and what an iterate gives. Not part of the library's interface.
#pragma once

#include <Eigen/Core>
#include <Eigen/Sparse>
#include <algorithm>
#include <utility>
#include <vector>

#include "mpm/core/grid.hpp"
#include "mpm/core/shape_functions.hpp"
#include "mpm/implicit/implicit_solver.hpp"
#include "mpm/step/energy_ledger.hpp"

namespace pfm {

namespace implicit_detail {

using SparseMatrix = Eigen::SparseMatrix<double>;
using Vector = Eigen::VectorXd;

// A node component's displacement increment as an affine function of the unknowns x:
// offset + sum weight x[dof].
struct Affine {
  double offset = 0.0;
  std::vector<std::pair<int, double>> terms;
  bool used = false;  ///< the component belongs to a node with material (or tied)
  /// Adds w times `other` (a tie's or a mirror's weight on the component it takes).
  void add_scaled(const Affine& other, double w) {
    offset += w * other.offset;
    for (const auto& [dof, v] : other.terms) terms.emplace_back(dof, w * v);
  }
};

using NodeWeight = pfm::NodeWeight;

// Where entry (row, column) of a compressed column-major pattern sits among its stored values
// (the entry must be in the pattern).
inline int place(const SparseMatrix& pattern, int row, int column) {
  const int* outer = pattern.outerIndexPtr();
  const int* inner = pattern.innerIndexPtr();
  return static_cast<int>(std::lower_bound(inner + outer[column], inner + outer[column + 1], row) -
                          inner);
}

// The nodes of a stencil that lie on the grid (a B-spline stencil at the grid's edge starts
// one node outside it, with zero weight there).
inline std::vector<NodeWeight> grid_nodes(const Grid& grid, const ShapeStencil& st) {
  std::vector<NodeWeight> nodes;
  for (int b = 0; b < st.width; ++b) {
    for (int a = 0; a < st.width; ++a) {
      const int i = st.base_i + a, j = st.base_j + b;
      if (i < 0 || j < 0 || i >= grid.n_nodes_x() || j >= grid.n_nodes_y()) continue;
      const auto k = static_cast<std::size_t>(b * st.width + a);
      nodes.push_back({grid.node_index(i, j), st.value[k], st.gradient[k]});
    }
  }
  return nodes;
}

// What a particle's B (or B-bar) operator is made of: per node, the strain of a unit
// displacement of its x and y components, (xx, yy, gamma_xy, zz) each.
struct NodeStrain {
  int node = 0;
  Eigen::Matrix<double, 4, 2> b = Eigen::Matrix<double, 4, 2>::Zero();
};

// A quadrature point of a constraint's part (implicit_constraints.cpp): the gap there is
// g = offset + P sum_I N_I du_I, the force on the body weight (share t - S g), on the nodes as
// N_I(x), with t = P sigma(x) n, sigma(x) = sum_p c_p sigma_p; the Implicit Boundary Method adds
// weight share (d sigma(x) / d du)^T n . g on its fit's particles' unknowns.
struct ConstraintPoint {
  int constraint = 0;
  Vec2 x = Vec2::Zero();  ///< m, where it lies
  double weight = 0.0;    ///< m, the rule's weight
  Vec2 normal = Vec2::Zero();
  Mat2 projector = Mat2::Identity();  ///< P
  Mat2 spring = Mat2::Zero();         ///< S, kPa/m: beta P, or the band's P (n.C.n) P 4 / (3 delta)
  double share = 0.0;                 ///< of the traction: penalty 0, Nitsche 1, the IBM 1/2
  bool symmetric = false;             ///< the IBM's transposed term
  Vec2 offset = Vec2::Zero();         ///< P (u_n(x) - u_bar(t_n+1)), m
  std::vector<std::pair<int, double>> nodes;  ///< (node, N_I(x)) over the nodes with material
  std::vector<std::pair<int, double>> fit;    ///< (particle, c_p), with a share only
  /// The tangent's places: its nodes' unknowns (rows), those and its fit particles' (columns),
  /// both ascending; position[row * cols.size() + col] among the matrix's stored values; with
  /// the transposed term, transposed[k] for the k-th (fit particle, its unknown, row) in order.
  std::vector<int> rows, cols, position, transposed;
};

}  // namespace implicit_detail

// The state of t_n that a load step's iterations share.
struct ImplicitSolver::Prepared {
  using NodeWeight = implicit_detail::NodeWeight;
  double dt = 0.0, t_end = 0.0;                // s
  std::vector<std::vector<NodeWeight>> nodes;  // per particle: the grid nodes it reaches
  // The material under each node, sum_p N_I V_p (m^2): what decides the nodes with material and
  // the ties (as the explicit step's masses do, also for a weightless material).
  std::vector<double> material;
  bool tied = false;  // nodes with little material are tied
  // The boundary detected at t_n (when a load or a constraint needs it).
  bool detected = false;
  DetectedBoundary boundary;
  std::vector<std::vector<implicit_detail::NodeStrain>> strain;  // per particle: B per node
  std::vector<implicit_detail::Affine> map;                      // per node component (2 n + d)
  int n_dofs = 0;
  std::vector<Vec2> external;                // per node, kN/m
  implicit_detail::Vector external_reduced;  // T^T f_ext
  // The ghost penalty (hold_and_tie): the light nodes with their arrays, each one's stiffness
  // (kPa); and (build_pattern) each one's unknowns, ascending, and where their pairs sit.
  NodeTies ghosts;
  std::vector<double> ghost_stiffness;
  std::vector<std::vector<int>> ghost_unknowns;
  std::vector<std::vector<int>> ghost_where;
  std::vector<implicit_detail::ConstraintPoint> points;  // of every constraint
  std::vector<Vec2> constraint_target;                   // u_bar(t_n+1) per constraint, m
  std::vector<char> fitted;                              // per particle: in a point's fit
  // The tangent's sparsity over the unknowns; per particle its unknowns (ascending); per
  // distinct set of unknowns (the particles of one cell share theirs, as a rule) where each
  // pair of them (row-major) sits among the matrix's stored values, and each particle's set.
  implicit_detail::SparseMatrix pattern;
  std::vector<std::vector<int>> unknowns;
  std::vector<std::vector<int>> positions;
  std::vector<int> position_of;
  // Per particle, the unknowns of each component of its strain nodes as (place among its
  // unknowns, weight): component 2 k + d of strain node k holds terms[start[2 k + d]] ..
  // terms[start[2 k + d + 1] - 1]; and the strain node of each of its stencil nodes.
  std::vector<std::vector<std::pair<int, double>>> terms;
  std::vector<std::vector<int>> start;
  std::vector<std::vector<int>> stencil_in_strain;
};

// What an iterate of the displacement increments gives (ImplicitSolver::evaluate).
struct ImplicitSolver::Iterate {
  std::vector<Vec2> increment;  // per node, m
  std::vector<Mat2> gradient;   // per particle: the increment gradient with B-bar's dilatation
  std::vector<Stress> stress;   // per particle, kPa
  std::vector<PointState> state;
  std::vector<Vec2> internal;  // per node, sum_p V_p B^T sigma_p, kN/m
  double internal_norm = 0.0;  // over the node components with material, reactions included
  implicit_detail::SparseMatrix tangent;  // T^T K T on the step's pattern
  // Per fitted particle, d sigma_p / d (its unknowns), 4 x their count (with the tangent).
  std::vector<Eigen::MatrixXd> stress_jacobian;
  std::vector<ConstraintReport> reports;  // per constraint
  // The second and later threads' own tangent values and internal forces (evaluate).
  std::vector<std::vector<double>> thread_values;
  std::vector<std::vector<Vec2>> thread_internal;
};

}  // namespace pfm

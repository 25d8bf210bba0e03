// Surface loads on a detected boundary, integrated into nodal forces on the background grid
// (thesis 6.1, eq. 6.1 and 6.4):  f_I = integral over Gamma of N_I(x) t dGamma, with N_I the
// grid functions of the MPM step (node index grid.node_index(i, j)): the bilinear functions
// (mpm/core/grid.hpp) for linear and uGIMP shape functions (uGIMP's functions at a point of
// zero size), the edge-modified B-splines of degree p for B-spline shape functions
// (mpm/core/shape_functions.hpp). The B-splines are polynomials between their knot lines: the
// cell edges and, for p = 2, the cell midlines too, where the segments are then also cut; their
// Gauss rules take 3 (p - 1) points more than gauss_points (8 and 11 by default), which keeps
// the exact mode exact (degree 6 p + 2 for the normal part on a cubic).
//
// Traction law. t depends on the outward unit normal n (material on the left of the curve,
// n = tangent turned clockwise):  t(n) = normal_scale (.) n + fixed_traction, kPa, where (.)
// is the component-wise product of the thesis (t = q (.) n). Along a Bezier segment
// n |B'(t)| = (B'_y, -B'_x), so the normal part of the integrand, N(B(t)) normal_scale (.)
// (B'_y, -B'_x), is a polynomial: degree <= 8 in t for a cubic inside one bilinear cell.
// The fixed part N(B(t)) fixed_traction |B'(t)| is a polynomial only on straight segments.
//
// Integration modes (QuadratureOptions):
// * kExact (default): each loaded part is split where it crosses cell edges and each piece
//   gets a k-point Gauss rule (k = 5 is exact for the normal part up to cubic segments);
//   the fixed-traction part on a curved piece uses adaptive Gauss-Legendre (~1e-14).
// * kThesis: eq. 6.12 as printed: (1/4) [sum_i w_i |B'(t_i)|] [sum_i w_i N(t_i)^T t(n(t_i))],
//   i.e. a Gauss arc length times a separate Gauss mean of N^T t, over the whole loaded part
//   of a segment (split = false, as the thesis) or per cell piece (split = true). Kept to
//   reproduce the error of figure 6.4.
// * scale_eq_6_15: after integrating one unit (a cell piece when splitting, else the loaded
//   part of a segment), each force
//   component of its nodal forces is scaled so that their sum equals the exact total of that
//   unit (eq. 6.15; exact total = normal_scale (.) (Delta y, -Delta x) + fixed_traction L).
//   A component whose integrated sum is zero is left alone.
//
// Load types (BoundaryLoadSpec):
// * kVerticalPressure (the thesis load): a downward pressure q over the fixed horizontal
//   interval x_range, applied normal-only on the upward-facing parts (n_y > 0):
//   t = (0, -q n_y), i.e. normal_scale = (0, -q). The total vertical force of a loaded part
//   from B(t_a) to B(t_b) is exactly q (x_b - x_a) (eq. 6.13; negative = downward for the
//   counter-clockwise top surface walked right to left).
// * kFollowerPressure: t = -p n on the boundary (normal_scale = (-p, -p)); p > 0 pushes on the
//   material.
// * kTraction: a fixed traction vector per current length, t = traction (kPa).
// Each type may be restricted to x_range and, by `faces`, to the upward-facing parts. In every
// integration mode a segment is first cut at x = x_min, x = x_max (roots of the cubic x(t))
// and, for upward faces, where B'_x(t) = 0 (n_y changes sign); the loaded parts are then
// integrated as described above.
// The solver builds the curves with make_composite_beziers(contours, spec.curve) and passes
// its time function's value as load_factor (t = load_factor x the full load of the spec).
//
// Lost load (thesis 6.2): nodal forces on nodes without mass act on nothing, and on nodes of
// tiny mass they fling the node. A node is "lost" when its mass is <= min_node_mass (by
// default 0.01 of a full cell's mass). The result reports the lost forces' sum and moment.
// With redistribute_lost_load (the default), each lost nodal force f_L at x_L is moved to the
// set S of nearest nodes of more mass (all such nodes within the smallest Chebyshev node
// distance r >= 1 from the lost node that holds at least two of them) as the
// least-squares-smallest set of forces with the same resultant and the same moment:
//   g_J = f_L / |S| + mu (-r_J,y, r_J,x),  r_J = x_J - c,  c = centroid of S,
//   mu = ((x_L - c) x f_L) / sum_J |r_J|^2,
// which conserves the total force and the total moment (about any point) exactly.
#pragma once

#include <algorithm>
#include <array>
#include <optional>
#include <span>
#include <vector>

#include "mpm/boundary/bezier.hpp"
#include "mpm/boundary/gauss_quadrature.hpp"
#include "mpm/core/grid.hpp"

namespace pfm::boundary {

enum class IntegrationMode { kExact, kThesis };
enum class BoundaryLoadType { kVerticalPressure, kFollowerPressure, kTraction };
/// kFixed: x_range stays where it is in space (thesis 6.2). kMaterial: the solver moves
/// x_range with the material (this library uses the x_range it is given).
enum class LoadInterval { kFixed, kMaterial };
/// kAll: every part; kUpward: parts with n_y > 0 (thesis 6.2); kTop: upward parts seen from
/// above, i.e. with no boundary above them (the upper envelope: wiggles of a detected vertical
/// face, overhangs and the floors of closed holes carry no load).
enum class LoadedFaces { kAll, kUpward, kTop };

/// The parts of the boundary whose outward unit normal n has n . direction >= min_cosine (a
/// segment belongs when its normal at its middle does: exact for linear curves).
struct NormalWindow {
  Vec2 direction = Vec2(0.0, 1.0);  ///< unit vector
  double min_cosine = 1.0;          ///< cos of the largest angle between n and direction
};

/// t(n) = normal_scale (.) n + fixed_traction, kPa (see the header comment).
struct TractionLaw {
  Vec2 normal_scale = Vec2::Zero();
  Vec2 fixed_traction = Vec2::Zero();
};

struct QuadratureOptions {
  IntegrationMode mode = IntegrationMode::kExact;
  int gauss_points = 5;             ///< k, 1..kMaxGaussPoints
  bool split_at_cell_edges = true;  ///< cut segments at cell edges before the quadrature
  bool scale_eq_6_15 = false;
};

struct BoundaryLoadSpec {
  BoundaryLoadType type = BoundaryLoadType::kVerticalPressure;
  double pressure = 0.0;         ///< kPa at full load (vertical / follower pressure)
  Vec2 traction = Vec2::Zero();  ///< kPa at full load (kTraction)
  std::optional<Vec2> x_range;   ///< m, (x_min, x_max); none = the whole boundary
  LoadedFaces faces = LoadedFaces::kTop;
  CurveKind curve = CurveKind::kLinear;  ///< how the solver builds the curves from contours
  QuadratureOptions quadrature;
  /// Move the force on nodes of too little mass (min_node_mass) to the nearest nodes with
  /// enough, conserving force and moment (the header comment; the solver moves those nodes'
  /// internal forces too, mpm/solver/boundary_coupling.hpp); off: such forces stay where they
  /// are (the thesis: forces on nodes without mass act on nothing).
  bool redistribute_lost_load = true;
  /// The part of the mass of a full cell (the densest material's rho h^2) below which a node
  /// is too light to carry a load: a force f on a node of mass m accelerates it by f / m, and a
  /// node that a body barely reaches would be flung, and the load's work on it would be lost in
  /// the next projection (the energy ledger's transfer_to_grid, mpm/step/energy_ledger.hpp).
  /// The default catches the nodes that a surface barely reaches; a larger fraction moves
  /// loads off nodes that carry them well, away from the boundary, and the stress next to the
  /// boundary suffers (tests/cpp/solver/test_boundary_coupling.cpp, the free square).
  double min_node_mass_fraction = 0.01;
  /// t: the threshold itself, min_node_mass_fraction x the mass of a full cell (set by the
  /// solver; 0 = only nodes without mass are lost).
  double min_node_mass = 0.0;
  LoadInterval interval = LoadInterval::kFixed;
  /// Only the parts whose outward normal lies in this window (none: any normal).
  std::optional<NormalWindow> normal_window;

  /// The traction law at load factor lambda (t = lambda x the full load).
  TractionLaw traction_law(double load_factor) const;
};

/// A point's share in a part restricted to x_range (loads' and constraints' x_range): 1 over
/// it, fading to 0 over the last `fade_width` inside its ends (smoothstep of the distance from
/// the nearer end); 1 without an x_range. The constraints (mpm/solver/boundary_constraint.hpp,
/// mpm/implicit/implicit_constraints.cpp) fade their particles over half a cell.
inline double part_share(double x, const std::optional<Vec2>& x_range, double fade_width) {
  if (!x_range) return 1.0;
  const double inside = std::min(x - x_range->x(), x_range->y() - x) / fade_width;
  return inside <= 0.0 ? 0.0 : inside >= 1.0 ? 1.0 : inside * inside * (3.0 - 2.0 * inside);
}

/// A point of a rule along the loaded parts of the curves: position, outward unit normal, and
/// weight (its share of the arc length, m).
struct CurvePoint {
  Vec2 x = Vec2::Zero();
  Vec2 normal = Vec2::Zero();
  double weight = 0.0;
};

struct NodalForce {
  int node = 0;  ///< grid.node_index(i, j)
  Vec2 force = Vec2::Zero();
};

struct BoundaryLoadResult {
  Vec2 total_force = Vec2::Zero();  ///< kN/m: sum of this load's nodal forces (on the grid)
  /// kN/m: the exact resultant of the load on the loaded parts of the curves (eq. 6.13 per
  /// part: normal_scale (.) (Delta y, -Delta x) + fixed_traction x length): the target that
  /// total_force + off_grid_force must equal.
  Vec2 exact_force = Vec2::Zero();
  double total_moment = 0.0;  ///< kN m/m about (0, 0): sum x_I x f_I (counter-clockwise +)
  Vec2 lost_force =
      Vec2::Zero();          ///< kN/m: part on nodes of mass <= min_node_mass (before moving it)
  double lost_moment = 0.0;  ///< kN m/m about (0, 0) of lost_force
  Vec2 off_grid_force = Vec2::Zero();  ///< kN/m: part on nodes outside the grid (dropped)
  int n_loaded_nodes = 0;              ///< nodes receiving a nonzero force (after redistribution)
  int n_lost_nodes = 0;         ///< nodes of mass <= min_node_mass that received a nonzero force
  std::vector<int> lost_nodes;  ///< those nodes, ascending
  bool redistributed = false;
  std::vector<NodalForce> nodal_forces;  ///< filled when asked for (plots), sorted by node
};

/// Points of the Gauss rule that the integrator uses for `gauss_points` (the option, counted
/// for bilinear functions) with grid functions of degree shape_degree: 3 (p - 1) more, which
/// keeps the exact mode exact (the header comment). Must be <= kMaxGaussPoints.
constexpr int gauss_points_for_degree(int gauss_points, int shape_degree) {
  return gauss_points + 3 * (shape_degree - 1);
}

/// Integrates loads along composite curves into nodal forces; keeps scratch arrays so that
/// repeated calls (one per time step) do not allocate once warmed up. Not thread-safe.
class BoundaryLoadIntegrator {
 public:
  /// shape_degree: 1 for the bilinear functions, 2 or 3 for the B-splines of that degree.
  explicit BoundaryLoadIntegrator(const Grid& grid, int shape_degree = 1);

  /// Adds the load of `spec` at `load_factor` (the solver's time function, 1 = full load)
  /// acting on `curves` to node_force_out (size grid.n_nodes(), kN/m). node_mass (t, size
  /// grid.n_nodes() or empty = every node has mass) decides which nodes lose their load: those
  /// of mass <= spec.min_node_mass.
  BoundaryLoadResult integrate(const std::vector<CompositeBezier>& curves,
                               const BoundaryLoadSpec& spec, double load_factor,
                               std::span<const double> node_mass, std::span<Vec2> node_force_out,
                               bool keep_nodal_forces = false);

  /// The points of the exact mode's rule along the parts of `curves` that `spec` selects
  /// (x_range, faces, normal_window), each segment cut where the grid functions change
  /// polynomial (the cell edges, and midlines for p = 2) and gauss_points_for_degree points
  /// per piece: sum w f(x) integrates f along the parts exactly for f a polynomial of that
  /// degree on each piece of a straight segment. Replaces `points`.
  void quadrature_points(const std::vector<CompositeBezier>& curves, const BoundaryLoadSpec& spec,
                         std::vector<CurvePoint>& points);

  /// Lower level: adds the load of one segment over its parameter range [t0, t1] (no
  /// filtering) to the internal accumulator; then call take_forces.
  void add_segment(const BezierSegment& segment, double t0, double t1, const TractionLaw& law,
                   const QuadratureOptions& options);
  /// Moves the accumulated forces into `out` (size n_nodes, overwritten) and clears them.
  void take_forces(std::span<Vec2> out);

  const Grid& grid() const { return grid_; }
  /// The k-point Gauss-Legendre rule, 1 <= k <= kMaxGaussPoints.
  const GaussRule& gauss_rule(int k) const;

 private:
  void add_unit(const BezierSegment& segment, double t0, double t1, const TractionLaw& law,
                const QuadratureOptions& options, const GaussRule& rule);
  void integrate_piece_exact(const BezierSegment& segment, double t0, double t1, int cell_i,
                             int cell_j, const TractionLaw& law, const GaussRule& rule);
  void add_point_force(int cell_i, int cell_j, const Vec2& x, const Vec2& force);
  void add_node_force(int i, int j, const Vec2& force);
  void flush_unit(const Vec2& exact_total, bool scale);

  Grid grid_;
  int degree_ = 1;  ///< of the grid functions (1: bilinear; 2, 3: B-splines)
  Grid knot_grid_;  ///< the lines where the grid functions change polynomial (segments cut there)
  std::array<GaussRule, kMaxGaussPoints + 1> rules_;  // rules_[k]: the k-point rule
  std::vector<Vec2> accumulated_;                     // per node
  std::vector<char> touched_flag_;                    // per node
  std::vector<int> touched_;                          // nodes with contributions
  std::vector<NodalForce> unit_;       // contributions of the current unit (eq. 6.15 scaling)
  std::vector<double> breaks_;         // scratch: cell-edge parameters
  std::vector<double> filter_breaks_;  // scratch: x-range and face cuts
  // kTop: the x of every vertex and turning point of the curves (sorted), the curves' segments
  // binned by x, and scratch for the shadow cuts.
  /// A loaded part: the parameter interval [t0, t1] of segment `segment` of curve `curve`.
  struct CurvePart {
    std::size_t curve = 0, segment = 0;
    double t0 = 0.0, t1 = 0.0;
  };
  /// The loaded parts that spec selects (x_range, faces, normal_window), in curve order.
  void select_parts(const std::vector<CompositeBezier>& curves, const BoundaryLoadSpec& spec,
                    std::vector<CurvePart>& parts);
  std::vector<CurvePart> parts_;  // scratch: select_parts
  void index_shadows(const std::vector<CompositeBezier>& curves);
  bool shadowed(const std::vector<CompositeBezier>& curves, const BezierSegment& segment,
                double t) const;
  std::vector<double> turning_x_;
  std::vector<std::vector<std::pair<int, int>>> shadow_bins_;
  double shadow_x0_ = 0.0, shadow_bin_width_ = 1.0;
  std::vector<double> shadow_cuts_;
  mutable std::vector<double> ray_roots_;
  Vec2 off_grid_ = Vec2::Zero();
};

/// Convenience wrapper: one integrator per call (allocates).
BoundaryLoadResult integrate_load(const Grid& grid, const std::vector<CompositeBezier>& curves,
                                  const BoundaryLoadSpec& spec, double load_factor,
                                  std::span<const double> node_mass, std::span<Vec2> node_force_out,
                                  bool keep_nodal_forces = false);

/// Nodal forces (size grid.n_nodes()) of one segment under `law` with `options`.
std::vector<Vec2> segment_nodal_forces(const Grid& grid, const BezierSegment& segment,
                                       const TractionLaw& law, const QuadratureOptions& options);

/// The exact resultant of `law` on the segment: normal_scale (.) (Delta y, -Delta x) +
/// fixed_traction x length (eq. 6.13 for the vertical pressure).
Vec2 exact_total_force(const BezierSegment& segment, const TractionLaw& law);

/// Moves the forces on `nodes` that have mass <= min_node_mass to the nearest nodes of more mass
/// (scheme in the header comment), in place. `forces` and `node_mass` have size grid.n_nodes().
/// Returns the number of those nodes whose force could be moved (all, unless fewer than two
/// nodes have enough mass; with exactly one such node the force goes there and the moment is
/// not conserved).
int redistribute_lost_forces(const Grid& grid, std::span<const double> node_mass,
                             std::span<Vec2> forces, std::span<const int> nodes,
                             double min_node_mass);

/// High-order reference for tests and the quadrature study: the nodal forces of one segment
/// by adaptive Gauss-Legendre over the whole segment (no cell splitting), with the hat
/// functions N_I(x) = max(0, 1 - |x - x_I| / h) max(0, 1 - |y - y_I| / h) evaluated for every
/// node independently of the stencil code. Local tolerance relative_tolerance x (integrand
/// scale) per unit parameter length.
std::vector<Vec2> reference_nodal_forces(const Grid& grid, const BezierSegment& segment,
                                         const TractionLaw& law, double relative_tolerance = 1e-14);

}  // namespace pfm::boundary

// What the UL-FEM's mesh takes from a case at its nodes and boundary edges: the supports and
// the loads. Both the explicit UL-FEM (ulfem_solver.hpp) and the implicit one
// (ulfem_implicit.hpp) use them.
//
// Constraints: "left" / "right" / "bottom" / "top" act on the mesh nodes whose reference
// position lies on the grid edge line x = x0, x = x0 + nx h, y = y0, y = y0 + ny h (within
// 1e-9 h): the grid nodes the MPM constrains there are exactly these nodes where the body
// touches the grid edge, and a body that does not touch a grid edge gets no constraint from it,
// as in the MPM. A node set constrains the mesh nodes in its closed box (reference position).
//
// Loads: every load of the case acts on the exact boundary edges of the current mesh (the FE
// boundary is exact, so there is nothing to detect), with the traction law of the MPM's
// surface loads (mpm/boundary/surface_load.hpp): t(n) = normal_scale (.) n + fixed_traction,
//   vertical_pressure  normal_scale = (0, -q): t = (0, -q n_y), vertical; resultant
//                      q x (loaded length in x) on upward faces;
//   follower_pressure  normal_scale = (-p, -p): t = -p n (p > 0 pushes on the material);
//   traction           fixed_traction = the given vector, per current length.
// apply_on "grid_top_nodes" (vertical_pressure only) is treated as the detected-boundary
// vertical pressure over its x_range with faces "top". For "detected_boundary" loads the
// entry's x_range (optional except for vertical_pressure), faces and interval are honoured:
//   faces "all"      every boundary edge;
//         "upward"   edges whose current outward normal has n_y > 0;
//         "top"      upward edges, only the parts with no boundary above them (each loaded part
//                    is cut at the x of every boundary node; a piece is shadowed when the
//                    vertical through its middle crosses another boundary edge higher up);
//   interval "fixed"     x_range is in space (on the current x);
//            "material"  x_range on the reference x of the load phase (the positions after the
//                        initial stress), so the interval moves with the material.
// Its curve and quadrature keys (curve,
// integration, gauss_points, split_at_cell_edges, scale_eq_6_15, redistribute_lost_load) only
// concern the MPM's Bezier boundary and grid quadrature and do not apply: the edges are straight
// and the integrals below are exact. Per edge A -> B (material on the left, d = B - A, outward
// n = (d_y, -d_x) / L), t L = normal_scale (.) (d_y, -d_x) + fixed_traction L is constant along
// the edge, so with the loaded part s in [s0, s1] (from the x-range) the consistent nodal forces
// are exact:  f_A = t L int (1 - s) ds,  f_B = t L int s ds.  On a flat top this is the MPM's
// grid_top_nodes hat integral. Nothing is lost (every boundary node has mass): the diagnostics
// report target = applied (exact resultant), lost = off-grid = 0.
#pragma once

#include <vector>

#include "fem_reference/ulfem/quad_mesh.hpp"
#include "mpm/boundary/surface_load.hpp"
#include "mpm/step/case.hpp"
#include "mpm/step/energy_ledger.hpp"

namespace pfm::ulfem {

/// Whether boundary condition `bc` holds the mesh node whose reference position is `x` (see
/// the header comment).
bool mesh_node_held(const Case& c, const BoundaryCondition& bc, const Vec2& x);

/// A boundary edge that can carry a load: nodes in element order (material on the left).
struct LoadedEdge {
  int from = 0;
  int to = 0;
};

/// One case load as applied on the mesh edges (see the header comment).
struct EdgeLoad {
  std::size_t case_index = 0;
  Vec2 normal_scale = Vec2::Zero();    ///< kPa at full load
  Vec2 fixed_traction = Vec2::Zero();  ///< kPa at full load
  bool has_range = false;
  double x0 = 0.0, x1 = 0.0;  ///< m
  boundary::LoadedFaces faces = boundary::LoadedFaces::kTop;
  bool material_interval = false;  ///< x-range on the reference (load-phase start) x
  TimeFunction time_function;
};

/// Summed over the loads at the last step that applied them (kN/m), as the MPM's
/// SurfaceLoadDiagnostics (mpm/solver/boundary_coupling.hpp).
struct EdgeLoadDiagnostics {
  Vec2 target = Vec2::Zero();    ///< exact resultant of the loaded edge parts
  Vec2 applied = Vec2::Zero();   ///< sum of the nodal forces (= target to round-off)
  Vec2 lost = Vec2::Zero();      ///< always 0: every mesh node has mass
  double lost_moment = 0.0;      ///< always 0
  Vec2 off_grid = Vec2::Zero();  ///< always 0
  int loaded_nodes = 0;          ///< nodes receiving a non-zero load force
  int lost_nodes = 0;            ///< always 0
};

/// The case's loads as edge loads; InputError (naming /loads/k) for a load the UL-FEM cannot
/// apply.
std::vector<EdgeLoad> edge_loads(const Case& c);

/// The case's loads on a mesh's boundary edges (see the header comment).
class EdgeLoading {
 public:
  EdgeLoading() = default;
  /// InputError (naming /loads/k) for a load the UL-FEM cannot apply.
  EdgeLoading(const Case& c, const QuadMesh& mesh);

  /// The loads' nodal forces at time t (each load's time function) on the edges through
  /// `position`, the material intervals measured on `reference`, added to `force` (one per
  /// node); each load's forces also into `recorder` when given; into d the exact resultant of
  /// the loaded parts (target), the sum of the forces (applied) and the nodes loaded. False,
  /// with nothing added and d untouched, when no load acts at t.
  bool add(double t, const std::vector<Vec2>& position, const std::vector<Vec2>& reference,
           std::vector<Vec2>& force, EdgeLoadDiagnostics& d, LoadWorkRecorder* recorder);

  /// Every boundary edge of the mesh (the candidates for loads), in boundary_edges() order.
  const std::vector<LoadedEdge>& edges() const { return edges_; }
  const std::vector<EdgeLoad>& loads() const { return loads_; }

 private:
  /// The forces of add() into `force`, the target into d.target; false when no load acts.
  bool integrate(double t, const std::vector<Vec2>& position, const std::vector<Vec2>& reference,
                 std::vector<Vec2>& force, EdgeLoadDiagnostics& d, LoadWorkRecorder* recorder);
  /// Whether another boundary edge crosses the vertical through x above y.
  bool shadowed(const std::vector<Vec2>& position, double x, double y) const;

  std::vector<LoadedEdge> edges_;
  std::vector<EdgeLoad> loads_;
  double tolerance_ = 0.0;          ///< 1e-9 h, m
  std::vector<double> boundary_x_;  ///< sorted x of the boundary nodes, scratch (faces "top")
  std::vector<double> cuts_;        ///< scratch
  std::vector<Vec2> forces_;        ///< per node, scratch of add(), zero between calls
};

}  // namespace pfm::ulfem

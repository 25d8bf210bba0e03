// The implicit UL-FEM: the implicit quasi-static solver of mpm/implicit (its load steps, its
// assembly, its Newton iteration, its strength reduction) on the UL-FEM's Q4 mesh, which moves
// with the material and is never reset. An implicit MPM answer so has a large-deformation
// reference from the same assembly on another discretisation.
//
// The mesh (QuadMesh, mesh_case) gives the step:
//   its points     the 2 x 2 Gauss points of every element (material_points), the explicit
//                  UL-FEM's;
//   its functions  the Q4 functions at each point's fixed natural coordinates, their gradients
//                  J^-T dN/dxi on the current node positions;
//   B-bar          the mean dilatation over an element's four points;
//   its supports   the nodes mesh_node_held selects, as the explicit UL-FEM's;
//   its loads      the case's loads on the exact boundary edges of the mesh at the step's start
//                  (EdgeLoading, dead within the step), at the load factor of the step's end,
//                  a material interval measured on the reference mesh (the initial one, or
//                  the one the gravity-loading initial stress reached);
//   its motion     the nodes by their converged increments; the points' positions interpolated
//                  and their volumes det J on the moved mesh (an element whose det J reaches 0
//                  at a point stops the run, SimulationError naming it).
// Constraints on a detected boundary do not apply (InputError naming /constraints): a mesh
// prescribes motion on its nodes, by a node set with a velocity.
#pragma once

#include <vector>

#include "fem_reference/ulfem/edge_loads.hpp"
#include "fem_reference/ulfem/quad_mesh.hpp"
#include "mpm/implicit/implicit_solver.hpp"
#include "mpm/step/run_support.hpp"

namespace pfm::ulfem {

class ImplicitQuadMesh final : public ImplicitMesh {
 public:
  /// InputError (naming /loads/k) for a load the mesh cannot apply.
  ImplicitQuadMesh(const Case& c, QuadMesh mesh);

  Particles material_points() const override;
  std::size_t n_nodes() const override { return mesh_.n_nodes(); }
  std::size_t n_elements() const override { return mesh_.n_elements(); }
  bool holds(const BoundaryCondition& bc, std::size_t n) const override;
  std::vector<NodeWeight> functions(std::size_t p) const override;
  std::size_t element_of(std::size_t p) const override { return p / 4; }
  void add_loads(double t, std::vector<Vec2>& force) override;
  void move(const std::vector<Vec2>& increment, Particles& points) override;
  void reset_reference() override { reference_ = position_; }

  const QuadMesh& mesh() const { return mesh_; }
  /// Current node positions, m.
  const std::vector<Vec2>& node_position() const { return position_; }
  /// Node displacements from the reference (the initial mesh, or the one the gravity-loading
  /// initial stress reached), m.
  std::vector<Vec2> node_displacement() const;
  /// The nodes' increments of the last converged step, m.
  const std::vector<Vec2>& last_increment() const { return last_increment_; }

 private:
  const Case& case_;
  QuadMesh mesh_;
  std::vector<Vec2> position_;
  std::vector<Vec2> reference_;
  std::vector<Vec2> last_increment_;
  EdgeLoading loading_;
};

/// Runs a case with solver.type "implicit" on the UL-FEM's mesh (mesh_case): the outputs of
/// run_implicit_case (mpm/implicit/implicit_run.hpp), with summary.solver "ulfem_implicit" and
/// the mesh's generator and size, plus at t = 0 and at each output the explicit UL-FEM's mesh
/// files (mesh.h5/.xdmf, boundary_<step>.csv, listed in run.json's "outputs"; the nodes'
/// velocity is their last increment over the step's pseudo-time).
int run_ulfem_implicit_case(const Case& c, const RunOptions& options);

}  // namespace pfm::ulfem

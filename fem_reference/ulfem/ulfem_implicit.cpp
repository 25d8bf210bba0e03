#include "fem_reference/ulfem/ulfem_implicit.hpp"

#include <cstdio>
#include <memory>
#include <string>

#include "fem_reference/ulfem/ulfem_run.hpp"
#include "mpm/implicit/implicit_run.hpp"

namespace pfm::ulfem {

ImplicitQuadMesh::ImplicitQuadMesh(const Case& c, QuadMesh mesh)
    : case_(c),
      mesh_(std::move(mesh)),
      position_(mesh_.node_position),
      reference_(mesh_.node_position),
      last_increment_(mesh_.n_nodes(), Vec2::Zero()),
      loading_(c, mesh_) {}

Particles ImplicitQuadMesh::material_points() const {
  return ulfem::material_points(case_, mesh_, position_);
}

bool ImplicitQuadMesh::holds(const BoundaryCondition& bc, std::size_t n) const {
  return mesh_node_held(case_, bc, mesh_.node_position[n]);
}

std::vector<NodeWeight> ImplicitQuadMesh::functions(std::size_t p) const {
  const std::size_t e = p / 4;
  const GaussSlot& slot = gauss_slots()[p % 4];
  const Eigen::Matrix<double, 4, 2> x = element_positions(mesh_, position_, e);
  // grad N_a = J^-T dN_a/dxi, J = d x / d xi (move() keeps det J > 0).
  const Eigen::Matrix<double, 4, 2> gradient =
      slot.natural_gradient * (x.transpose() * slot.natural_gradient).inverse();
  std::vector<NodeWeight> nodes(4);
  for (std::size_t a = 0; a < 4; ++a) {
    const auto row = static_cast<Eigen::Index>(a);
    nodes[a] = {mesh_.element_nodes[e][a], slot.value[row], gradient.row(row).transpose()};
  }
  return nodes;
}

void ImplicitQuadMesh::add_loads(double t, std::vector<Vec2>& force) {
  EdgeLoadDiagnostics unused;  // the implicit run writes no load diagnostics
  loading_.add(t, position_, reference_, force, unused, nullptr);
}

void ImplicitQuadMesh::move(const std::vector<Vec2>& increment, Particles& points) {
  for (std::size_t n = 0; n < position_.size(); ++n) position_[n] += increment[n];
  last_increment_ = increment;
  const std::array<GaussSlot, 4>& slots = gauss_slots();
  for (std::size_t e = 0; e < mesh_.n_elements(); ++e) {
    const Eigen::Matrix<double, 4, 2> x = element_positions(mesh_, position_, e);
    for (std::size_t k = 0; k < 4; ++k) {
      const std::size_t p = 4 * e + k;
      points.position[p] = point_position(mesh_, position_, e, k);
      points.volume[p] = (x.transpose() * slots[k].natural_gradient).determinant();
      if (points.volume[p] > 0.0) continue;
      const Vec2 centre = 0.25 * x.colwise().sum().transpose();
      throw SimulationError("element inverted: " + describe_element(mesh_, e, centre) +
                            ", det J = " + std::to_string(points.volume[p]) +
                            " m^2 <= 0 at its Gauss point " + std::to_string(k));
    }
  }
}

std::vector<Vec2> ImplicitQuadMesh::node_displacement() const {
  std::vector<Vec2> u(position_.size());
  for (std::size_t n = 0; n < u.size(); ++n) u[n] = position_[n] - reference_[n];
  return u;
}

int run_ulfem_implicit_case(const Case& c, const RunOptions& options) {
  auto owned = std::make_unique<ImplicitQuadMesh>(c, mesh_case(c));
  ImplicitQuadMesh* mesh = owned.get();  // the solver owns it for the run
  std::unique_ptr<MeshSeriesWriter> writer;
  ImplicitMeshRun on_mesh;
  on_mesh.mesh = std::move(owned);
  on_mesh.solver = "ulfem_implicit";
  on_mesh.output = [&](OutputFolder& folder, const ImplicitSolver& solver, long step) {
    if (!writer)
      writer = std::make_unique<MeshSeriesWriter>(folder, mesh->mesh(), c.output.compress);
    // The last converged step's size (after a collapse the log ends with failed attempts).
    double dt = 0.0;
    for (auto e = solver.log().rbegin(); e != solver.log().rend() && dt == 0.0; ++e)
      if (e->converged) dt = e->dt;
    std::vector<Vec2> velocity(mesh->n_nodes(), Vec2::Zero());
    for (std::size_t n = 0; dt > 0.0 && n < velocity.size(); ++n)
      velocity[n] = mesh->last_increment()[n] / dt;
    writer->write(solver.time(), step, mesh->node_position(), mesh->node_displacement(), velocity,
                  solver.particles());
    char name[48];
    std::snprintf(name, sizeof name, "boundary_%08ld.csv", step);
    write_file_atomically(folder.file(name), boundary_csv(mesh->mesh(), mesh->node_position()));
    return nlohmann::json{{"step", step}, {"time", solver.time()}, {"boundary", name}};
  };
  on_mesh.close = [&] { writer.reset(); };
  on_mesh.summarise = [&](nlohmann::json& summary) {
    summary["mesh"] = {{"generator", mesh->mesh().generator},
                       {"n_elements", mesh->mesh().n_elements()},
                       {"n_nodes", mesh->mesh().n_nodes()}};
  };
  return run_implicit_case(c, options, std::move(on_mesh));
}

}  // namespace pfm::ulfem

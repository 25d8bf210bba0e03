// The UL-FEM driver: `pfm-mpm run CASE.json --solver ulfem --out DIR`.
//
// Output directory, as pfm::run_case (mpm/solver/run.hpp) plus the exact boundary and the mesh:
//   run.json                provenance + summary (solver "ulfem", mesh generator and size) +
//                           "outputs": [{"step", "time", "boundary"}] per output step
//   particles.h5/.xdmf      material points (the Gauss points) per output step
//   timeseries.csv          time, kinetic energy, works, momentum (the MPM's columns); with
//                           loads also load_target_fx/fy, load_applied_fx/fy, load_lost_fx/fy,
//                           load_off_grid_fx/fy (kN/m), loaded_nodes, lost_nodes, summed over
//                           the loads (lost and off-grid are 0: the mesh boundary is exact)
//   final_particles.csv     the final material point state
//   boundary_<step>.csv     per output step (step with 8 digits): the exact outer boundary of
//                           the deformed mesh, columns loop,x,y; counter-clockwise (material on
//                           the left), no repeated closing point, first point the lowest (then
//                           leftmost); one loop per boundary component
//   mesh.h5/.xdmf           the mesh per output step: quads, current geometry, nodal
//                           displacement and velocity, and per element the mean stress sxx,
//                           syy, sxy, szz (kPa) and equivalent plastic strain eps_p over its
//                           four Gauss points, weighted by their volumes (the stress integral
//                           of the element over its area)
#pragma once

#include <string>
#include <vector>

#include "fem_reference/ulfem/quad_mesh.hpp"
#include "mpm/step/particles.hpp"
#include "mpm/step/run_support.hpp"

namespace pfm::ulfem {

/// Run a validated case with the UL-FEM (a case with solver.type "implicit" with the implicit
/// UL-FEM, run_ulfem_implicit_case in ulfem_implicit.hpp). Returns kExitOk, or kExitSimulationError
/// after writing run.json with status "failed" (outputs so far kept). InputError propagates before
/// anything is created.
int run_ulfem_case(const Case& c, const RunOptions& options);

/// boundary CSV text ("loop,x,y") of the mesh at the given node positions (boundary_loops).
std::string boundary_csv(const QuadMesh& mesh, const std::vector<Vec2>& positions);

/// Mesh time series: mesh.h5 (topology once, one group per step) + mesh.xdmf (temporal
/// collection of Quadrilateral grids; ParaView and meshio open it).
class MeshSeriesWriter {
 public:
  MeshSeriesWriter(OutputFolder& folder, const QuadMesh& mesh, bool compress);
  ~MeshSeriesWriter();
  MeshSeriesWriter(const MeshSeriesWriter&) = delete;
  MeshSeriesWriter& operator=(const MeshSeriesWriter&) = delete;

  /// positions, displacement, velocity: one per node (m, m, m/s); points: the Gauss points,
  /// 4 e + k for point k of element e (the element means).
  void write(double time, long step, const std::vector<Vec2>& position,
             const std::vector<Vec2>& displacement, const std::vector<Vec2>& velocity,
             const Particles& points);

 private:
  void write_xdmf() const;
  std::string h5_path_, xdmf_path_;
  bool compress_ = false;
  long file_ = -1;  // hid_t
  std::size_t n_nodes_ = 0, n_elements_ = 0;
  std::vector<double> times_;
  std::vector<std::string> groups_;
};

}  // namespace pfm::ulfem

namespace pfm {
using ulfem::run_ulfem_case;  // pfm::run_ulfem_case, beside pfm::run_case
}  // namespace pfm

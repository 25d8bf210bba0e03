// The `pfm-mpm run` driver: validated case in, output directory out.
//
// Output directory (created only once the case is valid):
//   run.json              provenance (git revision, build type, command, case copy) + summary
//   particles.h5/.xdmf    particle time series (ParaView: open particles.xdmf)
//   particles.pvd, particles_<step>.vtu, boundary.pvd, boundary_<step>.vtu   with output.vtk:
//                         the particles and the detected boundary as VTK XML
//   timeseries.csv        time, kinetic energy, works, momentum; with loads on the detected
//                         boundary also their target, applied, lost and off-grid forces (kN/m)
//   final_particles.csv   the final particle state
//   boundary_<step>.csv   with a detection block, per output step (step with 8 digits): the
//                         detected boundary, columns loop,x,y (mpm/detect/contour.hpp order)
//   boundary.h5/.xdmf     the same boundaries as polylines (ParaView: open beside particles)
//   checkpoint.h5         the complete state at the latest checkpoint (for --restart)
//   particles.h5.checkpoint, boundary.h5.checkpoint   the HDF5 series as they were at the
//                         latest checkpoint, which a restart rebuilds them from (a run killed
//                         while it appends an output step can leave the series unreadable)
//   .pfm-mpm-files        the files this program wrote here (the only ones it ever removes)
//   .pfm-mpm.lock         held while a run or restart uses the folder (mpm/core/output_folder.hpp)
#pragma once

#include "mpm/step/case.hpp"
#include "mpm/step/run_support.hpp"

namespace pfm {

/// Run a validated case. Returns kExitOk, kExitSimulationError after writing run.json with
/// status "failed" and keeping the outputs written so far, or kExitIoError after a write fault
/// (fail_on_write_fault). InputError propagates (nothing is created when the case or options
/// are invalid).
int run_case(const Case& c, const RunOptions& options);

}  // namespace pfm

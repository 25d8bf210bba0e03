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

#include <memory>

#include "mpm/step/case.hpp"
#include "mpm/step/run_support.hpp"

namespace pfm {

class MpmSolver;
class BoundaryCoupling;

/// A run of a validated case, a step at a time (the Python module's Simulation): the output
/// folder, the solver, the detected boundary's coupling and the outputs' writers of
/// `pfm-mpm run`. run_case() is begin(), step() while stepping(), end(); a driver that calls
/// end() earlier gets the files of a run whose end time is now (mpm/step/run_driver.hpp). The
/// constructor creates the output folder once the case and options are valid (InputError
/// otherwise, nothing created); --restart's state is read there.
class MpmRun {
 public:
  MpmRun(const Case& c, const RunOptions& options);
  ~MpmRun();
  MpmRun(const MpmRun&) = delete;
  MpmRun& operator=(const MpmRun&) = delete;

  /// Writes run.json, the initial stress and the first output (none for a restart).
  void begin();
  /// Whether the run has begun and has neither stopped (a simulation error) nor ended.
  bool running() const;
  /// running() and the case's end time not reached.
  bool stepping() const;
  /// One step with its time-series row, output and checkpoint when due (running() must hold).
  void step();
  /// Ends the run: the current step's row and output, final_particles.csv, run.json; closes
  /// the output files and releases the folder's lock. Returns the exit status of run_case();
  /// again the same on later calls.
  int end();

  /// The simulation error that stopped the run, or empty.
  const std::string& stop_message() const;
  /// The steps to the case's end time.
  long n_steps() const;
  MpmSolver& solver();
  BoundaryCoupling& coupling();
  const Case& case_spec() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
};

/// Run a validated case. Returns kExitOk, kExitSimulationError after writing run.json with
/// status "failed" and keeping the outputs written so far, or kExitIoError after a write fault
/// (fail_on_write_fault). InputError propagates (nothing is created when the case or options
/// are invalid).
int run_case(const Case& c, const RunOptions& options);

}  // namespace pfm

// The `pfm-mpm run` driver: validated case in, output directory out.
//
// Output directory (created only once the case is valid):
//   run.json              provenance (git revision, build type, command, case copy) + summary
//   particles.h5/.xdmf    particle time series (ParaView: open particles.xdmf)
//   timeseries.csv        time, kinetic energy, works, momentum; with loads on the detected
//                         boundary also their target, applied, lost and off-grid forces (kN/m)
//   final_particles.csv   the final particle state
//   boundary_<step>.csv   with a detection block, per output step (step with 8 digits): the
//                         detected boundary, columns loop,x,y (mpm/detect/contour.hpp order)
//   boundary.h5/.xdmf     the same boundaries as polylines (ParaView: open beside particles)
//   checkpoint.h5         the complete state at the latest checkpoint (for --restart)
#pragma once

#include <string>

#include "mpm/solver/case.hpp"

namespace pfm {

struct RunOptions {
  std::string out_dir;
  int threads = 0;           ///< 0: all cores
  bool progress = true;      ///< progress line on a terminal (never when CI is set)
  std::string command_line;  ///< recorded in run.json
  /// Checkpoint (checkpoint.h5) every this many steps (0: not by steps) and/or every this many
  /// seconds of wall time (0: not by time).
  long checkpoint_steps = 0;
  double checkpoint_seconds = 600.0;
  /// Continue the run in out_dir from its checkpoint (the case comes from its run.json).
  bool restart = false;
};

/// Exit codes of the command-line tool.
enum ExitCode : int {
  kExitOk = 0,
  kExitFailure = 1,
  kExitInputError = 2,
  kExitSimulationError = 3
};

/// Prepare the output directory: create it, or clear it if it holds a previous run (run.json);
/// InputError if it exists with other content.
void prepare_output_directory(const std::string& out_dir);

/// Run a validated case. Returns kExitOk, or kExitSimulationError after writing run.json with
/// status "failed" and keeping the outputs written so far. InputError propagates (nothing is
/// created when the case or options are invalid).
int run_case(const Case& c, const RunOptions& options);

}  // namespace pfm

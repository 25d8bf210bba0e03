// What both solvers' runs do alike around their steps (run_driver.hpp drives them): the run's
// options and exit codes, its progress line, the end of run.json, and the handling of a write
// fault or a simulation that stops.
#pragma once

#include <array>
#include <chrono>
#include <nlohmann/json.hpp>
#include <string>

#include "mpm/core/output_folder.hpp"
#include "mpm/core/provenance.hpp"
#include "mpm/step/case.hpp"
#include "mpm/step/output.hpp"

namespace pfm {

class SimulationError;  // mpm/step/step_view.hpp

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
  /// Write into an out_dir that holds files which are not this program's (they are kept).
  bool overwrite = false;
};

/// Exit codes of the command-line tools (README "Exit codes"). 1 is left to what no handler
/// foresaw (a bug), so that a handled condition never exits 1.
enum ExitCode : int {
  kExitOk = 0,
  kExitInternalError = 1,    ///< an unforeseen exception: a bug to report
  kExitInputError = 2,       ///< bad input or a refused request (nothing written or removed)
  kExitSimulationError = 3,  ///< the simulation stopped; outputs up to the last good step kept
  kExitIoError = 4           ///< a write failed (full disk, unwritable folder) or memory ran out
};

/// Progress of a run on stderr (none when disabled, `--quiet`): on a terminal one line rewritten
/// every 0.5 s, in a pipe or a log a new line every 5 s; step, simulated time, share done, steps
/// per second and the time left.
class RunProgress {
 public:
  explicit RunProgress(bool enabled);
  ~RunProgress();
  RunProgress(const RunProgress&) = delete;
  RunProgress& operator=(const RunProgress&) = delete;
  void update(long step, double time, double end_time);

 private:
  bool enabled_, terminal_, rewritten_ = false;
  std::chrono::steady_clock::time_point start_, last_;
};

/// One line on stderr at the end of a run: its status, steps, simulated and wall time,
/// particle-steps per second and where the results are (run.json's summary).
void print_run_summary(const nlohmann::json& run, const std::string& dir);

/// The output folder of a new run (OutputFolder::Mode::kNew, or kOverwrite with
/// options.overwrite) or of a restart (kResume).
OutputFolder::Mode output_folder_mode(const RunOptions& options);

/// Marks run.json "failed" with `reason` when that write still succeeds (the folder's reserve is
/// given back first) and removes the folder's temporaries.
void mark_failed(OutputFolder& folder, nlohmann::json& run, const std::string& reason) noexcept;
/// Ends a run that a write fault stopped: prints the reason, mark_failed(). Returns kExitIoError.
int fail_on_write_fault(OutputFolder& folder, nlohmann::json& run, const IoError& error);
/// A simulation error stopped the stepping: prints it and that the outputs so far are kept in
/// `dir`, sets `message` to it. Returns kExitSimulationError (the run's status).
int note_simulation_stop(const SimulationError& error, const std::string& dir,
                         std::string& message);

/// The status, error and summary of a finished run in run.json, as both solvers write them:
/// status ("completed" for kExitOk, else "failed"), error (`message`, when given), the finish
/// time, and the summary's particles, steps, times, speed (wall time since `wall_start`), the
/// stage seconds under the solver's names (Solver::kStageNames) for locate, particles-to-grid,
/// external forces, grid update, grid-to-particles, remap and stress, the energy ledger and the
/// threads. `Solver` is MpmSolver or UlFemSolver.
template <class Solver>
void record_run_end(nlohmann::json& run, const Solver& solver, long initial_steps,
                    std::chrono::steady_clock::time_point wall_start, int status,
                    const std::string& message, const nlohmann::json& threads);

/// Ends a run: writes its timeseries.csv and final run.json (the reserve given back first; a
/// write fault ends in fail_on_write_fault) and, unless quiet, prints the summary line. Returns
/// `status`, or kExitIoError.
int finish_run(OutputFolder& folder, nlohmann::json& run, const std::string& timeseries,
               const RunOptions& options, int status);

template <class Solver>
void record_run_end(nlohmann::json& run, const Solver& solver, long initial_steps,
                    std::chrono::steady_clock::time_point wall_start, int status,
                    const std::string& message, const nlohmann::json& threads) {
  const auto& stage_names = Solver::kStageNames;
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  const auto& st = solver.stage_times();
  const double n_particles = static_cast<double>(solver.particles().size());
  const double n_steps_done = static_cast<double>(solver.step_count() + initial_steps);
  run["status"] = status == kExitOk ? "completed" : "failed";
  if (!message.empty()) run["error"] = message;
  run["provenance"]["finished_utc"] = utc_now();
  nlohmann::json& summary = run["summary"] = nlohmann::json::object();
  summary["n_particles"] = solver.particles().size();
  summary["n_steps"] = solver.step_count();
  summary["n_initial_stress_steps"] = initial_steps;
  summary["final_time_s"] = solver.time();
  summary["dt_s"] = solver.dt();
  summary["critical_dt_s"] = solver.critical_dt();
  summary["wall_time_s"] = wall;
  summary["particle_steps_per_s"] = wall > 0 ? n_particles * n_steps_done / wall : 0.0;
  const double seconds[7] = {st.locate,      st.particles_to_grid, st.external_forces,
                             st.update_grid, st.grid_to_particles, st.remap,
                             st.stress};
  for (std::size_t k = 0; k < stage_names.size(); ++k)
    summary["stage_seconds"][stage_names[k]] = seconds[k];
  summary["energy"] = energy_summary(solver.energy());
  summary["threads"] = threads;
}

}  // namespace pfm

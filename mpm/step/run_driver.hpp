// The run driver of both solvers (run_case for the MPM, ulfem::run_ulfem_case for the UL-FEM):
// what they do alike from the first write of run.json to the last, with hooks for what differs
// (the MPM's restart, checkpoints and detected boundaries; the UL-FEM's mesh series).
#pragma once

#include <chrono>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>

#include "mpm/core/output_folder.hpp"
#include "mpm/core/provenance.hpp"
#include "mpm/step/case.hpp"
#include "mpm/step/output.hpp"
#include "mpm/step/run_support.hpp"
#include "mpm/step/step_view.hpp"

namespace pfm {

/// What a solver's run does its own way. Empty functions do nothing (finished is required).
struct RunHooks {
  /// Before run.json is first written (a restart rebuilds its output series here).
  std::function<void()> prepare_outputs;
  /// The run's start: the initial stress, the first output and time-series row (or nothing
  /// for a restart, whose state the checkpoint gave).
  std::function<void()> start;
  /// Whether the run has reached its end (after a step).
  std::function<bool()> finished;
  /// A row of the time series; an output step (particles and the solver's own series).
  std::function<void()> record, output;
  /// After each step, with whether it was the last (checkpoints).
  std::function<void(bool last)> after_step;
  /// Closes the output series (HDF5 files) before run.json is marked failed.
  std::function<void()> close_writers;
  /// The solver's own entries of run.json at the end (its summary, the outputs list).
  std::function<void(nlohmann::json& run)> summarise;
  /// The particles' recovered stress now (mpm/core/stress_recovery.hpp; empty: their own).
  std::function<std::vector<Stress>()> recovered_stress;
};

/// Runs `solver` with `hooks`: writes run.json as `run` holds it, starts, steps until
/// hooks.finished(), and after each step records a row of the time series every
/// c.output.timeseries_interval and after the last step, writes an output (and timeseries.csv
/// from `series`) every c.output.interval and after the last step, calls after_step and shows
/// the progress; then writes final_particles.csv and ends run.json (record_run_end, the hooks'
/// summary, finish_run). next_series and next_output (s) are the next times due (a restart
/// carries them over); their tolerance is 1e-9 of the time step solver.dt() at the start.
/// A simulation error ends the run "failed" with the outputs so far (kExitSimulationError), a
/// write fault with kExitIoError (fail_on_write_fault); any other exception marks run.json
/// failed and propagates.
template <class Solver>
int drive_run(Solver& solver, const RunHooks& hooks, const Case& c, const RunOptions& options,
              ThreadGovernor& governor, OutputFolder& folder, nlohmann::json& run,
              const TimeSeriesTable& series, double& next_series, double& next_output) {
  const auto call = [](const std::function<void()>& f) {
    if (f) f();
  };
  try {
    call(hooks.prepare_outputs);
    const std::string text = run.dump(2) + "\n";
    write_file_atomically(folder.file("run.json"), text);
    folder.reserve(2 * text.size() + 65536);  // room to mark run.json failed on a full disk
  } catch (const IoError& e) {
    call(hooks.close_writers);
    return fail_on_write_fault(folder, run, e);
  }
  const auto wall_start = std::chrono::steady_clock::now();
  long initial_steps = 0;
  int status = kExitOk;
  std::string message;
  try {
    call(hooks.start);
    initial_steps = solver.initial_stress_steps();
    const double eps = 1e-9 * solver.dt();
    RunProgress progress(options.progress);
    for (bool last = hooks.finished(); !last;) {
      governor.update();
      solver.step();
      const double t = solver.time();
      last = hooks.finished();
      if (t >= next_series - eps || last) {
        call(hooks.record);
        while (next_series <= t + eps) next_series += c.output.timeseries_interval;
      }
      if (t >= next_output - eps || last) {
        call(hooks.output);
        write_file_atomically(folder.file("timeseries.csv"), series.text());
        while (next_output <= t + eps) next_output += c.output.interval;
      }
      if (hooks.after_step) hooks.after_step(last);
      progress.update(solver.step_count(), t, c.time.end_time);
    }
    const std::vector<Stress> recovered =
        hooks.recovered_stress ? hooks.recovered_stress() : std::vector<Stress>{};
    write_file_atomically(folder.file("final_particles.csv"),
                          particles_csv(solver.particles(), recovered));
  } catch (const SimulationError& e) {
    status = note_simulation_stop(e, options.out_dir, message);
  } catch (const IoError& e) {
    call(hooks.close_writers);
    return fail_on_write_fault(folder, run, e);
  } catch (const std::exception& e) {  // memory ran out, or a bug: main() reports it
    call(hooks.close_writers);
    mark_failed(folder, run, e.what());
    throw;
  }
  record_run_end(run, solver, initial_steps, wall_start, status, message, governor.summary());
  if (hooks.summarise) hooks.summarise(run);
  return finish_run(folder, run, series.text(), options, status);
}

}  // namespace pfm

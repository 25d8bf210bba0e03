// The run driver of both solvers (MpmRun and run_case for the MPM, ulfem::run_ulfem_case for the
// UL-FEM): what they do alike from the first write of run.json to the last, with hooks for what
// differs (the MPM's restart, checkpoints and detected boundaries; the UL-FEM's mesh series).
// RunDriver takes a run a step at a time (a driver from Python ends it where it likes);
// drive_run runs it to its end.
#pragma once

#include <chrono>
#include <functional>
#include <nlohmann/json.hpp>
#include <optional>
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

/// A run of `solver` with `hooks`, a step at a time: begin() writes run.json as `run` holds it
/// and starts; each step() steps once, records a row of the time series every
/// c.output.timeseries_interval and after the last step (hooks.finished()), writes an output
/// (and timeseries.csv from `series`) every c.output.interval and after the last step, calls
/// after_step and shows the progress; end() writes final_particles.csv and ends run.json
/// (record_run_end, the hooks' summary, finish_run). end() before the last step ends the run
/// there, the current step written as a last step's would be (its row and its output, unless
/// it had them), so the files equal a run whose end time is now. next_series and next_output
/// (s) are the next times due (a restart carries them over); their tolerance is 1e-9 of the
/// time step solver.dt() at the start.
///
/// A simulation error stops the run (running() turns false; end() marks it "failed" with the
/// outputs so far, kExitSimulationError), a write fault ends it with kExitIoError
/// (fail_on_write_fault); any other exception marks run.json failed and propagates. Every
/// argument must outlive the driver.
template <class Solver>
class RunDriver {
 public:
  RunDriver(Solver& solver, const RunHooks& hooks, const Case& c, const RunOptions& options,
            ThreadGovernor& governor, OutputFolder& folder, nlohmann::json& run,
            const TimeSeriesTable& series, double& next_series, double& next_output)
      : solver_(solver),
        hooks_(hooks),
        case_(c),
        options_(options),
        governor_(governor),
        folder_(folder),
        run_(run),
        series_(series),
        next_series_(next_series),
        next_output_(next_output) {}

  /// Writes run.json and starts (hooks.prepare_outputs, hooks.start).
  void begin() {
    try {
      call(hooks_.prepare_outputs);
      const std::string text = run_.dump(2) + "\n";
      write_file_atomically(folder_.file("run.json"), text);
      folder_.reserve(2 * text.size() + 65536);  // room to mark run.json failed on a full disk
    } catch (const IoError& e) {
      call(hooks_.close_writers);
      return end_with(fail_on_write_fault(folder_, run_, e));
    }
    wall_start_ = std::chrono::steady_clock::now();
    phase_ = Phase::kRunning;
    guarded([&] {
      call(hooks_.start);
      initial_steps_ = solver_.initial_stress_steps();
      eps_ = 1e-9 * solver_.dt();
      recorded_step_ = written_step_ = solver_.step_count();
      progress_.emplace(options_.progress);
    });
  }

  /// Whether the run has begun and neither stopped nor ended.
  bool running() const { return phase_ == Phase::kRunning; }
  /// Whether the run has begun, not stopped or ended, and not reached its last step.
  bool stepping() const { return running() && !hooks_.finished(); }

  /// What stopped the run (a simulation error's message), or empty.
  const std::string& message() const { return message_; }

  /// One step (stepping() must hold).
  void step() {
    guarded([&] {
      governor_.update();
      solver_.step();
      const double t = solver_.time();
      const bool last = hooks_.finished();
      if (t >= next_series_ - eps_ || last) {
        record();
        while (next_series_ <= t + eps_) next_series_ += case_.output.timeseries_interval;
      }
      if (t >= next_output_ - eps_ || last) {
        output();
        while (next_output_ <= t + eps_) next_output_ += case_.output.interval;
      }
      if (hooks_.after_step) hooks_.after_step(last);
      progress_->update(solver_.step_count(), t, case_.time.end_time);
    });
  }

  /// Ends the run (see the class); returns its exit status. Once ended, returns it again.
  int end() {
    if (phase_ == Phase::kRunning) {
      guarded([&] {
        if (recorded_step_ != solver_.step_count()) record();
        if (written_step_ != solver_.step_count()) output();
        const std::vector<Stress> recovered =
            hooks_.recovered_stress ? hooks_.recovered_stress() : std::vector<Stress>{};
        write_file_atomically(folder_.file("final_particles.csv"),
                              particles_csv(solver_.particles(), recovered));
        progress_.reset();
      });
    }
    if (phase_ == Phase::kRunning || phase_ == Phase::kStopped) {
      record_run_end(run_, solver_, initial_steps_, wall_start_, status_, message_,
                     governor_.summary());
      if (hooks_.summarise) hooks_.summarise(run_);
      end_with(finish_run(folder_, run_, series_.text(), options_, status_));
    }
    return status_;
  }

 private:
  enum class Phase { kNew, kRunning, kStopped, kEnded };

  static void call(const std::function<void()>& f) {
    if (f) f();
  }
  void record() {
    call(hooks_.record);
    recorded_step_ = solver_.step_count();
  }
  void output() {
    call(hooks_.output);
    write_file_atomically(folder_.file("timeseries.csv"), series_.text());
    written_step_ = solver_.step_count();
  }
  void end_with(int status) {
    status_ = status;
    phase_ = Phase::kEnded;
  }
  /// Runs `f`, a part of the run between begin() and end(), with its errors' endings.
  template <class F>
  void guarded(F&& f) {
    try {
      f();
    } catch (const SimulationError& e) {
      progress_.reset();
      status_ = note_simulation_stop(e, options_.out_dir, message_);
      phase_ = Phase::kStopped;
    } catch (const IoError& e) {
      progress_.reset();
      call(hooks_.close_writers);
      end_with(fail_on_write_fault(folder_, run_, e));
    } catch (const std::exception& e) {  // memory ran out, or a bug: main() reports it
      progress_.reset();
      call(hooks_.close_writers);
      mark_failed(folder_, run_, e.what());
      end_with(kExitInternalError);
      throw;
    }
  }

  Solver& solver_;
  const RunHooks& hooks_;
  const Case& case_;
  const RunOptions& options_;
  ThreadGovernor& governor_;
  OutputFolder& folder_;
  nlohmann::json& run_;
  const TimeSeriesTable& series_;
  double& next_series_;
  double& next_output_;
  Phase phase_ = Phase::kNew;
  int status_ = kExitOk;
  std::string message_;
  std::chrono::steady_clock::time_point wall_start_;
  long initial_steps_ = 0;
  double eps_ = 0.0;
  long recorded_step_ = -1, written_step_ = -1;
  std::optional<RunProgress> progress_;
};

/// Runs `solver` with `hooks` from begin() to the last step and end() (RunDriver); returns the
/// exit status.
template <class Solver>
int drive_run(Solver& solver, const RunHooks& hooks, const Case& c, const RunOptions& options,
              ThreadGovernor& governor, OutputFolder& folder, nlohmann::json& run,
              const TimeSeriesTable& series, double& next_series, double& next_output) {
  RunDriver<Solver> driver(solver, hooks, c, options, governor, folder, run, series, next_series,
                           next_output);
  driver.begin();
  while (driver.stepping()) driver.step();
  return driver.end();
}

}  // namespace pfm

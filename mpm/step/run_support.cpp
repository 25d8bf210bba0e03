#include "mpm/step/run_support.hpp"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "mpm/core/json_input.hpp"
#include "mpm/core/provenance.hpp"
#include "mpm/step/step_view.hpp"

namespace pfm {

namespace fs = std::filesystem;

RunProgress::RunProgress(bool enabled)
    : enabled_(enabled),
      terminal_(isatty(STDERR_FILENO) && std::getenv("CI") == nullptr),
      start_(std::chrono::steady_clock::now()),
      last_(start_) {}

void RunProgress::update(long step, double time, double end_time) {
  if (!enabled_) return;
  const auto now = std::chrono::steady_clock::now();
  if (now - last_ < (terminal_ ? std::chrono::milliseconds(500) : std::chrono::seconds(5))) return;
  last_ = now;
  const double elapsed = std::chrono::duration<double>(now - start_).count();
  const double fraction = std::min(1.0, time / end_time);
  const double eta = fraction > 0 ? elapsed * (1.0 - fraction) / fraction : 0.0;
  std::fprintf(stderr, "%s  step %ld  t = %.4f / %.4f s  (%5.1f %%)  %.0f steps/s  ETA %.0f s%s",
               terminal_ ? "\r" : "", step, time, end_time, 100.0 * fraction,
               elapsed > 0 ? static_cast<double>(step) / elapsed : 0.0, eta,
               terminal_ ? "   " : "\n");
  std::fflush(stderr);
  rewritten_ = terminal_;
}

RunProgress::~RunProgress() {
  if (rewritten_) std::fprintf(stderr, "\n");
}

void print_run_summary(const nlohmann::json& run, const std::string& dir) {
  const nlohmann::json& s = run.at("summary");
  std::fprintf(
      stderr,
      "pfm-mpm: %s: %ld steps to t = %.4g s in %.1f s of wall time (%.3g particle-steps/s); "
      "results in %s\n",
      run.value("status", "?").c_str(), s.value("n_steps", 0L), s.value("final_time_s", 0.0),
      s.value("wall_time_s", 0.0), s.value("particle_steps_per_s", 0.0), dir.c_str());
}

OutputFolder::Mode output_folder_mode(const RunOptions& options) {
  if (options.restart) return OutputFolder::Mode::kResume;
  return options.overwrite ? OutputFolder::Mode::kOverwrite : OutputFolder::Mode::kNew;
}

void mark_failed(OutputFolder& folder, nlohmann::json& run, const std::string& reason) noexcept {
  folder.release_reserve();
  try {
    run["status"] = "failed";
    run["error"] = reason;
    run["provenance"]["finished_utc"] = utc_now();
    write_file_atomically(folder.file("run.json"), run.dump(2) + "\n");
  } catch (const std::exception&) {
    std::cerr << "pfm-mpm: run.json could not be marked failed either\n";
  }
  folder.remove_temporaries();
}

int note_simulation_stop(const SimulationError& error, const std::string& dir,
                         std::string& message) {
  message = error.what();
  std::cerr << "pfm-mpm: simulation stopped: " << message << "\n"
            << "pfm-mpm: outputs up to the last good step are kept in " << dir << "\n";
  return kExitSimulationError;
}

int fail_on_write_fault(OutputFolder& folder, nlohmann::json& run, const IoError& error) {
  std::cerr << "pfm-mpm: write failed: " << error.what() << "\n";
  mark_failed(folder, run, std::string("write failed: ") + error.what());
  return kExitIoError;
}

int finish_run(OutputFolder& folder, nlohmann::json& run, const std::string& timeseries,
               const RunOptions& options, int status) {
  try {
    write_file_atomically(folder.file("timeseries.csv"), timeseries);
    folder.release_reserve();  // the disk it kept is the final run.json's
    write_file_atomically(folder.file("run.json"), run.dump(2) + "\n");
  } catch (const IoError& e) {
    return fail_on_write_fault(folder, run, e);
  }
  if (options.progress) print_run_summary(run, options.out_dir);
  return status;
}

}  // namespace pfm

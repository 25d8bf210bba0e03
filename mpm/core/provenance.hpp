// What every output directory records of how it was made: the program, this binary's git
// revision and build type, the input files, the command line, the thread count, the start time
// and the units; and the thread count itself.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace pfm {

/// The current time, UTC, ISO 8601 ("2026-11-30T01:50:00Z").
std::string utc_now();

/// Threads on the machine, not this process's, that are running or waiting for a core:
/// /proc/loadavg's count of runnable threads less this process's running ones
/// (/proc/self/task/*/stat), the fewest of three looks 2 ms apart (a kernel thread that wakes for
/// a moment is not a busy job); 0 where /proc cannot be read.
int other_runnable_threads();

/// Memory this process could take without swapping, bytes: /proc/meminfo's MemAvailable (the
/// physical memory where that is not readable), at most the address-space limit (ulimit -v).
double available_memory_bytes();

/// The thread count for `cores` cores of which `busy` are kept busy by other processes: the
/// cores left, at least one. Two threads sharing one core with another busy job are slower than
/// one: a step waits at each of its dozen synchronisations for the thread the job delays, whether
/// the threads spin or sleep while they wait (pfm-bench BM_StepBesideABusyJob measures it).
int threads_for_load(int cores, int busy);

/// Sets the OpenMP threads of this process to `requested`, or for 0 to
/// threads_for_load(cores, other_runnable_threads()), and returns the count (for provenance()).
int use_threads(int requested);

/// The thread count of a run. A count the user gives (--threads N > 0) is kept. Without one (0),
/// the count follows the machine's load: set by use_threads() at the start and again, by
/// update(), every `period` seconds of wall time, so that a job started beside a run takes its
/// core back. The solvers' results do not depend on the count (their sums go by fixed chunks),
/// so a run whose count changes ends bitwise where a run on one count would.
class ThreadGovernor {
 public:
  explicit ThreadGovernor(int requested, double period_seconds = 2.0);
  /// Looks at the load again once `period` has passed since the last look (cheap otherwise).
  void update();
  int threads() const { return threads_; }
  /// "fixed" (given by the user) or "load" (follows the machine's load).
  const char* policy() const { return automatic_ ? "load" : "fixed"; }
  /// {policy, fewest, most}, for a run's summary.
  nlohmann::json summary() const {
    return {{"policy", policy()}, {"fewest", fewest_}, {"most", most_}};
  }

 private:
  bool automatic_;
  double period_;
  double last_look_;  ///< seconds on the steady clock
  int threads_, fewest_, most_;
};

/// "pfm-mpm <version> (git <revision>, <build type> build)", for --version.
std::string version_line();

/// {program, version, git_revision, build_type, command, threads, started_utc, units} and the
/// members of `inputs`, which name the input files (e.g. {"case_file": path}).
nlohmann::json provenance(const nlohmann::json& inputs, const std::string& command_line,
                          int threads);

}  // namespace pfm

// Wall-clock time of a run's stages (StageTimes of the solvers, CouplingTimes).
#pragma once

#include <chrono>

namespace pfm {

using Clock = std::chrono::steady_clock;

/// Seconds from `start` to now.
inline double seconds_since(Clock::time_point start) {
  return std::chrono::duration<double>(Clock::now() - start).count();
}

/// Adds the wall-clock seconds of its scope to `total` (a stage's running sum):
///   { StageTimer timer(times_.update_grid); update_grid(); }
class StageTimer {
 public:
  explicit StageTimer(double& total) : total_(total), start_(Clock::now()) {}
  ~StageTimer() { total_ += seconds_since(start_); }
  StageTimer(const StageTimer&) = delete;
  StageTimer& operator=(const StageTimer&) = delete;

 private:
  double& total_;
  Clock::time_point start_;
};

}  // namespace pfm

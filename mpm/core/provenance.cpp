#include "mpm/core/provenance.hpp"

#include <omp.h>
#include <sys/resource.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <ctime>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>

#ifndef PFM_GIT_REVISION
#define PFM_GIT_REVISION "unknown"
#endif
#ifndef PFM_VERSION
#define PFM_VERSION "unknown"
#endif
#ifndef PFM_BUILD_TYPE
#define PFM_BUILD_TYPE "unknown"
#endif

namespace pfm {

std::string utc_now() {
  const std::time_t now = std::time(nullptr);
  char buffer[32];
  std::strftime(buffer, sizeof buffer, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&now));
  return buffer;
}

namespace {

double steady_seconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

// The runnable threads of the machine (/proc/loadavg, fourth field "runnable/total"), -1 if
// unreadable.
int runnable_threads() {
  std::ifstream file("/proc/loadavg");
  std::string a, b, c, counts;
  if (!(file >> a >> b >> c >> counts)) return -1;
  try {
    return std::stoi(counts.substr(0, counts.find('/')));
  } catch (const std::exception&) {
    return -1;
  }
}

// This process's threads in state R (/proc/self/task/*/stat: the state follows the command name's
// closing parenthesis).
int own_running_threads() {
  int running = 0;
  std::error_code error;
  for (const auto& task : std::filesystem::directory_iterator("/proc/self/task", error)) {
    std::ifstream file(task.path() / "stat");
    const std::string line((std::istreambuf_iterator<char>(file)),
                           std::istreambuf_iterator<char>());
    const std::size_t close = line.rfind(')');
    if (close != std::string::npos && close + 2 < line.size() && line[close + 2] == 'R') ++running;
  }
  return running;
}

}  // namespace

int other_runnable_threads() {
  int fewest = -1;
  for (int look = 0; look < 3; ++look) {
    if (look > 0) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    const int all = runnable_threads();
    if (all < 0) return 0;
    const int others = std::max(0, all - own_running_threads());
    fewest = fewest < 0 ? others : std::min(fewest, others);
  }
  return fewest;
}

double available_memory_bytes() {
  double bytes =
      static_cast<double>(sysconf(_SC_PHYS_PAGES)) * static_cast<double>(sysconf(_SC_PAGESIZE));
  std::ifstream meminfo("/proc/meminfo");
  std::string key, unit;
  double kilobytes = 0.0;
  while (meminfo >> key >> kilobytes >> unit) {
    if (key == "MemAvailable:") {
      bytes = kilobytes * 1024.0;
      break;
    }
  }
  rlimit limit{};
  if (getrlimit(RLIMIT_AS, &limit) == 0 && limit.rlim_cur != RLIM_INFINITY)
    bytes = std::min(bytes, static_cast<double>(limit.rlim_cur));
  return bytes;
}

int threads_for_load(int cores, int busy) {
  return std::max(1, cores - std::max(0, busy));
}

int use_threads(int requested) {
  const int threads =
      requested > 0 ? requested : threads_for_load(omp_get_num_procs(), other_runnable_threads());
  omp_set_num_threads(threads);
  return threads;
}

ThreadGovernor::ThreadGovernor(int requested, double period_seconds)
    : automatic_(requested <= 0), period_(period_seconds), last_look_(steady_seconds()) {
  threads_ = fewest_ = most_ = use_threads(requested);
}

void ThreadGovernor::update() {
  if (!automatic_) return;
  const double now = steady_seconds();
  if (now - last_look_ < period_) return;
  last_look_ = now;
  threads_ = use_threads(0);
  fewest_ = std::min(fewest_, threads_);
  most_ = std::max(most_, threads_);
}

std::string version_line() {
  return std::string("pfm-mpm ") + PFM_VERSION + " (git " + PFM_GIT_REVISION + ", " +
         PFM_BUILD_TYPE + " build)";
}

nlohmann::json provenance(const nlohmann::json& inputs, const std::string& command_line,
                          int threads) {
  nlohmann::json p = {{"program", "pfm-mpm"},
                      {"version", PFM_VERSION},
                      {"git_revision", PFM_GIT_REVISION},
                      {"build_type", PFM_BUILD_TYPE},
                      {"command", command_line},
                      {"threads", threads},
                      {"started_utc", utc_now()},
                      {"units", "kN, m, s, t, kPa; plane strain; tension positive"}};
  p.update(inputs);
  return p;
}

}  // namespace pfm

#include "mpm/core/provenance.hpp"

#include <omp.h>

#include <ctime>

#ifndef PFM_GIT_REVISION
#define PFM_GIT_REVISION "unknown"
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

int use_threads(int requested) {
  const int threads = requested > 0 ? requested : omp_get_num_procs();
  omp_set_num_threads(threads);
  return threads;
}

nlohmann::json provenance(const nlohmann::json& inputs, const std::string& command_line,
                          int threads) {
  nlohmann::json p = {{"program", "pfm-mpm"},
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

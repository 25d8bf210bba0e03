// What every output directory records of how it was made: the program, this binary's git
// revision and build type, the input files, the command line, the thread count, the start time
// and the units; and the thread count itself.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

namespace pfm {

/// The current time, UTC, ISO 8601 ("2026-11-30T01:50:00Z").
std::string utc_now();

/// Sets the OpenMP threads of this process to `requested`, or to every core for 0, and returns
/// the count (for provenance()).
int use_threads(int requested);

/// {program, git_revision, build_type, command, threads, started_utc, units} and the members of
/// `inputs`, which name the input files (e.g. {"case_file": path}).
nlohmann::json provenance(const nlohmann::json& inputs, const std::string& command_line,
                          int threads);

}  // namespace pfm

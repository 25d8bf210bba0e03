// One harness for the input readers and the detector, compiled twice: into the libFuzzer targets
// (clang, -DPFM_FUZZ=ON, tests/fuzz/fuzz_main.cpp) and into the replay test that `make test` runs
// with the normal build (tests/cpp/fuzz/test_fuzz_replay.cpp).
//
// Contract checked: a reader either accepts an input or rejects it with pfm::InputError. Any
// other exception (including a nlohmann::json exception that a reader let through), a crash, a
// sanitizer report or a hang is a finding. Accepted inputs are also checked for the invariants
// the rest of the program relies on; a violation throws InvariantViolation. The detector target
// decodes a particle cloud from the bytes and checks the detector's contour invariants.
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>
#include <string_view>

namespace pfm::fuzz {

enum class Target {
  kCase,         ///< pfm::read_case, detection block and detected-boundary loads included
  kParticleCsv,  ///< pfm::read_particle_csv
  kConfig,       ///< pfm::parse_detector_config and pfm::boundary::parse_boundary_load
  kDetect,       ///< pfm::detect (improved) on a cloud decoded from the bytes: its invariants
};

inline constexpr Target kAllTargets[] = {Target::kCase, Target::kParticleCsv, Target::kConfig,
                                         Target::kDetect};

/// Directory name of the target under tests/fuzz/corpus and tests/fuzz/regressions.
const char* target_name(Target target);
std::optional<Target> target_from_name(std::string_view name);

enum class Outcome { kAccepted, kRejected };

/// An accepted input broke an invariant the rest of the program relies on (a reader bug).
class InvariantViolation : public std::logic_error {
 public:
  using std::logic_error::logic_error;
};

/// Feeds the file at `path` to the target's reader(s). Returns kRejected when every reader threw
/// pfm::InputError; other exceptions propagate.
Outcome run_file(Target target, const std::string& path);

/// Writes the bytes to a scratch file of this process (in the temporary directory) and calls
/// run_file on it: the readers take file names.
Outcome run_bytes(Target target, const std::uint8_t* data, std::size_t size);

}  // namespace pfm::fuzz

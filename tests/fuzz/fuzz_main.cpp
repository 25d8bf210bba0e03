// libFuzzer entry point of one target; PFM_FUZZ_TARGET (case, particle_csv, config or detect) is
// set by tests/cpp/fuzz/CMakeLists.txt. Built only with -DPFM_FUZZ=ON and clang; see
// tests/fuzz/README.md.
#include <cstddef>
#include <cstdint>

#include "fuzz_harness.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  pfm::fuzz::run_bytes(pfm::fuzz::Target::PFM_FUZZ_TARGET, data, size);
  return 0;
}

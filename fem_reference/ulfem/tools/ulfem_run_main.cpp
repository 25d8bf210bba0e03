// pfm-ulfem: run a case with the UL-FEM, stand-alone (`pfm-mpm run CASE --out DIR --solver ulfem`
// runs the same run_ulfem_case).
//
//   pfm-ulfem CASE.json OUT_DIR [THREADS]
//
// Exit codes as pfm-mpm (mpm/step/run_support.hpp): 0 done, 2 bad input, 3 the simulation stopped,
// 4 a write failed.
#include <hdf5.h>

#include <charconv>
#include <iostream>
#include <string>

#include "fem_reference/ulfem/ulfem_run.hpp"
#include "mpm/core/heap_policy.hpp"
#include "mpm/core/json_input.hpp"
#include "mpm/step/step_view.hpp"

int main(int argc, char** argv) {
  H5dont_atexit();           // as pfm-mpm (apps/main.cpp)
  pfm::keep_freed_memory();  // as pfm-mpm: its runs and this one on the same heap policy
  if (argc < 3) {
    std::cerr << "usage: pfm-ulfem CASE.json OUT_DIR [THREADS]\n";
    return pfm::kExitInputError;
  }
  pfm::RunOptions options;
  options.out_dir = argv[2];
  if (argc > 3) {
    const std::string threads = argv[3];
    const char* end = threads.data() + threads.size();
    const auto [stop, error] = std::from_chars(threads.data(), end, options.threads);
    if (error != std::errc() || stop != end || options.threads < 0) {
      std::cerr << "pfm-ulfem: error: THREADS: expected a whole number >= 0 (0: all cores), got '"
                << threads << "'\nusage: pfm-ulfem CASE.json OUT_DIR [THREADS]\n";
      return pfm::kExitInputError;
    }
  }
  for (int k = 0; k < argc; ++k) {
    if (k > 0) options.command_line += ' ';
    options.command_line += argv[k];
  }
  try {
    const pfm::Case c = pfm::read_case(argv[1]);
    const int status = pfm::run_ulfem_case(c, options);
    if (status == pfm::kExitOk) std::cout << "results: " << options.out_dir << "\n";
    return status;
  } catch (const pfm::InputError& e) {
    std::cerr << "pfm-ulfem: error: " << e.what() << "\n";
    return pfm::kExitInputError;
  } catch (const pfm::IoError& e) {
    std::cerr << "pfm-ulfem: write failed: " << e.what() << "\n";
    return pfm::kExitIoError;
  } catch (const std::exception& e) {
    std::cerr << "pfm-ulfem: internal error (please report it): " << e.what() << "\n";
    return pfm::kExitInternalError;
  }
}

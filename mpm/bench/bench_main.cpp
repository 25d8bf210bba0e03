// main() of the benchmarks: BENCHMARK_MAIN() with the heap policy of pfm-mpm
// (mpm/core/heap_policy.hpp), so that the timings do not depend on what the process allocated
// and freed before.
#include <benchmark/benchmark.h>

#include "mpm/core/heap_policy.hpp"

int main(int argc, char** argv) {
  pfm::keep_freed_memory();
  benchmark::Initialize(&argc, argv);
  if (benchmark::ReportUnrecognizedArguments(argc, argv)) return 1;
  benchmark::RunSpecifiedBenchmarks();
  benchmark::Shutdown();
  return 0;
}

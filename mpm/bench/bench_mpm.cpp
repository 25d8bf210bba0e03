// make bench: particle-steps per second of the explicit MPM step on the thesis's bearing block
// (15 x 5 m, 2 x 2 points per cell, zero initial stress, q_v = 50 kPa) refined to about 1.2k,
// 19k and 300k particles, elastic and softening Tresca, 1 and 2 threads.
// Counter `particle_steps/s` is the cb-geo style throughput; per-stage shares are reported as
// counters too (fraction of the step time).
#include <benchmark/benchmark.h>
#include <omp.h>

#include <string>

#include "mpm/core/json_input.hpp"
#include "mpm/solver/mpm_solver.hpp"

namespace {

pfm::Case bearing_block(double cell, bool elastic) {
  nlohmann::json j = pfm::read_json_file(std::string(PFM_SOURCE_DIR) + "/cases/bearing_block.json");
  const int nx = static_cast<int>(15.0 / cell + 0.5), ny = static_cast<int>(7.5 / cell + 0.5);
  j["grid"]["cell_size"] = cell;
  j["grid"]["n_cells"] = {nx, ny};
  if (elastic) {
    j["materials"][0].erase("cohesion");
    j["materials"][0]["model"] = "linear_elastic";
  }
  return pfm::parse_case(j, "bench");
}

void BM_Step(benchmark::State& state) {
  const double cell = 0.5 / static_cast<double>(state.range(0));
  const bool elastic = state.range(1) == 0;
  const int threads = static_cast<int>(state.range(2));
  omp_set_num_threads(threads);
  pfm::MpmSolver solver(bearing_block(cell, elastic));
  for (int k = 0; k < 3; ++k) solver.step();  // warm up, allocate
  const pfm::StageTimes before = solver.stage_times();
  long steps = 0;
  for (auto _ : state) {
    solver.step();
    ++steps;
  }
  const double n = static_cast<double>(solver.particles().size());
  state.counters["particles"] = n;
  state.counters["particle_steps/s"] =
      benchmark::Counter(n * static_cast<double>(steps), benchmark::Counter::kIsRate);
  const pfm::StageTimes& t = solver.stage_times();
  const double total = t.total() - before.total();
  state.counters["p2g_share"] = (t.particles_to_grid - before.particles_to_grid) / total;
  state.counters["g2p_share"] = (t.grid_to_particles - before.grid_to_particles) / total;
  state.counters["stress_share"] = (t.stress - before.stress) / total;
  state.counters["locate_share"] = (t.locate - before.locate) / total;
  state.counters["remap_share"] = (t.remap - before.remap) / total;
  state.SetLabel(std::string(elastic ? "elastic" : "tresca") + ", " + std::to_string(threads) +
                 " thread(s)");
}

// range(0): refinement (1 -> 1.2k particles, 4 -> 19k, 16 -> 307k); range(1): 0 elastic,
// 1 Tresca; range(2): threads.
BENCHMARK(BM_Step)
    ->ArgsProduct({{1, 4, 16}, {0, 1}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(1.0);

}  // namespace

BENCHMARK_MAIN();

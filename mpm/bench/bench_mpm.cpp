// make bench: particle-steps per second of the explicit MPM step on the thesis's bearing block
// (15 x 5 m, 2 x 2 points per cell, zero initial stress, q_v = 50 kPa as consistent forces on
// the top grid nodes) refined to about 1.2k, 19k and 300k particles, elastic and softening
// Tresca, 1 and 2 threads (BM_Step), and with each shape function with and without
// anti-locking (BM_StepShapes).
//
// Counters:
//   particle_steps/s  the cb-geo style throughput (particles x steps / wall time)
//   per_cpu_s         particles x steps per CPU second of the process (all threads): on a
//                     machine shared with other jobs this is the steadier figure for one thread
//   particles         number of material points
//   locate ... stress seconds per particle-step spent in each stage of MpmSolver (StageTimes),
//                     so that a stage's counter times particle_steps/s is its share of the step
//   stages            their sum (the rest of the wall time is the step bookkeeping)
//
// The load is forced onto the grid-top nodes here whatever
// cases/thesis62_bearing_dynamic_zero_start.json says, so the benchmark measures the MPM step alone
// (boundary detection has its own benchmark); the B-spline blocks of BM_StepShapes carry their
// weight alone.
#include <benchmark/benchmark.h>
#include <omp.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <ctime>
#include <string>
#include <thread>

#include "mpm/core/json_input.hpp"
#include "mpm/core/provenance.hpp"
#include "mpm/solver/mpm_solver.hpp"

namespace {

double process_cpu_seconds() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

pfm::Case bearing_block(double cell, bool elastic, const std::string& shape_function = "linear",
                        const std::string& anti_locking = "none") {
  nlohmann::json j = pfm::read_json_file(std::string(PFM_SOURCE_DIR) +
                                         "/cases/thesis62_bearing_dynamic_zero_start.json");
  const int nx = static_cast<int>(15.0 / cell + 0.5), ny = static_cast<int>(7.5 / cell + 0.5);
  j["grid"]["origin"] = {0.0, 0.0};
  j["grid"]["cell_size"] = cell;
  j["grid"]["n_cells"] = {nx, ny};
  j["materials"] = nlohmann::json::parse(R"([
    {"name": "soil", "model": "tresca", "youngs_modulus": 1000.0, "poisson_ratio": 0.15,
     "unit_weight": 20.0,
     "cohesion": {"initial": 20.0, "peak": 10.0, "residual": 5.0,
                  "peak_plastic_strain": 0.05, "residual_plastic_strain": 0.25}}])");
  if (elastic) {
    j["materials"][0].erase("cohesion");
    j["materials"][0]["model"] = "linear_elastic";
  }
  j["loads"] = nlohmann::json::parse(R"([
    {"type": "vertical_pressure", "pressure": 50.0, "x_range": [5.0, 10.0],
     "apply_on": "grid_top_nodes", "time_function": {"type": "constant"}}])");
  j.erase("detection");
  j["solver"] = {{"scheme", "musl"},
                 {"shape_function", shape_function},
                 {"damping", 0.05},
                 {"anti_locking", anti_locking}};
  if (shape_function == "gimp") {
    // uGIMP: a margin of 2 cells, and the walls as node sets holding the nodes behind them (as
    // cases/bearing_quasi_static.json).
    j["grid"]["origin"] = {-2.0 * cell, -2.0 * cell};
    j["grid"]["n_cells"] = {nx + 4, ny + 4};
    j["node_sets"] = nlohmann::json::parse(R"([
      {"name": "base", "box": [[-1000.0, -1000.0], [1015.0, 1e-9]]},
      {"name": "left_wall", "box": [[-1000.0, 0.0], [1e-9, 1000.0]]},
      {"name": "right_wall", "box": [[14.999999999, 0.0], [1015.0, 1000.0]]}])");
    j["boundary_conditions"] = nlohmann::json::parse(R"([
      {"where": "base", "fix": "xy"}, {"where": "left_wall", "fix": "x"},
      {"where": "right_wall", "fix": "x"}])");
  }
  if (shape_function.ends_with("bspline")) {
    // B-splines take no load on the grid-top nodes (its nodal forces are the linear
    // functions'); the block settles under its weight alone, the step's work otherwise the same.
    j.erase("loads");
  }
  return pfm::parse_case(j, "bench");
}

// Times steps of `solver` and sets the counters of the header comment.
void time_steps(benchmark::State& state, pfm::MpmSolver& solver) {
  for (int k = 0; k < 3; ++k) solver.step();  // warm up, allocate
  const pfm::StageTimes before = solver.stage_times();
  const double cpu_before = process_cpu_seconds();
  long steps = 0;
  for (auto _ : state) {
    solver.step();
    ++steps;
  }
  const double cpu_seconds = process_cpu_seconds() - cpu_before;
  const double n = static_cast<double>(solver.particles().size());
  const double particle_steps = n * static_cast<double>(steps);
  state.counters["particles"] = n;
  state.counters["particle_steps/s"] =
      benchmark::Counter(particle_steps, benchmark::Counter::kIsRate);
  state.counters["per_cpu_s"] = cpu_seconds > 0.0 ? particle_steps / cpu_seconds : 0.0;
  const pfm::StageTimes& t = solver.stage_times();
  auto per_particle_step = [&](double after, double start) {
    return particle_steps > 0.0 ? (after - start) / particle_steps : 0.0;
  };
  state.counters["locate"] = per_particle_step(t.locate, before.locate);
  state.counters["p2g"] = per_particle_step(t.particles_to_grid, before.particles_to_grid);
  state.counters["external"] = per_particle_step(t.external_forces, before.external_forces);
  state.counters["grid"] = per_particle_step(t.update_grid, before.update_grid);
  state.counters["g2p"] = per_particle_step(t.grid_to_particles, before.grid_to_particles);
  state.counters["remap"] = per_particle_step(t.remap, before.remap);
  state.counters["stress"] = per_particle_step(t.stress, before.stress);
  state.counters["stages"] = per_particle_step(t.total(), before.total());
}

void BM_Step(benchmark::State& state) {
  const double cell = 0.5 / static_cast<double>(state.range(0));
  const bool elastic = state.range(1) == 0;
  const int threads = static_cast<int>(state.range(2));
  omp_set_num_threads(threads);
  pfm::MpmSolver solver(bearing_block(cell, elastic));
  time_steps(state, solver);
  state.SetLabel(std::string(elastic ? "elastic" : "tresca") + ", " + std::to_string(threads) +
                 " thread(s)");
}

// The softening Tresca block with each shape function, with and without anti-locking
// (solver.anti_locking "bbar"): the cost of each per particle-step, against BM_Step's linear
// figure of the same size and threads.
void BM_StepShapes(benchmark::State& state) {
  const double cell = 0.5 / static_cast<double>(state.range(0));
  const char* shapes[] = {"linear", "gimp", "quadratic_bspline", "cubic_bspline"};
  const std::string shape = shapes[state.range(1)];
  const std::string anti_locking = state.range(2) == 0 ? "none" : "bbar";
  const int threads = static_cast<int>(state.range(3));
  omp_set_num_threads(threads);
  pfm::MpmSolver solver(bearing_block(cell, false, shape, anti_locking));
  time_steps(state, solver);
  state.SetLabel(shape + ", " + anti_locking + ", " + std::to_string(threads) + " thread(s)");
}

// range(0): refinement (1 -> 1.2k particles, 4 -> 19k, 16 -> 307k); range(1): 0 elastic,
// 1 Tresca; range(2): threads.
BENCHMARK(BM_Step)
    ->ArgsProduct({{1, 4, 16}, {0, 1}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(1.0);

// The B-spline blocks with the ties of nearly empty nodes (mpm/core/basis_extension.hpp, the
// default) and without them (solver.outer_node_fraction 0, the step before the ties existed):
// what the ties cost per particle-step, side by side in one run.
void BM_StepTies(benchmark::State& state) {
  const double cell = 0.5 / static_cast<double>(state.range(0));
  const std::string shape = state.range(1) == 2 ? "quadratic_bspline" : "cubic_bspline";
  const bool ties = state.range(2) != 0;
  omp_set_num_threads(1);
  pfm::Case c = bearing_block(cell, false, shape);
  if (!ties) c.solver.outer_node_fraction = 0.0;
  pfm::MpmSolver solver(c);
  time_steps(state, solver);
  state.SetLabel(shape + (ties ? ", ties" : ", no ties") + ", 1 thread");
}

// range(0): refinement (4 -> 19k, 16 -> 307k); range(1): 0 linear, 1 uGIMP, 2 quadratic and
// 3 cubic B-splines; range(2): 0 no anti-locking, 1 B-bar; range(3): threads.
BENCHMARK(BM_StepShapes)
    ->ArgsProduct({{4, 16}, {0, 1, 2, 3}, {0, 1}, {1, 2}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(1.0);

// range(0): refinement (4 -> 19k, 16 -> 307k); range(1): 2 quadratic, 3 cubic B-splines;
// range(2): 0 without the ties, 1 with them.
BENCHMARK(BM_StepTies)
    ->ArgsProduct({{4, 16}, {2, 3}, {0, 1}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(1.0);

// A child process that keeps one core busy (a spinning loop) until it is killed: the job that
// shares the machine.
class BusyJob {
 public:
  BusyJob() : pid_(fork()) {
    if (pid_ == 0) {
      volatile unsigned long spin = 0;
      for (;;) spin = spin + 1;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(200));  // let it take its core
  }
  ~BusyJob() {
    if (pid_ > 0) {
      kill(pid_, SIGKILL);
      waitpid(pid_, nullptr, 0);
    }
  }
  BusyJob(const BusyJob&) = delete;
  BusyJob& operator=(const BusyJob&) = delete;

 private:
  pid_t pid_;
};

// Steps of the Tresca block beside a busy job, by the wall clock. range(0): refinement (1 ->
// 1.2k particles, 4 -> 19k); range(1): threads, 0 = the default (pfm::use_threads(0), which
// counts the cores the other jobs keep busy). Counter threads: the count used. The default must
// be no more than 10 % slower than one thread (issue 19): compare /0 with /1.
void BM_StepBesideABusyJob(benchmark::State& state) {
  const double cell = 0.5 / static_cast<double>(state.range(0));
  const BusyJob job;
  const int threads = pfm::use_threads(static_cast<int>(state.range(1)));
  pfm::MpmSolver solver(bearing_block(cell, false));
  for (int k = 0; k < 3; ++k) solver.step();
  for (auto _ : state) solver.step();
  state.counters["particles"] = static_cast<double>(solver.particles().size());
  state.counters["threads"] = threads;
  state.SetLabel(state.range(1) == 0 ? "default threads beside a busy job"
                                     : std::to_string(threads) + " thread(s) beside a busy job");
}
BENCHMARK(BM_StepBesideABusyJob)
    ->ArgsProduct({{1, 4}, {1, 2, 0}})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime()
    ->MinTime(1.0);

}  // namespace

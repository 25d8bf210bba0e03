#include "mpm/solver/run.hpp"

#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <memory>
#include <sstream>

#include "mpm/core/json_input.hpp"
#include "mpm/core/provenance.hpp"
#include "mpm/detect/loop_classes.hpp"
#include "mpm/solver/boundary_coupling.hpp"
#include "mpm/solver/checkpoint.hpp"
#include "mpm/solver/mpm_solver.hpp"
#include "mpm/step/output.hpp"
#include "mpm/step/run_driver.hpp"
#include "mpm/step/stage_timer.hpp"
#include "mpm/step/vtk_output.hpp"

namespace pfm {

namespace fs = std::filesystem;

namespace {

/// An output step's detected boundary: boundary_<step>.csv, the step of boundary.h5 (and of the
/// VTK series with output.vtk), and the loops' classes, recorded in the output's `entry`.
void write_boundary_output(OutputFolder& folder, const Case& c, BoundaryCoupling& coupling,
                           MpmSolver& solver,
                           std::unique_ptr<BoundarySeriesWriter>& boundary_writer,
                           std::unique_ptr<VtkSeriesWriter>& boundary_vtk, nlohmann::json& entry) {
  const DetectedBoundary& boundary = coupling.current_boundary(solver.step_view());
  char name[40];
  std::snprintf(name, sizeof name, "boundary_%08ld.csv", solver.step_count());
  write_file_atomically(folder.file(name), boundary_csv(boundary));
  std::vector<std::vector<Vec2>> loops;
  std::vector<bool> closed;
  for (const Contour& contour : boundary.contours) {
    loops.push_back(contour.points);
    closed.push_back(contour.closed);
  }
  if (!boundary_writer)
    boundary_writer = std::make_unique<BoundarySeriesWriter>(folder, c.output.compress);
  boundary_writer->write(solver.time(), solver.step_count(), loops, closed);
  if (c.output.vtk) {
    if (!boundary_vtk) boundary_vtk = std::make_unique<VtkSeriesWriter>(folder, "boundary");
    boundary_vtk->write(solver.time(), solver.step_count(), boundary_vtu(loops, closed));
  }
  entry["boundary"] = name;
  // What each loop is (loop_classes.hpp), counted at the output steps only (a hole's search
  // for a free disk and an island's contacts cost more than a step where they occur).
  const LoopClasses classes =
      classify_loops(boundary, solver.particles().position, coupling.initial_spacing());
  for (const auto& [kind, count] : classes.counts()) entry["loop_classes"][kind] = count;
}

/// An output step's nodal loads (output.nodal_loads): nodal_loads_<step>.csv, recorded in `entry`.
void write_nodal_loads(OutputFolder& folder, const Case& c, const BoundaryCoupling& coupling,
                       const MpmSolver& solver, nlohmann::json& entry) {
  // The forces applied in the last step (thesis figure 6.6), with the nodal masses then.
  std::ostringstream csv;
  csv << "node,i,j,x,y,fx,fy,mass\n";
  const int nnx = c.grid.n_nodes_x();
  for (const auto& f : coupling.nodal_forces()) {
    const int i = f.node % nnx, j = f.node / nnx;
    const Vec2 x = c.grid.node_position(i, j);
    csv << f.node << ',' << i << ',' << j << ',' << format_exact(x.x()) << ','
        << format_exact(x.y()) << ',' << format_exact(f.force.x()) << ','
        << format_exact(f.force.y()) << ','
        << format_exact(solver.grid_state().mass[static_cast<std::size_t>(f.node)]) << '\n';
  }
  char name[40];
  std::snprintf(name, sizeof name, "nodal_loads_%08ld.csv", solver.step_count());
  write_file_atomically(folder.file(name), csv.str());
  entry["nodal_loads"] = name;
}

/// run.json's summary of the detected boundary: the stages' seconds outside the step's, the
/// stress recovery's calls and seconds, the detector's counters, the loops' classes at the output
/// steps, and the particles that end the loads' intervals.
void summarise_detection(nlohmann::json& summary, const Case& c, const BoundaryCoupling& coupling,
                         const nlohmann::json& outputs, long recoveries, double recovery_seconds) {
  // The in-step parts of these run inside external_forces (the hook); detections for output
  // steps run outside the step.
  const CouplingTimes& ct = coupling.times();
  summary["stage_seconds"]["detect"] = ct.detect;
  summary["stage_seconds"]["bezier"] = ct.bezier;
  summary["stage_seconds"]["traction"] = ct.traction;
  if (!c.constraints.empty()) summary["stage_seconds"]["constraints"] = ct.constraint;
  summary["stress_recovery"] = {{"calls", recoveries}, {"seconds", recovery_seconds}};
  summary["detection"] = {{"calls", ct.detections},
                          {"seconds_per_call", ct.detections > 0 ? ct.detect / ct.detections : 0.0},
                          {"every_steps", c.detection->every_steps},
                          {"max_motion", c.detection->max_motion},
                          {"kept_calls", ct.kept},
                          {"most_loops", ct.most_loops},
                          {"bridged_calls", ct.bridged_detections},
                          {"bridges", ct.bridges},
                          {"spurious_loops_removed", ct.spurious_loops_removed},
                          {"guard_refinement_passes", ct.guard_refinement_passes}};
  // The loops' classes at the output steps, summed.
  nlohmann::json totals = nlohmann::json::object();
  for (const auto& entry : outputs) {
    if (!entry.contains("loop_classes")) continue;
    for (const auto& [kind, count] : entry["loop_classes"].items()) {
      totals[kind] = totals.value(kind, 0L) + count.get<long>();
    }
  }
  summary["detection"]["loop_classes_at_outputs"] = totals;
  nlohmann::json ends = nlohmann::json::array();
  for (const auto& ids : coupling.interval_particles()) ends.push_back({ids[0], ids[1]});
  if (coupling.has_surface_loads()) summary["load_interval_particles"] = ends;
}

/// run.json as a run starts: a new run's provenance and case, or for --restart the run.json in
/// the folder (read under the folder's lock: a restart that waited for another to end finds it
/// done, and refuses a completed run); "running", and the checkpoint settings --restart takes
/// again unless it is given others.
nlohmann::json running_run_json(const Case& c, const RunOptions& options, int threads) {
  nlohmann::json run;
  if (options.restart) {
    run = read_json_file(options.out_dir + "/run.json");
    if (run.value("status", "") == "completed")
      throw InputError("--restart " + options.out_dir +
                       ": the run has completed; nothing to restart");
    run["status"] = "running";
    run.erase("error");
  } else {
    run["provenance"] = provenance({{"case_file", c.file}}, options.command_line, threads);
    run["case"] = c.source;
    run["status"] = "running";
  }
  run["checkpoint"] = {{"steps", options.checkpoint_steps},
                       {"seconds", options.checkpoint_seconds}};
  return run;
}

/// The list of output steps a checkpoint keeps ("run/outputs"), each an object with its step (at
/// most `last_step`) and time; InputError naming the dataset otherwise.
nlohmann::json get_outputs(const CheckpointFile& file, long last_step) {
  nlohmann::json outputs = nlohmann::json::parse(file.text("run/outputs"), nullptr, false);
  bool valid = outputs.is_array();
  for (const auto& entry : valid ? outputs : nlohmann::json::array()) {
    valid = valid && entry.is_object() && entry.contains("step") && entry.contains("time") &&
            entry["step"].is_number_integer() && entry["time"].is_number() &&
            entry["step"].get<long>() >= 0 && entry["step"].get<long>() <= last_step;
  }
  if (!valid) file.fail("run/outputs", "is not the list of output steps before the checkpoint");
  return outputs;
}

/// The output series of a restarted run, rebuilt with its output steps up to the checkpoint
/// (`outputs`): the particles' and, with a detected boundary, the boundary's (HDF5, and VTK with
/// output.vtk).
void reopen_series(OutputFolder& folder, const Case& c, bool detection,
                   const nlohmann::json& outputs, std::unique_ptr<ParticleSeriesWriter>& particles,
                   std::unique_ptr<VtkSeriesWriter>& particles_vtk,
                   std::unique_ptr<BoundarySeriesWriter>& boundary,
                   std::unique_ptr<VtkSeriesWriter>& boundary_vtk) {
  std::vector<std::pair<double, long>> keep;
  for (const auto& entry : outputs)
    keep.emplace_back(entry.at("time").get<double>(), entry.at("step").get<long>());
  particles = std::make_unique<ParticleSeriesWriter>(folder, c.output.compress, keep);
  if (c.output.vtk) {
    particles_vtk = std::make_unique<VtkSeriesWriter>(folder, "particles", keep);
    if (detection) boundary_vtk = std::make_unique<VtkSeriesWriter>(folder, "boundary", keep);
  }
  if (detection) boundary = std::make_unique<BoundarySeriesWriter>(folder, c.output.compress, keep);
}

/// `c`, once check_run_length() has accepted its number of steps of `dt`.
const Case& length_checked(const Case& c, double dt) {
  check_run_length(c, dt);
  return c;
}

}  // namespace

/// Everything a run holds between its steps. The hooks call its members; it never moves.
struct MpmRun::State {
  State(const Case& case_spec, const RunOptions& run_options);
  State(const State&) = delete;
  State& operator=(const State&) = delete;

  void record() {
    series.record(solver.time(), solver.energy(), coupling.diagnostics(),
                  coupling.constraints().reports());
  }
  void save_checkpoint();
  void restore_checkpoint(const CheckpointFile& file);
  const std::vector<Stress>& recovered_stress();
  void write_output(ParticleSeriesWriter& writer);
  void set_hooks();

  const RunOptions options;
  ThreadGovernor governor;
  const int threads;
  const Case c;
  MpmSolver solver;  // may throw InputError: nothing created yet
  BoundaryCoupling coupling;
  OutputFolder folder;
  nlohmann::json run;
  TimeSeriesTable series;
  nlohmann::json outputs = nlohmann::json::array();
  std::unique_ptr<ParticleSeriesWriter> writer_owner;
  std::unique_ptr<BoundarySeriesWriter> boundary_writer;
  std::unique_ptr<VtkSeriesWriter> vtk_writer, boundary_vtk;  // with output.vtk
  double next_output, next_series;
  const long n_steps;
  // The stresses next to the boundary's known tractions, recovered (stress_recovery.hpp), at
  // output steps, once per step (the last output's serve final_particles.csv); timed apart from
  // the step's stages.
  double recovery_seconds = 0.0;
  long recoveries = 0;
  std::vector<Stress> recovered;
  long recovered_step = -1;
  std::chrono::steady_clock::time_point last_checkpoint;
  RunHooks hooks;
  RunDriver<MpmSolver> driver;
};

MpmRun::State::State(const Case& case_spec, const RunOptions& run_options)
    : options(run_options),
      governor(options.threads),
      threads(governor.threads()),
      c(case_spec),
      solver(c),
      coupling(length_checked(c, solver.dt())),
      folder(options.out_dir, output_folder_mode(options), options.restart ? "--restart" : "--out"),
      run(running_run_json(c, options, threads)),
      series(coupling.has_surface_loads(), c.loads.size(), reaction_names(c.boundary_conditions),
             c.constraints.size()),
      next_output(c.output.interval),
      next_series(c.output.timeseries_interval),
      n_steps(static_cast<long>(std::ceil(c.time.end_time / solver.dt() - 1e-9))),
      driver(solver, hooks, c, options, governor, folder, run, series, next_series, next_output) {
  if (options.restart) {
    // Nothing is touched until the checkpoint has been read and validated.
    restore_checkpoint(CheckpointFile::read(options.out_dir + "/checkpoint.h5"));
    run["restarts"].push_back({{"utc", utc_now()},
                               {"from_step", solver.step_count()},
                               {"command", options.command_line},
                               {"threads", threads}});
  }
  last_checkpoint = std::chrono::steady_clock::now();
  set_hooks();
}

void MpmRun::State::save_checkpoint() {
  CheckpointFile file;
  put_particles(file, solver.particles());
  put_solver_counters(file, solver.counters());
  coupling.save(file);
  file.put("run/next_output", next_output);
  file.put("run/next_series", next_series);
  file.put_text("run/timeseries", series.text());
  file.put_text("run/outputs", outputs.dump());
  // The HDF5 series as they are now, before the checkpoint that a restart rebuilds them to:
  // a kill during a later output step can leave the files themselves unreadable.
  if (writer_owner) writer_owner->copy_for_checkpoint(folder);
  if (boundary_writer) boundary_writer->copy_for_checkpoint(folder);
  file.write(folder.file("checkpoint.h5"));
}

void MpmRun::State::restore_checkpoint(const CheckpointFile& file) {
  // Every value as the case reader would check it (checkpoint.hpp): a damaged checkpoint is
  // refused with the dataset's name, never continued.
  get_particles(file, solver.mutable_particles());  // the case's fill is there to compare
  const SolverCounters n = get_solver_counters(file, c, solver.dt(), n_steps);
  solver.restore(n);
  coupling.attach(solver);
  coupling.restore(file, solver.step_view());
  const double past = n.time - n.dt;
  next_output = file.scalar("run/next_output", past, n.time + c.output.interval + n.dt);
  next_series = file.scalar("run/next_series", past, n.time + c.output.timeseries_interval + n.dt);
  const std::string& table = file.text("run/timeseries");
  const std::string header = series.text();
  if (table.compare(0, header.size(), header) != 0)
    file.fail("run/timeseries", "does not start with this run's column names");
  series.restore(table);
  outputs = get_outputs(file, n.step);
}

const std::vector<Stress>& MpmRun::State::recovered_stress() {
  if (!coupling.detection_enabled() || recovered_step == solver.step_count()) return recovered;
  StageTimer timer(recovery_seconds);
  ++recoveries;
  const std::vector<TractionSample> samples =
      coupling.traction_samples(solver.step_view(), solver.grid_state().fixed);
  recovered = recover_stress(solver.particles().position, solver.particles().stress, samples,
                             c.grid.cell_size);
  recovered_step = solver.step_count();
  return recovered;
}

void MpmRun::State::write_output(ParticleSeriesWriter& writer) {
  const std::vector<Stress>& recovered_now = recovered_stress();
  writer.write(solver.time(), solver.step_count(), solver.particles(), recovered_now);
  if (vtk_writer) {
    vtk_writer->write(solver.time(), solver.step_count(),
                      particles_vtu(solver.particles(), recovered_now));
  }
  nlohmann::json entry = {{"step", solver.step_count()}, {"time", solver.time()}};
  if (coupling.detection_enabled()) {
    write_boundary_output(folder, c, coupling, solver, boundary_writer, boundary_vtk, entry);
  }
  if (c.output.nodal_loads && coupling.has_surface_loads()) {
    write_nodal_loads(folder, c, coupling, solver, entry);
  }
  outputs.push_back(entry);
}

void MpmRun::State::set_hooks() {
  hooks.prepare_outputs = [this] {
    if (!options.restart) return;
    reopen_series(folder, c, coupling.detection_enabled(), outputs, writer_owner, vtk_writer,
                  boundary_writer, boundary_vtk);
  };
  hooks.start = [this] {
    if (!options.restart) {
      solver.initialise_stress();
      coupling.attach(solver);
      writer_owner = std::make_unique<ParticleSeriesWriter>(folder, c.output.compress);
      if (c.output.vtk) vtk_writer = std::make_unique<VtkSeriesWriter>(folder, "particles");
      write_output(*writer_owner);
      record();
    }
    last_checkpoint = std::chrono::steady_clock::now();
  };
  hooks.finished = [this] { return solver.step_count() >= n_steps; };
  hooks.record = [this] { record(); };
  hooks.output = [this] { write_output(*writer_owner); };
  hooks.recovered_stress = [this] { return recovered_stress(); };
  hooks.after_step = [this](bool last) {
    const bool by_steps =
        options.checkpoint_steps > 0 && solver.step_count() % options.checkpoint_steps == 0;
    const bool by_time = options.checkpoint_seconds > 0.0 &&
                         seconds_since(last_checkpoint) >= options.checkpoint_seconds;
    if ((by_steps || by_time) && !last) {
      save_checkpoint();
      last_checkpoint = std::chrono::steady_clock::now();
    }
  };
  hooks.close_writers = [this] {
    writer_owner.reset();  // closes the HDF5 files before run.json is marked
    boundary_writer.reset();
  };
  hooks.summarise = [this](nlohmann::json& ended) {
    if (coupling.detection_enabled()) {
      summarise_detection(ended["summary"], c, coupling, outputs, recoveries, recovery_seconds);
    }
    ended["outputs"] = outputs;
  };
}

MpmRun::MpmRun(const Case& c, const RunOptions& options)
    : state_(std::make_unique<State>(c, options)) {}

MpmRun::~MpmRun() = default;

void MpmRun::begin() {
  state_->driver.begin();
}
bool MpmRun::stepping() const {
  return state_->driver.stepping();
}
bool MpmRun::running() const {
  return state_->driver.running();
}
void MpmRun::step() {
  state_->driver.step();
}
int MpmRun::end() {
  const int status = state_->driver.end();
  // The run's files complete and the folder free, as when pfm-mpm exits.
  state_->writer_owner.reset();
  state_->boundary_writer.reset();
  state_->vtk_writer.reset();
  state_->boundary_vtk.reset();
  state_->folder.unlock();
  return status;
}
const std::string& MpmRun::stop_message() const {
  return state_->driver.message();
}
long MpmRun::n_steps() const {
  return state_->n_steps;
}
MpmSolver& MpmRun::solver() {
  return state_->solver;
}
BoundaryCoupling& MpmRun::coupling() {
  return state_->coupling;
}
const Case& MpmRun::case_spec() const {
  return state_->c;
}

int run_case(const Case& c, const RunOptions& options) {
  MpmRun run(c, options);
  run.begin();
  while (run.stepping()) run.step();
  return run.end();
}

}  // namespace pfm

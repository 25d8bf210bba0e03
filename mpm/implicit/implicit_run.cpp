#include "mpm/implicit/implicit_run.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <memory>
#include <string>

#include "mpm/core/exact_text.hpp"
#include "mpm/core/provenance.hpp"
#include "mpm/implicit/implicit_solver.hpp"
#include "mpm/step/output.hpp"
#include "mpm/step/prescribed_velocity.hpp"
#include "mpm/step/step_view.hpp"

namespace pfm {

namespace {

nlohmann::json step_log(const LoadStepLog& e) {
  return {{"time", e.time}, {"dt", e.dt}, {"converged", e.converged}, {"residuals", e.residuals}};
}

}  // namespace

int run_implicit_case(const Case& c, const RunOptions& options) {
  return run_implicit_case(c, options, ImplicitMeshRun{});
}

int run_implicit_case(const Case& c, const RunOptions& options, ImplicitMeshRun on_mesh) {
  ThreadGovernor governor(options.threads);
  ImplicitSolver solver(c, std::move(on_mesh.mesh));  // may throw InputError: nothing created yet
  OutputFolder folder(options.out_dir, output_folder_mode(options));
  nlohmann::json run;
  run["provenance"] = provenance({{"case_file", c.file}}, options.command_line, governor.threads());
  run["provenance"]["solver"] = on_mesh.solver;
  run["case"] = c.source;
  run["status"] = "running";
  std::unique_ptr<ParticleSeriesWriter> writer;
  // With strength_reduction, the factor of each step after the attempts; per constraint its
  // force on the body (kN/m) and root-mean-square gap (m), as the explicit run's columns.
  const bool reduction = c.implicit.strength_reduction.has_value();
  std::string table = "time,dt,iterations,residual,attempts";
  if (reduction) table += ",strength_factor";
  for (std::size_t k = 0; k < c.constraints.size(); ++k) {
    const std::string name = "constraint_" + std::to_string(k);
    table += ',' + name + "_fx," + name + "_fy," + name + "_gap";
  }
  for (const std::string& k : reaction_names(c.boundary_conditions))
    table += ",reaction_" + k + "_fx,reaction_" + k + "_fy";
  table += '\n';
  const auto wall_start = std::chrono::steady_clock::now();
  const double end = c.time.end_time;
  int status = kExitOk;
  std::string message;
  long steps = 0;
  nlohmann::json outputs = nlohmann::json::array();  // the mesh's files per output
  const auto write_output = [&] {
    writer->write(solver.time(), steps, solver.particles());
    if (on_mesh.output) outputs.push_back(on_mesh.output(folder, solver, steps));
  };
  try {
    const std::string text = run.dump(2) + "\n";
    write_file_atomically(folder.file("run.json"), text);
    folder.reserve(2 * text.size() + 65536);
    writer = std::make_unique<ParticleSeriesWriter>(folder, c.output.compress);
    RunProgress progress(options.progress);
    double next_output = c.output.interval;
    double written_at = 0.0;
    const double eps = 1e-9 * end;
    try {
      solver.initialise_stress();  // the gravity loading's load steps, before t = 0
      write_output();
      while (solver.time() < end - eps) {
        const std::size_t before = solver.log().size();
        solver.advance(end);
        if (solver.collapsed()) {  // the strength reduction's answer: the last step stands
          if (solver.time() > written_at) write_output();
          write_file_atomically(folder.file("timeseries.csv"), table);
          break;
        }
        ++steps;
        const LoadStepLog& e = solver.log().back();
        table += format_exact(e.time) + ',' + format_exact(e.dt) + ',' +
                 std::to_string(e.residuals.size() - 1) + ',' + format_exact(e.residuals.back()) +
                 ',' + std::to_string(solver.log().size() - before);
        if (reduction) table += ',' + format_exact(solver.strength_factor());
        for (const ConstraintReport& r : solver.constraint_reports()) {
          table += ',' + format_exact(r.force.x()) + ',' + format_exact(r.force.y()) + ',' +
                   format_exact(r.rms_gap);
        }
        for (const Vec2& r : solver.support_reactions())
          table += ',' + format_exact(r.x()) + ',' + format_exact(r.y());
        table += '\n';
        const bool last = solver.time() >= end - eps;
        if (solver.time() >= next_output - eps || last) {
          write_output();
          written_at = solver.time();
          write_file_atomically(folder.file("timeseries.csv"), table);
          while (next_output <= solver.time() + eps) next_output += c.output.interval;
        }
        governor.update();
        progress.update(steps, solver.time(), end);
      }
      write_file_atomically(folder.file("final_particles.csv"), particles_csv(solver.particles()));
    } catch (const SimulationError& e) {  // a step that did not converge, a particle off the grid
      status = note_simulation_stop(e, options.out_dir, message);
    }
    writer.reset();  // closes particles.h5 before run.json is final
    if (on_mesh.close) on_mesh.close();
  } catch (const IoError& e) {
    writer.reset();
    if (on_mesh.close) on_mesh.close();
    return fail_on_write_fault(folder, run, e);
  }
  const double wall =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - wall_start).count();
  long iterations = 0;
  nlohmann::json attempts = nlohmann::json::array();
  for (const LoadStepLog& e : solver.log()) {
    iterations += static_cast<long>(e.residuals.size()) - 1;
    attempts.push_back(step_log(e));
  }
  run["status"] = status == kExitOk ? "completed" : "failed";
  if (!message.empty()) run["error"] = message;
  run["provenance"]["finished_utc"] = utc_now();
  const double n_particles = static_cast<double>(solver.particles().size());
  run["summary"] = {{"solver", on_mesh.solver},
                    {"n_particles", solver.particles().size()},
                    {"n_steps", steps},
                    {"n_attempts", solver.log().size()},
                    {"n_iterations", iterations},
                    {"final_time_s", solver.time()},
                    {"wall_time_s", wall},
                    {"particle_steps_per_s", wall > 0.0 ? n_particles * steps / wall : 0.0},
                    {"threads", governor.summary()}};
  if (reduction) {
    // The factor of safety lies between the last converged factor and the failed one (none
    // when the run reached its final factor).
    run["summary"]["strength_reduction"] = {
        {"collapsed", solver.collapsed()},
        {"last_converged_factor", solver.strength_factor()},
        {"failed_factor", solver.collapsed() ? nlohmann::json(solver.failed_factor()) : nullptr}};
  }
  if (on_mesh.summarise) {
    on_mesh.summarise(run["summary"]);
    run["outputs"] = outputs;
  }
  run["load_steps"] = attempts;
  if (c.initial_stress.method == InitialStressMethod::kGravity) {
    nlohmann::json settling = nlohmann::json::array();
    for (const LoadStepLog& e : solver.initial_stress_log()) settling.push_back(step_log(e));
    run["initial_stress_load_steps"] = settling;
    run["summary"]["n_initial_stress_steps"] =
        std::count_if(settling.begin(), settling.end(),
                      [](const nlohmann::json& e) { return e["converged"].get<bool>(); });
  }
  return finish_run(folder, run, table, options, status);
}

}  // namespace pfm

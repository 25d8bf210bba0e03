// `pfm-mpm run` of a case with solver.type "implicit" (implicit_solver.hpp).
#pragma once

#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>

#include "mpm/core/output_folder.hpp"
#include "mpm/implicit/implicit_solver.hpp"
#include "mpm/step/case.hpp"
#include "mpm/step/run_support.hpp"

namespace pfm {

/// Runs the case's load steps to time.end_time and writes into options.out_dir:
///   run.json         provenance, the case, the status ("completed" or "failed" with the
///                    error), the summary (n_particles, n_steps = converged load steps,
///                    n_attempts, n_iterations, final_time_s, wall_time_s,
///                    particle_steps_per_s) and load_steps: every attempt of every step with
///                    its time, dt, whether it converged and its relative residuals; with
///                    initial_stress "gravity" also initial_stress_load_steps, those of the
///                    settling under gravity before t = 0 (summary n_initial_stress_steps);
///   timeseries.csv   one row per converged load step: time, dt, iterations, residual (the
///                    last relative residual), attempts (1 + the step's cut-backs); with a
///                    strength reduction its factor, per constraint constraint_<k>_fx, _fy,
///                    _gap, per moving support reaction_<k>_fx, _fy (kN/m, the force on the
///                    body, k its index in boundary_conditions);
///   particles.h5/.xdmf at t = 0 and at every output.interval (and the last step), the
///                    particle fields of the explicit run (output.hpp);
///   final_particles.csv.
/// Returns kExitOk, kExitSimulationError when a step does not converge after
/// implicit.max_cuts halvings (the outputs so far kept, run.json "failed" naming the step, its
/// size and its residuals) or a particle leaves the grid, kExitIoError on a write fault.
/// Throws InputError (nothing created) for a case the solver refuses.
int run_implicit_case(const Case& c, const RunOptions& options);

/// What a run on a mesh adds (the implicit UL-FEM, fem_reference/ulfem/ulfem_implicit.hpp).
struct ImplicitMeshRun {
  std::unique_ptr<ImplicitMesh> mesh;
  /// run.json's provenance.solver and summary.solver.
  std::string solver = "implicit";
  /// At t = 0 and at each output, after the points: the mesh's own files; returns run.json's
  /// "outputs" entry for them.
  std::function<nlohmann::json(OutputFolder& folder, const ImplicitSolver& solver, long step)>
      output;
  /// Closes its files, before run.json is final.
  std::function<void()> close;
  /// Its lines in run.json's summary.
  std::function<void(nlohmann::json& summary)> summarise;
};

/// run_implicit_case on the mesh's nodes, with its outputs and its summary.
int run_implicit_case(const Case& c, const RunOptions& options, ImplicitMeshRun on_mesh);

}  // namespace pfm

// pfm-mpm: the command-line tool.
//
//   pfm-mpm run CASE.json --out DIR [--overwrite] [--solver mpm|ulfem] [--threads N] [--quiet]
//               (a case with solver.type "implicit" runs the implicit quasi-static MPM, or
//               with --solver ulfem the implicit UL-FEM)
//               [--checkpoint-steps N] [--checkpoint-seconds T]
//   pfm-mpm run --restart DIR [--threads N]      continue a killed run from its checkpoint
//   pfm-mpm validate CASE.json
//   pfm-mpm detect PARTICLES.csv --config DETECT.json --out DIR [--overwrite] [--threads N]
//
// Exit codes (mpm/solver/run.hpp): 0 success; 2 bad input or a refused request (nothing
// written or removed); 3 the simulation stopped (NaN, CFL, a particle leaving the grid), the
// outputs up to the last good step kept; 4 a write failed or memory ran out (run.json marked
// "failed" when it can be, the last checkpoint kept); 1 only for an unforeseen error (a bug).
#include <hdf5.h>

#include <CLI/CLI.hpp>
#include <filesystem>
#include <iostream>
#include <new>

#include "fem_reference/ulfem/ulfem_run.hpp"
#include "mpm/core/heap_policy.hpp"
#include "mpm/core/json_input.hpp"
#include "mpm/core/provenance.hpp"
#include "mpm/detect/detect_command.hpp"
#include "mpm/implicit/implicit_run.hpp"
#include "mpm/implicit/implicit_solver.hpp"
#include "mpm/solver/mpm_solver.hpp"
#include "mpm/solver/run.hpp"

namespace {

// `pfm-mpm run` of a new case by the solver --solver names, the MPM or the UL-FEM, each explicit
// or, for solver.type "implicit", implicit.
int run_new_case(const pfm::Case& c, const std::string& solver_name,
                 const pfm::RunOptions& options) {
  if (solver_name == "ulfem") return pfm::run_ulfem_case(c, options);
  if (c.solver.type == pfm::SolverType::kImplicit) return pfm::run_implicit_case(c, options);
  return pfm::run_case(c, options);
}

}  // namespace

int main(int argc, char** argv) {
  // HDF5's own exit handler closes files again that a failed write left half-closed, and
  // crashes doing so; every file is closed by its writer, so the handler is not needed.
  H5dont_atexit();
  pfm::keep_freed_memory();  // scratch freed by a step or a detection is reused, not refaulted
  CLI::App app{"pfm-mpm: MPM with moving-boundary detection and loads (units kN, m, s, t, kPa)"};
  app.set_version_flag("--version", pfm::version_line());
  app.require_subcommand(1);
  std::string command_line;
  for (int k = 0; k < argc; ++k) command_line += (k ? " " : "") + std::string(argv[k]);

  pfm::RunOptions options;
  options.command_line = command_line;
  std::string case_file;
  bool quiet = false;
  CLI::App* run = app.add_subcommand("run", "run a case file");
  std::string restart_dir;
  run->add_option("case", case_file, "case file (JSON)");
  run->add_option("--out", options.out_dir, "output directory");
  run->add_option("--restart", restart_dir,
                  "continue the run in this output directory from its latest checkpoint");
  run->add_option("--checkpoint-steps", options.checkpoint_steps,
                  "write checkpoint.h5 every N steps (default: off)")
      ->check(CLI::Range(0L, 1000000000L));
  run->add_option("--checkpoint-seconds", options.checkpoint_seconds,
                  "write checkpoint.h5 every T seconds of wall time (default 600, 0: off)")
      ->check(CLI::Range(0.0, 1e9));
  run->add_option("--threads", options.threads, "threads (default: all cores)")
      ->check(CLI::Range(1, 1024));
  run->add_flag("--quiet", quiet, "no progress line");
  run->add_flag("--overwrite", options.overwrite,
                "write into a folder that holds other files (they are kept; only this "
                "program's earlier files are replaced)");
  std::string solver_name = "mpm";
  run->add_option("--solver", solver_name,
                  "mpm (default) or ulfem (updated-Lagrangian FEM on a gmsh mesh)")
      ->check(CLI::IsMember({"mpm", "ulfem"}));

  std::string particles_csv, detect_config, detect_out;
  CLI::App* detect = app.add_subcommand("detect", "detect the boundary of a particle file");
  detect->add_option("particles", particles_csv, "particle CSV with x,y,volume[,F11..F22]")
      ->required();
  detect->add_option("--config", detect_config, "detector configuration (JSON)")->required();
  detect->footer(
      "Configuration keys (every key, unit and default: mpm/detect/README.md; an example: "
      "cases/detect/improved.json):\n"
      "  method            \"improved\" (default), \"pfm\" (the thesis), \"smm\", \"vof\", "
      "\"density\"\n"
      "  improved, pfm, smm, vof, density   the chosen method's settings, e.g. improved: "
      "profile, radius_factor, level, guard_factor, refinement, narrow_band, neighbour_shape, "
      "max_stretch, spurious_loops\n"
      "  initial_spacing   m, the particles' spacing in the reference state (default: sqrt of "
      "the median volume)\n"
      "  grid              {origin, cell_size, n_cells} (default: cell 2 x spacing around the "
      "particles)\n"
      "Without F11..F22 columns every particle's F is taken as the identity (a warning says "
      "so).");
  detect->add_option("--out", detect_out, "output directory")->required();
  int detect_threads = 0;
  bool detect_overwrite = false;
  detect->add_flag("--overwrite", detect_overwrite,
                   "write into a folder that holds other files (they are kept)");
  detect->add_option("--threads", detect_threads, "threads (default: all cores)")
      ->check(CLI::Range(1, 1024));

  std::string validate_file;
  CLI::App* validate = app.add_subcommand("validate", "check a case file and exit");
  validate->add_option("case", validate_file, "case file (JSON)")->required();

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    const int code = app.exit(e);
    return code == 0 ? 0 : pfm::kExitInputError;
  }

  try {
    if (*validate) {
      const pfm::Case c = pfm::read_case(validate_file);
      if (c.solver.type == pfm::SolverType::kImplicit) {
        pfm::ImplicitSolver solver(c);  // checks that need the particles, refusals
        std::cout << validate_file << ": valid (" << solver.particles().size()
                  << " particles, implicit, " << c.implicit.load_steps << " load steps)\n";
        return pfm::kExitOk;
      }
      pfm::MpmSolver solver(c);  // checks that need the particles (empty bodies, time step)
      std::cout << validate_file << ": valid (" << solver.particles().size() << " particles, dt "
                << solver.dt() << " s)\n";
      return pfm::kExitOk;
    }
    if (*detect) {
      return pfm::run_detect_command(particles_csv, detect_config, detect_out, detect_threads,
                                     command_line, detect_overwrite);
    }
    options.progress = !quiet;
    if (!restart_dir.empty()) {
      if (!case_file.empty() || !options.out_dir.empty())
        throw pfm::InputError("--restart DIR takes the case and the output directory from DIR");
      if (solver_name != "mpm") throw pfm::InputError("--restart: only the MPM solver restarts");
      if (options.overwrite) throw pfm::InputError("--restart continues a run: no --overwrite");
      const nlohmann::json run_json = pfm::read_json_file(restart_dir + "/run.json");
      if (!run_json.contains("case") || !run_json.contains("provenance"))
        throw pfm::InputError(restart_dir + "/run.json: not a pfm-mpm run (no case)");
      const pfm::Case c =
          pfm::parse_case(run_json.at("case"), run_json.at("provenance").value("case_file", ""));
      // The original run's checkpoint settings, unless the restart gives its own.
      const nlohmann::json saved = run_json.value("checkpoint", nlohmann::json::object());
      if (run->count("--checkpoint-steps") == 0)
        options.checkpoint_steps = saved.value("steps", options.checkpoint_steps);
      if (run->count("--checkpoint-seconds") == 0)
        options.checkpoint_seconds = saved.value("seconds", options.checkpoint_seconds);
      options.out_dir = restart_dir;
      options.restart = true;
      const int status = pfm::run_case(c, options);
      if (status == pfm::kExitOk) std::cout << "results: " << options.out_dir << "\n";
      return status;
    }
    if (case_file.empty() || options.out_dir.empty())
      throw pfm::InputError("run: give CASE.json and --out DIR (or --restart DIR)");
    const int status = run_new_case(pfm::read_case(case_file), solver_name, options);
    if (status == pfm::kExitOk) std::cout << "results: " << options.out_dir << "\n";
    return status;
  } catch (const pfm::InputError& e) {
    std::cerr << "pfm-mpm: error: " << e.what() << "\n";
    return pfm::kExitInputError;
  } catch (const pfm::SimulationError& e) {
    std::cerr << "pfm-mpm: simulation error: " << e.what() << "\n";
    return pfm::kExitSimulationError;
  } catch (const pfm::IoError& e) {
    std::cerr << "pfm-mpm: write failed: " << e.what() << "\n";
    return pfm::kExitIoError;
  } catch (const std::filesystem::filesystem_error& e) {
    std::cerr << "pfm-mpm: file system error: " << e.what() << "\n";
    return pfm::kExitIoError;
  } catch (const std::bad_alloc&) {
    std::cerr << "pfm-mpm: out of memory (a smaller grid or fewer particles?)\n";
    return pfm::kExitIoError;
  } catch (const std::exception& e) {
    std::cerr << "pfm-mpm: internal error (please report it): " << e.what() << "\n";
    return pfm::kExitInternalError;
  }
}

#include "fem_reference/ulfem/ulfem_run.hpp"

#include <hdf5.h>

#include <cerrno>
#include <cstdio>
#include <memory>
#include <sstream>

#include "fem_reference/ulfem/ulfem_implicit.hpp"
#include "fem_reference/ulfem/ulfem_solver.hpp"
#include "mpm/core/provenance.hpp"
#include "mpm/step/hdf5_untimed.hpp"
#include "mpm/step/output.hpp"
#include "mpm/step/run_driver.hpp"
#include "mpm/step/vtk_output.hpp"

namespace pfm::ulfem {

std::string boundary_csv(const QuadMesh& mesh, const std::vector<Vec2>& positions) {
  std::ostringstream out;
  out << "loop,x,y\n";
  const auto loops = boundary_loops(mesh, positions);
  for (std::size_t k = 0; k < loops.size(); ++k) {
    for (int n : loops[k]) {
      const Vec2& x = positions[static_cast<std::size_t>(n)];
      out << k << ',' << format_exact(x.x()) << ',' << format_exact(x.y()) << '\n';
    }
  }
  return out.str();
}

namespace {

// The element fields of mesh.h5: the stress components in Voigt order (kXX, kYY, kXY, kZZ),
// then eps_p.
constexpr const char* kCellFields[] = {"sxx", "syy", "sxy", "szz", "eps_p"};

}  // namespace

MeshSeriesWriter::MeshSeriesWriter(OutputFolder& folder, const QuadMesh& mesh, bool compress)
    : h5_path_(folder.file("mesh.h5")),
      xdmf_path_(folder.file("mesh.xdmf")),
      compress_(compress),
      n_nodes_(mesh.n_nodes()),
      n_elements_(mesh.n_elements()) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  file_ = H5Fcreate(h5_path_.c_str(), H5F_ACC_TRUNC, UntimedCreation(H5P_FILE_CREATE).get(),
                    H5P_DEFAULT);
  if (file_ < 0) throw_io_error("cannot create", h5_path_, errno);
  std::vector<long long> topology;
  for (const auto& element : mesh.element_nodes) {
    for (int n : element) topology.push_back(n);
  }
  write_h5_dataset(static_cast<hid_t>(file_), h5_path_, "topology", topology, n_elements_, 4,
                   compress_);
}

MeshSeriesWriter::~MeshSeriesWriter() {
  if (file_ >= 0) H5Fclose(static_cast<hid_t>(file_));
}

void MeshSeriesWriter::write(double time, long step, const std::vector<Vec2>& position,
                             const std::vector<Vec2>& displacement,
                             const std::vector<Vec2>& velocity, const Particles& points) {
  const H5Handle group(create_step_group(static_cast<hid_t>(file_), h5_path_, step, time),
                       H5Gclose);
  std::vector<double> buffer(3 * n_nodes_, 0.0);
  auto put = [&](const std::vector<Vec2>& v, const char* dataset) {
    for (std::size_t n = 0; n < n_nodes_; ++n) {
      buffer[3 * n] = v[n].x();
      buffer[3 * n + 1] = v[n].y();
      buffer[3 * n + 2] = 0.0;
    }
    write_h5_dataset(group.get(), h5_path_, dataset, buffer, n_nodes_, 3, compress_);
  };
  put(position, "geometry");
  put(displacement, "displacement");
  put(velocity, "velocity");
  // Per element: the volume-weighted means over its four Gauss points.
  std::vector<double> mean(n_elements_);
  for (int k = 0; k < 5; ++k) {
    for (std::size_t e = 0; e < n_elements_; ++e) {
      double sum = 0.0, volume = 0.0;
      for (std::size_t p = 4 * e; p < 4 * e + 4; ++p) {
        sum += points.volume[p] * (k < 4 ? points.stress[p][k] : points.state[p].plastic_strain);
        volume += points.volume[p];
      }
      mean[e] = sum / volume;
    }
    write_h5_dataset(group.get(), h5_path_, kCellFields[k], mean, n_elements_, 1, compress_);
  }
  end_series_step(static_cast<hid_t>(file_), h5_path_, step, time, times_, groups_);
  write_xdmf();
}

void MeshSeriesWriter::write_xdmf() const {
  std::string x = xdmf::open("mesh");
  for (std::size_t s = 0; s < times_.size(); ++s) {
    const std::string at = "mesh.h5:/" + groups_[s] + "/";
    x += xdmf::step(groups_[s], times_[s]);
    x += xdmf::topology(
        "Quadrilateral", n_elements_, 0,
        xdmf::data_item(std::to_string(n_elements_) + " 4", true, "mesh.h5:/topology"));
    x += xdmf::geometry(n_nodes_, at + "geometry");
    for (const char* name : kCellFields) {
      x += xdmf::attribute(name, false, true, n_elements_, false, at + name);
    }
    for (const char* vector_name : {"displacement", "velocity"}) {
      x += xdmf::attribute(vector_name, true, false, n_nodes_, false, at + vector_name);
    }
    x += xdmf::kEndStep;
  }
  x += xdmf::kClose;
  write_file_atomically(xdmf_path_, x);
}

int run_ulfem_case(const Case& c, const RunOptions& options) {
  if (c.solver.type == SolverType::kImplicit) return run_ulfem_implicit_case(c, options);
  ThreadGovernor governor(options.threads);
  const int threads = governor.threads();
  UlFemSolver solver(c);  // may throw InputError: nothing created yet
  check_run_length(c, solver.dt());
  OutputFolder folder(options.out_dir, output_folder_mode(options));

  nlohmann::json run;
  run["provenance"] = provenance({{"case_file", c.file}}, options.command_line, threads);
  run["provenance"]["solver"] = "ulfem";
  run["case"] = c.source;
  run["status"] = "running";
  // The MPM's columns (mpm/solver/run.cpp); with loads also its load diagnostics, summed over
  // every load of the case (the UL-FEM applies them all on the mesh edges, nothing is lost).
  TimeSeriesTable series(!c.loads.empty(), c.loads.size(), reaction_names(c.boundary_conditions));
  nlohmann::json outputs = nlohmann::json::array();
  std::unique_ptr<ParticleSeriesWriter> particle_writer;
  std::unique_ptr<MeshSeriesWriter> mesh_writer;
  std::unique_ptr<VtkSeriesWriter> vtk_writer;
  double next_output = c.output.interval, next_series = c.output.timeseries_interval;
  // The step may shrink as elements are crushed (UlFemSolver::dt), so the run ends on time,
  // to 1e-9 of the step after the initial stress.
  const double end = c.time.end_time;
  double eps = 0.0;

  RunHooks hooks;
  hooks.record = [&] { series.record(solver.time(), solver.energy(), solver.load_diagnostics()); };
  hooks.output = [&] {
    const double t = solver.time();
    particle_writer->write(t, solver.step_count(), solver.particles());
    if (vtk_writer) vtk_writer->write(t, solver.step_count(), particles_vtu(solver.particles()));
    mesh_writer->write(t, solver.step_count(), solver.node_position(), solver.node_displacement(),
                       solver.node_state().velocity, solver.particles());
    char name[48];
    std::snprintf(name, sizeof name, "boundary_%08ld.csv", solver.step_count());
    write_file_atomically(folder.file(name), boundary_csv(solver.mesh(), solver.node_position()));
    outputs.push_back({{"step", solver.step_count()}, {"time", t}, {"boundary", name}});
  };
  hooks.start = [&] {
    solver.initialise_stress();
    eps = 1e-9 * solver.dt();
    particle_writer = std::make_unique<ParticleSeriesWriter>(folder, c.output.compress);
    mesh_writer = std::make_unique<MeshSeriesWriter>(folder, solver.mesh(), c.output.compress);
    if (c.output.vtk) vtk_writer = std::make_unique<VtkSeriesWriter>(folder, "particles");
    hooks.output();
    hooks.record();
  };
  hooks.finished = [&] { return solver.time() >= end - eps; };
  hooks.close_writers = [&] {
    particle_writer.reset();  // closes the HDF5 files before run.json is marked
    mesh_writer.reset();
    vtk_writer.reset();
  };
  hooks.summarise = [&](nlohmann::json& ended) {
    ended["summary"]["solver"] = "ulfem";
    ended["summary"]["mesh"] = {{"generator", solver.mesh().generator},
                                {"n_elements", solver.mesh().n_elements()},
                                {"n_nodes", solver.mesh().n_nodes()}};
    ended["outputs"] = outputs;
  };
  return drive_run(solver, hooks, c, options, governor, folder, run, series, next_series,
                   next_output);
}

}  // namespace pfm::ulfem

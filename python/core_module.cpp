// pfm_mpm._core: the C++ core seen from Python (python/README.md). Thin: every function converts
// numpy arrays and JSON text to the core's types, calls one core function and converts back.
// Bad input raises pfm_mpm.InputError (a ValueError) with the core's message (file and JSON
// pointer). Units as in the core: kN, m, s, t, kPa.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <chrono>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "mpm/boundary/bezier.hpp"
#include "mpm/boundary/load_input.hpp"
#include "mpm/boundary/surface_load.hpp"
#include "mpm/core/json_input.hpp"
#include "mpm/core/output_folder.hpp"
#include "mpm/core/provenance.hpp"
#include "mpm/detect/detect_command.hpp"
#include "mpm/detect/detector.hpp"
#include "mpm/solver/boundary_coupling.hpp"
#include "mpm/solver/mpm_solver.hpp"
#include "mpm/solver/run.hpp"
#include "mpm/step/case.hpp"
#include "mpm/step/step_view.hpp"

namespace py = pybind11;
using nlohmann::json;

namespace {

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

// Grid from {"origin": [x, y], "cell_size": h, "n_cells": [nx, ny]}, as pfm-mpm detect's.
pfm::Grid grid_from_json(const std::string& text) {
  const json document = json::parse(text);
  return pfm::parse_detection_grid(pfm::JsonView(document, "<grid>"));
}

std::vector<pfm::Vec2> points_from(const Array& a, const char* name) {
  if (a.ndim() != 2 || a.shape(1) != 2) {
    throw pfm::InputError(std::string(name) + ": expected an array of shape (n, 2)");
  }
  std::vector<pfm::Vec2> out(static_cast<std::size_t>(a.shape(0)));
  const auto r = a.unchecked<2>();
  for (py::ssize_t k = 0; k < a.shape(0); ++k) out[k] = pfm::Vec2(r(k, 0), r(k, 1));
  return out;
}

Array array_from(const std::vector<pfm::Vec2>& points) {
  Array out({static_cast<py::ssize_t>(points.size()), py::ssize_t{2}});
  auto w = out.mutable_unchecked<2>();
  for (std::size_t k = 0; k < points.size(); ++k) {
    w(k, 0) = points[k].x();
    w(k, 1) = points[k].y();
  }
  return out;
}

py::list loops_of(const pfm::DetectedBoundary& boundary) {
  py::list loops;
  for (const pfm::Contour& c : boundary.contours) {
    loops.append(py::make_tuple(array_from(c.points), c.closed));
  }
  return loops;
}

std::string read_case_json(const std::string& path) {
  return pfm::resolved_case(pfm::read_case(path)).dump();
}

// The case given as JSON text; `file` names it in messages and resolves relative paths.
pfm::Case case_from_text(const std::string& text, const std::string& file) {
  json document;
  try {
    document = json::parse(text);
  } catch (const json::parse_error& e) {
    throw pfm::InputError(file + ": not valid JSON: " + e.what());
  }
  return pfm::parse_case(document, file);
}

std::string parse_case_json(const std::string& text, const std::string& file) {
  return pfm::resolved_case(case_from_text(text, file)).dump();
}

py::list detect(const Array& position, const Array& volume, double initial_spacing,
                const std::string& grid_json, const std::string& config_json,
                const std::optional<Array>& deformation_gradient) {
  const std::vector<pfm::Vec2> x = points_from(position, "position");
  if (volume.ndim() != 1 || static_cast<std::size_t>(volume.shape(0)) != x.size()) {
    throw pfm::InputError("volume: expected an array of shape (n,) with n = len(position)");
  }
  const std::vector<double> v(volume.data(), volume.data() + volume.shape(0));
  std::vector<pfm::Mat2> f;
  if (deformation_gradient) {
    const Array& a = *deformation_gradient;
    if (a.ndim() != 3 || static_cast<std::size_t>(a.shape(0)) != x.size() || a.shape(1) != 2 ||
        a.shape(2) != 2) {
      throw pfm::InputError("deformation_gradient: expected an array of shape (n, 2, 2)");
    }
    const auto r = a.unchecked<3>();
    f.resize(x.size());
    for (std::size_t k = 0; k < x.size(); ++k) {
      f[k] << r(k, 0, 0), r(k, 0, 1), r(k, 1, 0), r(k, 1, 1);
    }
  }
  const pfm::Grid grid = grid_from_json(grid_json);
  const json config_document = json::parse(config_json);
  const pfm::DetectorConfig config =
      pfm::parse_detector_config(pfm::JsonView(config_document, "<config>"));
  pfm::ParticleCloud cloud{x, v, f, initial_spacing};
  pfm::DetectorState state;
  pfm::DetectedBoundary boundary;
  {
    py::gil_scoped_release release;
    boundary = pfm::detect(cloud, grid, config, state);
  }
  return loops_of(boundary);
}

// A composite curve's segments as (n_segments, 4, 2) control points (unused rows zero) and
// their degrees.
py::tuple composite_bezier(const Array& points, bool closed, const std::string& kind) {
  pfm::Contour contour{points_from(points, "points"), closed};
  pfm::boundary::CurveKind curve;
  try {
    curve = pfm::boundary::curve_kind_from_name(kind);
  } catch (const std::exception&) {
    throw pfm::InputError("kind: expected linear, quadratic, cubic or catmull_rom, got \"" + kind +
                          "\"");
  }
  const pfm::boundary::CompositeBezier bezier =
      pfm::boundary::make_composite_bezier(contour, curve);
  const auto n = static_cast<py::ssize_t>(bezier.segments.size());
  Array control({n, py::ssize_t{4}, py::ssize_t{2}});
  py::array_t<int> degree(n);
  auto w = control.mutable_unchecked<3>();
  auto d = degree.mutable_unchecked<1>();
  for (py::ssize_t s = 0; s < n; ++s) {
    const pfm::boundary::BezierSegment& segment = bezier.segments[s];
    d(s) = segment.degree;
    for (int k = 0; k < 4; ++k) {
      const pfm::Vec2 p = k <= segment.degree ? segment.control[k] : pfm::Vec2::Zero();
      w(s, k, 0) = p.x();
      w(s, k, 1) = p.y();
    }
  }
  return py::make_tuple(control, degree, bezier.closed);
}

pfm::boundary::CompositeBezier curve_from(const Array& control, const py::array_t<int>& degree,
                                          bool closed) {
  if (control.ndim() != 3 || control.shape(1) != 4 || control.shape(2) != 2 || degree.ndim() != 1 ||
      degree.shape(0) != control.shape(0)) {
    throw pfm::InputError("curve: expected control (n, 4, 2) and degree (n,)");
  }
  pfm::boundary::CompositeBezier curve;
  curve.closed = closed;
  const auto r = control.unchecked<3>();
  const auto d = degree.unchecked<1>();
  for (py::ssize_t s = 0; s < control.shape(0); ++s) {
    if (d(s) < 1 || d(s) > 3) throw pfm::InputError("curve: a degree must be 1, 2 or 3");
    pfm::boundary::BezierSegment segment;
    segment.degree = d(s);
    for (int k = 0; k <= segment.degree; ++k)
      segment.control[k] = pfm::Vec2(r(s, k, 0), r(s, k, 1));
    curve.segments.push_back(segment);
  }
  return curve;
}

// Nodal forces (n_nodes, 2) of a detected-boundary load entry (the case file's loads[] schema)
// on the curves, and the result's totals.
py::tuple nodal_forces(const std::string& grid_json, const py::list& curves,
                       const std::string& load_json, double load_factor, int shape_degree,
                       const std::optional<Array>& node_mass) {
  const pfm::Grid grid = grid_from_json(grid_json);
  const json document = json::parse(load_json);
  const pfm::boundary::BoundaryLoadSpec spec =
      pfm::boundary::parse_boundary_load(pfm::JsonView(document, "<load>"));
  if (shape_degree < 1 || shape_degree > 3) {
    throw pfm::InputError("shape_degree: expected 1, 2 or 3");
  }
  std::vector<pfm::boundary::CompositeBezier> beziers;
  for (const py::handle item : curves) {
    const auto t = item.cast<py::tuple>();
    beziers.push_back(
        curve_from(t[0].cast<Array>(), t[1].cast<py::array_t<int>>(), t[2].cast<bool>()));
  }
  const auto n_nodes = static_cast<std::size_t>(grid.n_nodes());
  std::vector<double> mass;
  if (node_mass) {
    if (node_mass->ndim() != 1 || static_cast<std::size_t>(node_mass->shape(0)) != n_nodes) {
      throw pfm::InputError("node_mass: expected an array of shape (n_nodes,)");
    }
    mass.assign(node_mass->data(), node_mass->data() + n_nodes);
  }
  std::vector<pfm::Vec2> force(n_nodes, pfm::Vec2::Zero());
  pfm::boundary::BoundaryLoadIntegrator integrator(grid, shape_degree);
  const pfm::boundary::BoundaryLoadResult result =
      integrator.integrate(beziers, spec, load_factor, mass, force);
  py::dict totals;
  totals["total_force"] = py::make_tuple(result.total_force.x(), result.total_force.y());
  totals["exact_force"] = py::make_tuple(result.exact_force.x(), result.exact_force.y());
  totals["off_grid_force"] = py::make_tuple(result.off_grid_force.x(), result.off_grid_force.y());
  totals["lost_force"] = py::make_tuple(result.lost_force.x(), result.lost_force.y());
  totals["n_loaded_nodes"] = result.n_loaded_nodes;
  totals["n_lost_nodes"] = result.n_lost_nodes;
  return py::make_tuple(array_from(force), totals);
}

// A run of the explicit MPM driven from Python (pfm_mpm.Simulation): pfm::MpmRun, begun when
// built. The particle arrays are numpy views of the run's own (the run's particles never move
// in memory: none are added or removed after the start); each view keeps the run alive.
class Simulation {
 public:
  Simulation(const pfm::Case& c, const pfm::RunOptions& options)
      : out_(options.out_dir), run_(std::make_shared<pfm::MpmRun>(c, options)) {
    {
      py::gil_scoped_release release;
      run_->begin();
    }
    raise_if_stopped();
  }

  // Up to n steps, fewer at the case's end time; Ctrl-C (or any Python signal handler's
  // exception) interrupts between steps and leaves the run as it is.
  long step(long n) {
    if (n < 0) throw pfm::InputError("step: n must be >= 0, got " + std::to_string(n));
    long done = 0;
    while (done < n && run().stepping()) {
      {
        py::gil_scoped_release release;
        const auto start = std::chrono::steady_clock::now();
        do {
          run_->step();
          ++done;
        } while (done < n && run_->stepping() &&
                 std::chrono::steady_clock::now() - start < std::chrono::milliseconds(200));
      }
      raise_if_stopped();
      if (PyErr_CheckSignals() != 0) throw py::error_already_set();
    }
    return done;
  }

  int finish() {
    py::gil_scoped_release release;
    return run().end();
  }

  // The detector of the case's detection block (default: the improved detector) on the points
  // now, with a state of its own: the run's detections are not touched.
  py::list detect() {
    pfm::MpmSolver& solver = run().solver();
    const pfm::Particles& p = solver.particles();
    const pfm::Case& c = run_->case_spec();
    const pfm::DetectorConfig config = c.detection ? c.detection->detector : pfm::DetectorConfig{};
    pfm::ParticleCloud cloud{p.position, p.volume, p.deformation_gradient,
                             run_->coupling().initial_spacing()};
    pfm::DetectorState state;
    pfm::DetectedBoundary boundary;
    {
      py::gil_scoped_release release;
      boundary = pfm::detect(cloud, c.grid, config, state);
    }
    return loops_of(boundary);
  }

  // A view of one particle field: `components` doubles per particle, in the shape and strides
  // given (bytes), starting at `data`.
  py::array view(const double* data, std::vector<py::ssize_t> shape,
                 std::vector<py::ssize_t> strides) const {
    auto* keep = new std::shared_ptr<pfm::MpmRun>(run_);
    py::capsule owner(keep, [](void* p) { delete static_cast<std::shared_ptr<pfm::MpmRun>*>(p); });
    return py::array(py::dtype::of<double>(), std::move(shape), std::move(strides), data, owner);
  }
  py::array vectors(const std::vector<pfm::Vec2>& field) const {
    static_assert(sizeof(pfm::Vec2) == 2 * sizeof(double));
    return view(field.data()->data(), {static_cast<py::ssize_t>(field.size()), 2},
                {sizeof(pfm::Vec2), sizeof(double)});
  }
  py::array scalars(const std::vector<double>& field) const {
    return view(field.data(), {static_cast<py::ssize_t>(field.size())}, {sizeof(double)});
  }
  py::array stresses(const std::vector<pfm::Stress>& field) const {
    static_assert(sizeof(pfm::Stress) == 4 * sizeof(double));
    return view(field.data()->data(), {static_cast<py::ssize_t>(field.size()), 4},
                {sizeof(pfm::Stress), sizeof(double)});
  }
  // F[p, i, j]: Eigen stores a Mat2 column by column.
  py::array tensors(const std::vector<pfm::Mat2>& field) const {
    static_assert(sizeof(pfm::Mat2) == 4 * sizeof(double));
    return view(field.data()->data(), {static_cast<py::ssize_t>(field.size()), 2, 2},
                {sizeof(pfm::Mat2), sizeof(double), 2 * sizeof(double)});
  }

  pfm::MpmRun& run() {
    if (!run_) throw pfm::InputError(out_ + ": the simulation is closed");
    return *run_;
  }
  // Drops this object's hold on the run (the views keep theirs): the output folder's lock is
  // released once no view is left.
  void close() { run_.reset(); }

 private:
  // A run that a simulation error or a write fault stopped: ended, and raised as
  // pfm_mpm.SimulationError or pfm_mpm.OutputError.
  void raise_if_stopped() {
    if (run_->running()) return;
    const int status = run_->end();
    if (status == pfm::kExitSimulationError) throw pfm::SimulationError(run_->stop_message());
    if (status != pfm::kExitOk) {
      throw pfm::IoError(out_ + ": a write failed; run.json says why (exit status " +
                         std::to_string(status) + ")");
    }
  }

  std::string out_;
  std::shared_ptr<pfm::MpmRun> run_;
};

std::unique_ptr<Simulation> make_simulation(const std::string& path, const std::string& text,
                                            const std::string& file, const std::string& out,
                                            int threads, bool overwrite, bool progress,
                                            long checkpoint_steps, double checkpoint_seconds) {
  pfm::RunOptions options;
  options.out_dir = out;
  options.threads = threads;
  options.overwrite = overwrite;
  options.progress = progress;
  options.checkpoint_steps = checkpoint_steps;
  options.checkpoint_seconds = checkpoint_seconds;
  options.command_line =
      "pfm_mpm.Simulation(" + (path.empty() ? file : path) + ", out=" + out + ")";
  return std::make_unique<Simulation>(
      path.empty() ? case_from_text(text, file) : pfm::read_case(path), options);
}

}  // namespace

PYBIND11_MODULE(_core, m) {
  m.doc() = "The pfm-mpm C++ core (python/README.md).";
  py::register_exception<pfm::InputError>(m, "InputError", PyExc_ValueError);
  py::register_exception<pfm::SimulationError>(m, "SimulationError", PyExc_RuntimeError);
  py::register_exception<pfm::IoError>(m, "OutputError", PyExc_OSError);
  m.def("version", &pfm::version_line, "pfm-mpm <version> (git <revision>, <build type> build)");
  m.def("read_case_json", &read_case_json, py::arg("path"),
        "Reads and validates a case file; the resolved case as JSON text (resolved_case).");
  m.def("parse_case_json", &parse_case_json, py::arg("text"), py::arg("file"),
        "Validates a case given as JSON text (file names it in messages and resolves relative "
        "paths); the resolved case as JSON text.");
  m.def("detect", &detect, py::arg("position"), py::arg("volume"), py::arg("initial_spacing"),
        py::arg("grid"), py::arg("config"), py::arg("deformation_gradient") = py::none(),
        "Detected boundary loops [(points (m, 2), closed)]; grid and config as JSON text.");
  m.def("composite_bezier", &composite_bezier, py::arg("points"), py::arg("closed"),
        py::arg("kind"), "(control (n, 4, 2), degree (n,), closed) of the composite curve.");
  m.def("nodal_forces", &nodal_forces, py::arg("grid"), py::arg("curves"), py::arg("load"),
        py::arg("load_factor"), py::arg("shape_degree"), py::arg("node_mass") = py::none(),
        "(forces (n_nodes, 2), totals) of a detected-boundary load on the curves.");
  py::class_<Simulation>(m, "Simulation")
      .def(py::init(&make_simulation), py::arg("path"), py::arg("text"), py::arg("file"),
           py::arg("out"), py::arg("threads"), py::arg("overwrite"), py::arg("progress"),
           py::arg("checkpoint_steps"), py::arg("checkpoint_seconds"),
           "A case (a file at path, or JSON text named file) run into the folder out, begun.")
      .def("step", &Simulation::step, py::arg("n"), "Up to n steps; the steps taken.")
      .def("finish", &Simulation::finish, "Ends the run now; its exit status.")
      .def("close", &Simulation::close, "Drops the run (views keep it alive).")
      .def("detect", &Simulation::detect, "The detected loops of the points now.")
      .def_property_readonly("time", [](Simulation& s) { return s.run().solver().time(); })
      .def_property_readonly("step_count",
                             [](Simulation& s) { return s.run().solver().step_count(); })
      .def_property_readonly("dt", [](Simulation& s) { return s.run().solver().dt(); })
      .def_property_readonly("n_steps", [](Simulation& s) { return s.run().n_steps(); })
      .def_property_readonly("stepping", [](Simulation& s) { return s.run().stepping(); })
      .def(
          "field",
          [](Simulation& s, const std::string& name) -> py::array {
            // Fields a user may change between steps come through mutable_particles().
            pfm::MpmSolver& solver = s.run().solver();
            const pfm::Particles& p = solver.particles();
            if (name == "position") return s.vectors(solver.mutable_particles().position);
            if (name == "velocity") return s.vectors(solver.mutable_particles().velocity);
            if (name == "stress") return s.stresses(solver.mutable_particles().stress);
            if (name == "deformation_gradient")
              return s.tensors(solver.mutable_particles().deformation_gradient);
            if (name == "reference_position") return s.vectors(p.reference_position);
            if (name == "mass") return s.scalars(p.mass);
            if (name == "volume") return s.scalars(p.volume);
            throw pfm::InputError("field: no particle field \"" + name + "\"");
          },
          py::arg("name"), "A numpy view of a particle field.");
}

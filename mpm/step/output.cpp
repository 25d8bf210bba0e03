#include "mpm/step/output.hpp"

#include <hdf5.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <stdexcept>

#include "mpm/core/json_input.hpp"
#include "mpm/step/hdf5_untimed.hpp"

namespace pfm {

namespace xdmf {

std::string open(const std::string& name) {
  return "<?xml version=\"1.0\" ?>\n<Xdmf Version=\"3.0\">\n<Domain>\n<Grid Name=\"" + name +
         "\" GridType=\"Collection\" CollectionType=\"Temporal\">\n";
}

std::string step(const std::string& group, double time) {
  return "<Grid Name=\"" + group + "\" GridType=\"Uniform\">\n<Time Value=\"" + format_exact(time) +
         "\"/>\n";
}

std::string data_item(const std::string& dimensions, bool integer, const std::string& path) {
  return "<DataItem Dimensions=\"" + dimensions + "\" Format=\"HDF\" NumberType=\"" +
         (integer ? "Int" : "Float") + "\" Precision=\"8\">" + path + "</DataItem>";
}

std::string topology(const char* type, std::size_t elements, int nodes_per_element,
                     const std::string& item) {
  std::string text = std::string("<Topology TopologyType=\"") + type + "\" NumberOfElements=\"" +
                     std::to_string(elements) + "\"";
  if (nodes_per_element > 0) {
    text += " NodesPerElement=\"" + std::to_string(nodes_per_element) + "\"";
  }
  return text + ">" + item + "</Topology>\n";
}

std::string geometry(std::size_t n, const std::string& path) {
  return "<Geometry GeometryType=\"XYZ\">" + data_item(std::to_string(n) + " 3", false, path) +
         "</Geometry>\n";
}

std::string attribute(const char* name, bool vector, bool cell, std::size_t n, bool integer,
                      const std::string& path) {
  return std::string("<Attribute Name=\"") + name + "\" AttributeType=\"" +
         (vector ? "Vector" : "Scalar") + "\" Center=\"" + (cell ? "Cell" : "Node") + "\">" +
         data_item(std::to_string(n) + (vector ? " 3" : ""), integer, path) + "</Attribute>\n";
}

}  // namespace xdmf

TimeSeriesTable::TimeSeriesTable(bool with_loads, std::size_t n_loads,
                                 const std::vector<std::string>& reactions,
                                 std::size_t n_constraints)
    : with_loads_(with_loads),
      n_loads_(n_loads),
      n_reactions_(reactions.size()),
      n_constraints_(n_constraints) {
  text_ << "time,kinetic_energy,external_work,internal_work,damping_work,momentum_x,momentum_y";
  if (with_loads_) {
    text_ << ",load_target_fx,load_target_fy,load_applied_fx,load_applied_fy,load_lost_fx,"
             "load_lost_fy,load_off_grid_fx,load_off_grid_fy,loaded_nodes,lost_nodes,"
             "load_lost_moment";
  }
  text_ << ",elastic_energy,plastic_dissipation,gravity_work,load_work,constraint_work,"
           "transfer_to_grid,transfer_to_particles,internal_force_work,rotation_work,volume_work,"
           "energy_error";
  for (std::size_t k = 0; k < n_loads_; ++k) text_ << ",load_work_" << k;
  for (const std::string& name : reactions)
    text_ << ",reaction_" << name << "_fx,reaction_" << name << "_fy";
  for (std::size_t k = 0; k < n_constraints; ++k)
    text_ << ",constraint_" << k << "_fx,constraint_" << k << "_fy,constraint_" << k << "_gap";
  text_ << '\n';
}

nlohmann::json energy_summary(const EnergyBalance& e) {
  nlohmann::json out = {{"kinetic", e.kinetic_energy},
                        {"elastic_energy", e.elastic_energy},
                        {"external_work", e.external_work()},
                        {"internal_work", e.internal_work()}};
  EnergyLedger ledger = e.ledger;
  const auto fields = ledger.fields();
  for (std::size_t k = 0; k < fields.size(); ++k)
    out[std::string(EnergyLedger::kNames[k])] = *fields[k];
  if (!ledger.load_work_by_load.empty()) out["load_work_by_load"] = ledger.load_work_by_load;
  out["energy_error"] = e.energy_error();
  out["largest_term"] = e.largest_term();
  out["relative_error"] =
      e.largest_term() > 0.0 ? std::abs(e.energy_error()) / e.largest_term() : 0.0;
  return out;
}

void TimeSeriesTable::restore(const std::string& text) {
  text_.str(text);
  text_.seekp(0, std::ios_base::end);
}

namespace {

// A failed HDF5 call on an output file: IoError with the file, the object and the system's
// reason (HDF5 leaves errno as its last system call set it: ENOSPC on a full disk).
void check(long status, const std::string& file, const std::string& what) {
  if (status < 0) throw_io_error("HDF5 cannot write " + what + " in", file, errno);
}

}  // namespace

namespace {

void write_typed(hid_t group, const std::string& file, const char* name, hid_t file_type,
                 hid_t memory_type, const void* data, std::size_t rows, std::size_t cols,
                 bool compress) {
  hsize_t dims[2] = {rows, cols};
  const hid_t space = H5Screate_simple(cols == 1 ? 1 : 2, dims, nullptr);
  UntimedCreation creation(H5P_DATASET_CREATE);
  if (compress) creation.compressed(rows, cols);
  const hid_t set =
      H5Dcreate2(group, name, file_type, space, H5P_DEFAULT, creation.get(), H5P_DEFAULT);
  const int error = errno;
  H5Sclose(space);
  if (set < 0)
    throw_io_error(std::string("HDF5 cannot create dataset ") + name + " in", file, error);
  const herr_t status =
      rows > 0 ? H5Dwrite(set, memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) : 0;
  H5Dclose(set);
  check(status, file, name);
}

}  // namespace

void write_h5_dataset(hid_t group, const std::string& file, const char* name,
                      const std::vector<double>& data, std::size_t rows, std::size_t cols,
                      bool compress) {
  write_typed(group, file, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, data.data(), rows, cols,
              compress);
}

void write_h5_dataset(hid_t group, const std::string& file, const char* name,
                      const std::vector<long long>& data, std::size_t rows, std::size_t cols,
                      bool compress) {
  write_typed(group, file, name, H5T_STD_I64LE, H5T_NATIVE_LLONG, data.data(), rows, cols,
              compress);
}

hid_t create_step_group(hid_t file, const std::string& path, long step, double time) {
  char name[32];
  std::snprintf(name, sizeof name, "step_%08ld", step);
  H5Handle group(
      H5Gcreate2(file, name, H5P_DEFAULT, UntimedCreation(H5P_GROUP_CREATE).get(), H5P_DEFAULT),
      H5Gclose);
  if (!group.ok())
    throw_io_error(std::string("HDF5 cannot create group ") + name + " in", path, errno);
  write_h5_attribute(group.get(), path, "time", time);
  write_h5_attribute(group.get(), path, "step", static_cast<double>(step));
  return group.release();
}

void write_h5_attribute(hid_t object, const std::string& file, const char* name, double value) {
  const H5Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  const H5Handle attribute(
      H5Acreate2(object, name, H5T_IEEE_F64LE, space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attribute.ok() || H5Awrite(attribute.get(), H5T_NATIVE_DOUBLE, &value) < 0)
    throw_io_error(std::string("HDF5 cannot write attribute ") + name + " in", file, errno);
}

void write_h5_attribute(hid_t object, const std::string& file, const char* name,
                        const std::string& value) {
  const H5Handle type(H5Tcopy(H5T_C_S1), H5Tclose);
  H5Tset_size(type.get(), std::max<std::size_t>(value.size(), 1));
  const H5Handle space(H5Screate(H5S_SCALAR), H5Sclose);
  const H5Handle attribute(
      H5Acreate2(object, name, type.get(), space.get(), H5P_DEFAULT, H5P_DEFAULT), H5Aclose);
  if (!attribute.ok() || H5Awrite(attribute.get(), type.get(), value.c_str()) < 0)
    throw_io_error(std::string("HDF5 cannot write attribute ") + name + " in", file, errno);
}

namespace {

// The "units" attribute of particles.h5 (and of the UL-FEM's mesh.h5).
constexpr const char* kParticleUnits =
    "kN, m, s, t, kPa; plane strain, tension positive: position, displacement m; velocity m/s; "
    "sxx, syy, sxy, szz kPa; eps_p, F11..F22 -; volume m^2 per m; id, material, body integers; "
    "group attributes time s, step";

std::string step_group(long step) {
  char name[32];
  std::snprintf(name, sizeof name, "step_%08ld", step);
  return name;
}

/// The copy of a series file that the latest checkpoint keeps (copy_for_checkpoint()).
std::string checkpoint_copy_of(const std::string& path) {
  return path + ".checkpoint";
}

/// Copies the series file `name` of `folder` as it is now (flushed at the end of each output
/// step) to its checkpoint_copy_of(), by a temporary and a rename, unless `steps` (the output
/// steps the file holds) equals `steps_at_copy` (the copy still holds them all); sets
/// `steps_at_copy`. IoError (copy_file_atomically) when a read or write fails.
void copy_series(OutputFolder& folder, const std::string& name, std::size_t steps,
                 std::size_t& steps_at_copy) {
  if (steps == steps_at_copy) return;
  copy_file_atomically(folder.file(name), folder.file(checkpoint_copy_of(name)));
  steps_at_copy = steps;
}

/// Rebuilds `path` with only the objects `names` (copied in order) of its copy at the latest
/// checkpoint, or of the file itself where there is no such copy (a run from before the copies
/// were kept), written to a temporary file and renamed; returns the reopened file (read-write).
hid_t rebuild_keeping(const std::string& path, const std::vector<std::string>& names) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  const std::string temporary = path + ".rebuild";
  const std::string copy = checkpoint_copy_of(path);
  const std::string source = std::filesystem::exists(copy) ? copy : path;
  const hid_t old_file = H5Fopen(source.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT);
  if (old_file < 0) throw InputError(source + ": missing or not a readable HDF5 file (restart)");
  const hid_t new_file = H5Fcreate(temporary.c_str(), H5F_ACC_TRUNC,
                                   UntimedCreation(H5P_FILE_CREATE).get(), H5P_DEFAULT);
  if (new_file < 0) {
    const int error = errno;
    H5Fclose(old_file);
    throw_io_error("cannot create", temporary, error);
  }
  for (const std::string& name : names) {
    if (H5Ocopy(old_file, name.c_str(), new_file, name.c_str(), H5P_DEFAULT, H5P_DEFAULT) < 0) {
      H5Fclose(old_file);
      H5Fclose(new_file);
      std::remove(temporary.c_str());
      throw InputError(source + ": has no readable " + name + " (restart)");
    }
  }
  H5Fclose(old_file);
  if (H5Fclose(new_file) < 0) throw_io_error("cannot write", temporary, errno);
  if (std::rename(temporary.c_str(), path.c_str()) != 0)
    throw_io_error("cannot rename to", path, errno);
  const hid_t file = H5Fopen(path.c_str(), H5F_ACC_RDWR, H5P_DEFAULT);
  if (file < 0) throw_io_error("cannot reopen", path, errno);
  return file;
}

std::size_t dataset_rows(hid_t file, const std::string& name) {
  const hid_t set = H5Dopen2(file, name.c_str(), H5P_DEFAULT);
  if (set < 0) throw InputError("restart: the output file has no dataset " + name);
  const hid_t space = H5Dget_space(set);
  hsize_t dims[2] = {0, 0};
  H5Sget_simple_extent_dims(space, dims, nullptr);
  H5Sclose(space);
  H5Dclose(set);
  return static_cast<std::size_t>(dims[0]);
}

}  // namespace

void end_series_step(hid_t file, const std::string& path, long step, double time,
                     std::vector<double>& times, std::vector<std::string>& groups) {
  const std::string name = step_group(step);
  check(H5Fflush(file, H5F_SCOPE_GLOBAL), path, name);
  times.push_back(time);
  groups.push_back(name);
}

ParticleSeriesWriter::ParticleSeriesWriter(OutputFolder& folder, bool compress)
    : h5_path_(folder.file("particles.h5")),
      xdmf_path_(folder.file("particles.xdmf")),
      compress_(compress) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  file_ = H5Fcreate(h5_path_.c_str(), H5F_ACC_TRUNC, UntimedCreation(H5P_FILE_CREATE).get(),
                    H5P_DEFAULT);
  if (file_ < 0) throw_io_error("cannot create", h5_path_, errno);
}

ParticleSeriesWriter::ParticleSeriesWriter(OutputFolder& folder, bool compress,
                                           const std::vector<std::pair<double, long>>& keep)
    : h5_path_(folder.file("particles.h5")),
      xdmf_path_(folder.file("particles.xdmf")),
      compress_(compress) {
  std::vector<std::string> names;
  if (!keep.empty()) names.push_back("connectivity");
  for (const auto& [time, step] : keep) names.push_back(step_group(step));
  file_ = rebuild_keeping(h5_path_, names);
  for (const auto& [time, step] : keep) {
    times_.push_back(time);
    groups_.push_back(step_group(step));
    counts_.push_back(dataset_rows(static_cast<hid_t>(file_), groups_.back() + "/id"));
  }
  write_xdmf();
}

ParticleSeriesWriter::~ParticleSeriesWriter() {
  if (file_ >= 0) H5Fclose(static_cast<hid_t>(file_));
}

void ParticleSeriesWriter::write(double time, long step, const Particles& particles,
                                 std::span<const Stress> recovered) {
  if (times_.empty()) {
    // Polyvertex connectivity 0 .. N-1, shared by every step (the particle count is fixed),
    // and the units of the file's fields.
    std::vector<long long> connectivity(particles.size());
    for (std::size_t p = 0; p < connectivity.size(); ++p)
      connectivity[p] = static_cast<long long>(p);
    write_h5_dataset(static_cast<hid_t>(file_), h5_path_, "connectivity", connectivity,
                     connectivity.size(), 1, compress_);
    write_h5_attribute(static_cast<hid_t>(file_), h5_path_, "units", kParticleUnits);
  }
  const std::string name = step_group(step);
  const H5Handle group(create_step_group(static_cast<hid_t>(file_), h5_path_, step, time),
                       H5Gclose);
  const std::size_t n = particles.size();
  std::vector<double> buffer;
  std::vector<long long> integers(n);
  auto vec3 = [&](auto get) {
    buffer.assign(3 * n, 0.0);
    for (std::size_t p = 0; p < n; ++p) {
      const Vec2 v = get(p);
      buffer[3 * p] = v.x();
      buffer[3 * p + 1] = v.y();
    }
  };
  auto scalar = [&](auto get) {
    buffer.resize(n);
    for (std::size_t p = 0; p < n; ++p) buffer[p] = get(p);
  };
  vec3([&](std::size_t p) { return particles.position[p]; });
  write_h5_dataset(group.get(), h5_path_, "position", buffer, n, 3, compress_);
  vec3(
      [&](std::size_t p) { return Vec2(particles.position[p] - particles.reference_position[p]); });
  write_h5_dataset(group.get(), h5_path_, "displacement", buffer, n, 3, compress_);
  vec3([&](std::size_t p) { return particles.velocity[p]; });
  write_h5_dataset(group.get(), h5_path_, "velocity", buffer, n, 3, compress_);
  const char* stress_names[4] = {"sxx", "syy", "sxy", "szz"};
  for (int k = 0; k < 4; ++k) {
    scalar([&](std::size_t p) { return particles.stress[p][k]; });
    write_h5_dataset(group.get(), h5_path_, stress_names[k], buffer, n, 1, compress_);
  }
  scalar([&](std::size_t p) { return particles.state[p].plastic_strain; });
  write_h5_dataset(group.get(), h5_path_, "eps_p", buffer, n, 1, compress_);
  scalar([&](std::size_t p) { return particles.volume[p]; });
  write_h5_dataset(group.get(), h5_path_, "volume", buffer, n, 1, compress_);
  for (std::size_t p = 0; p < n; ++p) integers[p] = static_cast<long long>(p);
  write_h5_dataset(group.get(), h5_path_, "id", integers, n, 1, compress_);
  for (std::size_t p = 0; p < n; ++p) integers[p] = particles.material[p];
  write_h5_dataset(group.get(), h5_path_, "material", integers, n, 1, compress_);
  for (std::size_t p = 0; p < n; ++p) integers[p] = particles.body[p];
  write_h5_dataset(group.get(), h5_path_, "body", integers, n, 1, compress_);
  const char* gradient_names[4] = {"F11", "F12", "F21", "F22"};
  for (int k = 0; k < 4; ++k) {
    scalar([&](std::size_t p) { return particles.deformation_gradient[p](k / 2, k % 2); });
    write_h5_dataset(group.get(), h5_path_, gradient_names[k], buffer, n, 1, compress_);
  }
  for (int k = 0; k < 4; ++k) {
    scalar([&](std::size_t p) { return recovered_or_own(recovered, particles, p)[k]; });
    write_h5_dataset(group.get(), h5_path_, kRecoveredStressNames[k], buffer, n, 1, compress_);
  }
  end_series_step(static_cast<hid_t>(file_), h5_path_, step, time, times_, groups_);
  counts_.push_back(n);
  write_xdmf();
}

void ParticleSeriesWriter::copy_for_checkpoint(OutputFolder& folder) {
  copy_series(folder, "particles.h5", times_.size(), steps_at_copy_);
}

void ParticleSeriesWriter::write_xdmf() const {
  std::string x = xdmf::open("particles");
  for (std::size_t s = 0; s < times_.size(); ++s) {
    const std::size_t n = counts_[s];
    const std::string at = "particles.h5:/" + groups_[s] + "/";
    x += xdmf::step(groups_[s], times_[s]);
    x += xdmf::topology("Polyvertex", n, 1,
                        xdmf::data_item(std::to_string(n), true, "particles.h5:/connectivity"));
    x += xdmf::geometry(n, at + "position");
    // position again as an attribute: readers that keep the first step's geometry for the
    // whole series (meshio's TimeSeriesReader) get each step's positions from it.
    for (const char* vector_name : {"position", "displacement", "velocity"}) {
      x += xdmf::attribute(vector_name, true, false, n, false, at + vector_name);
    }
    for (const char* scalar_name :
         {"sxx", "syy", "sxy", "szz", "eps_p", "volume", "id", "material", "body", "F11", "F12",
          "F21", "F22", kRecoveredStressNames[0], kRecoveredStressNames[1],
          kRecoveredStressNames[2], kRecoveredStressNames[3]}) {
      const std::string name = scalar_name;
      const bool integer = name == "id" || name == "material" || name == "body";
      x += xdmf::attribute(scalar_name, false, false, n, integer, at + name);
    }
    x += xdmf::kEndStep;
  }
  x += xdmf::kClose;
  write_file_atomically(xdmf_path_, x);
}

BoundarySeriesWriter::BoundarySeriesWriter(OutputFolder& folder, bool compress)
    : h5_path_(folder.file("boundary.h5")),
      xdmf_path_(folder.file("boundary.xdmf")),
      compress_(compress) {
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  file_ = H5Fcreate(h5_path_.c_str(), H5F_ACC_TRUNC, UntimedCreation(H5P_FILE_CREATE).get(),
                    H5P_DEFAULT);
  if (file_ < 0) throw_io_error("cannot create", h5_path_, errno);
}

BoundarySeriesWriter::BoundarySeriesWriter(OutputFolder& folder, bool compress,
                                           const std::vector<std::pair<double, long>>& keep)
    : h5_path_(folder.file("boundary.h5")),
      xdmf_path_(folder.file("boundary.xdmf")),
      compress_(compress) {
  std::vector<std::string> names;
  for (const auto& [time, step] : keep) names.push_back(step_group(step));
  file_ = rebuild_keeping(h5_path_, names);
  for (const auto& [time, step] : keep) {
    times_.push_back(time);
    groups_.push_back(step_group(step));
    points_.push_back(dataset_rows(static_cast<hid_t>(file_), groups_.back() + "/loop"));
    segments_.push_back(dataset_rows(static_cast<hid_t>(file_), groups_.back() + "/segments"));
  }
  write_xdmf();
}

void BoundarySeriesWriter::copy_for_checkpoint(OutputFolder& folder) {
  copy_series(folder, "boundary.h5", times_.size(), steps_at_copy_);
}

BoundarySeriesWriter::~BoundarySeriesWriter() {
  if (file_ >= 0) H5Fclose(static_cast<hid_t>(file_));
}

void BoundarySeriesWriter::write(double time, long step,
                                 const std::vector<std::vector<Vec2>>& loops,
                                 const std::vector<bool>& closed) {
  std::vector<double> position;
  std::vector<long long> loop_of_point, segments;
  for (std::size_t k = 0; k < loops.size(); ++k) {
    const auto first = static_cast<long long>(loop_of_point.size());
    const auto count = static_cast<long long>(loops[k].size());
    for (const Vec2& x : loops[k]) {
      position.insert(position.end(), {x.x(), x.y(), 0.0});
      loop_of_point.push_back(static_cast<long long>(k));
    }
    for (long long i = 0; i + 1 < count; ++i)
      segments.insert(segments.end(), {first + i, first + i + 1});
    if (closed[k] && count > 2) segments.insert(segments.end(), {first + count - 1, first});
  }
  const std::string name = step_group(step);
  const H5Handle group(create_step_group(static_cast<hid_t>(file_), h5_path_, step, time),
                       H5Gclose);
  const std::size_t n_points = loop_of_point.size(), n_segments = segments.size() / 2;
  write_h5_dataset(group.get(), h5_path_, "position", position, n_points, 3, compress_);
  write_h5_dataset(group.get(), h5_path_, "loop", loop_of_point, n_points, 1, compress_);
  write_h5_dataset(group.get(), h5_path_, "segments", segments, n_segments, 2, compress_);
  end_series_step(static_cast<hid_t>(file_), h5_path_, step, time, times_, groups_);
  points_.push_back(n_points);
  segments_.push_back(n_segments);
  write_xdmf();
}

void BoundarySeriesWriter::write_xdmf() const {
  std::string x = xdmf::open("boundary");
  for (std::size_t s = 0; s < times_.size(); ++s) {
    if (segments_[s] == 0) continue;  // no boundary at this step: nothing to draw
    const std::string at = "boundary.h5:/" + groups_[s] + "/";
    x += xdmf::step(groups_[s], times_[s]);
    x +=
        xdmf::topology("Polyline", segments_[s], 2,
                       xdmf::data_item(std::to_string(segments_[s]) + " 2", true, at + "segments"));
    x += xdmf::geometry(points_[s], at + "position");
    x += xdmf::attribute("position", true, false, points_[s], false, at + "position");
    x += xdmf::attribute("loop", false, false, points_[s], true, at + "loop");
    x += xdmf::kEndStep;
  }
  x += xdmf::kClose;
  write_file_atomically(xdmf_path_, x);
}

std::string particles_csv(const Particles& particles, std::span<const Stress> recovered) {
  std::ostringstream out;
  out << "id,x,y,vx,vy,sxx,syy,sxy,szz,eps_p,volume,ux,uy,material,body,F11,F12,F21,F22,"
         "sxx_rec,syy_rec,sxy_rec,szz_rec\n";
  for (std::size_t p = 0; p < particles.size(); ++p) {
    const Vec2& x = particles.position[p];
    const Vec2& v = particles.velocity[p];
    const Stress& s = particles.stress[p];
    const Vec2 u = x - particles.reference_position[p];
    out << p << ',' << format_exact(x.x()) << ',' << format_exact(x.y()) << ','
        << format_exact(v.x()) << ',' << format_exact(v.y()) << ',' << format_exact(s[0]) << ','
        << format_exact(s[1]) << ',' << format_exact(s[2]) << ',' << format_exact(s[3]) << ','
        << format_exact(particles.state[p].plastic_strain) << ','
        << format_exact(particles.volume[p]) << ',' << format_exact(u.x()) << ','
        << format_exact(u.y()) << ',' << particles.material[p] << ',' << particles.body[p];
    const Mat2& f = particles.deformation_gradient[p];
    out << ',' << format_exact(f(0, 0)) << ',' << format_exact(f(0, 1)) << ','
        << format_exact(f(1, 0)) << ',' << format_exact(f(1, 1));
    const Stress& r = recovered_or_own(recovered, particles, p);
    out << ',' << format_exact(r[0]) << ',' << format_exact(r[1]) << ',' << format_exact(r[2])
        << ',' << format_exact(r[3]) << '\n';
  }
  return out.str();
}

}  // namespace pfm

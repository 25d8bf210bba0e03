#include "mpm/solver/checkpoint.hpp"

#include <hdf5.h>
#include <zlib.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "mpm/core/json_input.hpp"
#include "mpm/core/output_folder.hpp"
#include "mpm/step/hdf5_untimed.hpp"

namespace pfm {

namespace {

// Dataset names are stored with '/' replaced, so that the file stays flat.
std::string encode(const std::string& name) {
  std::string out = name;
  for (char& c : out)
    if (c == '/') c = '|';
  return out;
}
std::string decode(const std::string& name) {
  std::string out = name;
  for (char& c : out)
    if (c == '|') c = '/';
  return out;
}

const std::string kChecksums = "t:checksums";

void write_array(hid_t file, const std::string& path, const std::string& name, hid_t file_type,
                 hid_t memory_type, const void* data, std::size_t count) {
  hsize_t dims[1] = {count};
  const H5Handle space(H5Screate_simple(1, dims, nullptr), H5Sclose);
  const H5Handle set(H5Dcreate2(file, name.c_str(), file_type, space.get(), H5P_DEFAULT,
                                UntimedCreation(H5P_DATASET_CREATE).get(), H5P_DEFAULT),
                     H5Dclose);
  if (!set.ok()) throw_io_error("HDF5 cannot create dataset " + name + " in", path, errno);
  if (count > 0 && H5Dwrite(set.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    throw_io_error("HDF5 cannot write dataset " + name + " in", path, errno);
}

std::string crc_hex(const void* data, std::size_t bytes) {
  uLong crc = crc32(0L, Z_NULL, 0);
  const auto* p = static_cast<const Bytef*>(data);
  while (bytes > 0) {  // crc32 takes at most 4 GB a call
    const auto chunk = static_cast<uInt>(std::min<std::size_t>(bytes, 1u << 30));
    crc = crc32(crc, p, chunk);
    p += chunk;
    bytes -= chunk;
  }
  char text[16];
  std::snprintf(text, sizeof text, "%08lx", static_cast<unsigned long>(crc));
  return text;
}

struct ReadContext {
  CheckpointFile* out;
  std::map<std::string, std::vector<double>>* numbers;
  std::map<std::string, std::string>* texts;
  std::string path;
  std::string error;
};

}  // namespace

void CheckpointFile::put(const std::string& name, std::span<const double> values) {
  numbers_[name].assign(values.begin(), values.end());
}

void CheckpointFile::put_text(const std::string& name, const std::string& text) {
  texts_[name] = text;
}

bool CheckpointFile::has(const std::string& name) const {
  return numbers_.count(name) > 0 || texts_.count(name) > 0;
}

void CheckpointFile::fail(const std::string& name, const std::string& message) const {
  throw InputError(file_ + ": checkpoint dataset " + name + ": " + message);
}

const std::vector<double>& CheckpointFile::get(const std::string& name) const {
  const auto it = numbers_.find(name);
  if (it == numbers_.end()) throw InputError(file_ + ": checkpoint has no dataset " + name);
  for (std::size_t k = 0; k < it->second.size(); ++k)
    if (!std::isfinite(it->second[k]))
      fail(name, "holds a value that is not finite (at index " + std::to_string(k) + ")");
  return it->second;
}

const std::vector<double>& CheckpointFile::get(const std::string& name, std::size_t size) const {
  const std::vector<double>& values = get(name);
  if (values.size() != size) {
    fail(name,
         "holds " + std::to_string(values.size()) + " values, expected " + std::to_string(size));
  }
  return values;
}

double CheckpointFile::scalar(const std::string& name, double lo, double hi) const {
  const double value = get(name, 1)[0];
  if (!(value >= lo && value <= hi)) {
    std::ostringstream message;
    message << "value " << value << " is outside [" << lo << ", " << hi << "]";
    fail(name, message.str());
  }
  return value;
}

long CheckpointFile::integer(const std::string& name, long lo, long hi) const {
  const double value = scalar(name, static_cast<double>(lo), static_cast<double>(hi));
  if (value != std::floor(value)) fail(name, "is not an integer");
  return static_cast<long>(value);
}

const std::string& CheckpointFile::text(const std::string& name) const {
  const auto it = texts_.find(name);
  if (it == texts_.end()) throw InputError(file_ + ": checkpoint has no text " + name);
  return it->second;
}

void CheckpointFile::write(const std::string& path) const {
  const std::string temporary = path + ".tmp";
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  try {
    const H5Handle file(H5Fcreate(temporary.c_str(), H5F_ACC_TRUNC,
                                  UntimedCreation(H5P_FILE_CREATE).get(), H5P_DEFAULT),
                        H5Fclose);
    if (!file.ok()) throw_io_error("cannot create", temporary, errno);
    std::string checksums;
    for (const auto& [name, values] : numbers_) {
      const std::string stored = "n:" + encode(name);
      write_array(file.get(), temporary, stored, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, values.data(),
                  values.size());
      checksums += stored + " " + crc_hex(values.data(), values.size() * sizeof(double)) + "\n";
    }
    for (const auto& [name, text] : texts_) {
      const std::string stored = "t:" + encode(name);
      write_array(file.get(), temporary, stored, H5T_STD_U8LE, H5T_NATIVE_UCHAR, text.data(),
                  text.size());
      checksums += stored + " " + crc_hex(text.data(), text.size()) + "\n";
    }
    write_array(file.get(), temporary, kChecksums, H5T_STD_U8LE, H5T_NATIVE_UCHAR, checksums.data(),
                checksums.size());
    if (H5Fflush(file.get(), H5F_SCOPE_GLOBAL) < 0)
      throw_io_error("HDF5 cannot write", temporary, errno);
  } catch (...) {
    std::remove(temporary.c_str());
    throw;
  }
  if (std::rename(temporary.c_str(), path.c_str()) != 0) {
    const int error = errno;
    std::remove(temporary.c_str());
    throw_io_error("cannot rename to", path, error);
  }
}

CheckpointFile CheckpointFile::read(const std::string& path) {
  CheckpointFile result;
  result.file_ = path;
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  if (!std::filesystem::exists(path)) throw InputError(path + ": no checkpoint");
  const H5Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) throw InputError(path + ": not a readable HDF5 checkpoint");
  ReadContext context{&result, &result.numbers_, &result.texts_, path, ""};
  auto visit = [](hid_t group, const char* raw_name, const H5L_info_t*, void* data) -> herr_t {
    auto* c = static_cast<ReadContext*>(data);
    const std::string name(raw_name);
    const H5Handle set(H5Dopen2(group, raw_name, H5P_DEFAULT), H5Dclose);
    const H5Handle space(H5Dget_space(set.get()), H5Sclose);
    if (!set.ok() || !space.ok() || H5Sget_simple_extent_ndims(space.get()) != 1) {
      c->error = "unexpected object " + name;
      return -1;
    }
    hsize_t dims[1] = {0};
    H5Sget_simple_extent_dims(space.get(), dims, nullptr);
    if (name.rfind("n:", 0) == 0) {
      std::vector<double> values(dims[0]);
      if (dims[0] > 0 &&
          H5Dread(set.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, values.data()) < 0) {
        c->error = "cannot read " + name;
        return -1;
      }
      (*c->numbers)[decode(name.substr(2))] = std::move(values);
    } else if (name.rfind("t:", 0) == 0) {
      std::string text(dims[0], '\0');
      if (dims[0] > 0 &&
          H5Dread(set.get(), H5T_NATIVE_UCHAR, H5S_ALL, H5S_ALL, H5P_DEFAULT, text.data()) < 0) {
        c->error = "cannot read " + name;
        return -1;
      }
      (*c->texts)[decode(name.substr(2))] = std::move(text);
    } else {
      c->error = "unexpected dataset " + name;
      return -1;
    }
    return 0;
  };
  if (H5Literate(file.get(), H5_INDEX_NAME, H5_ITER_INC, nullptr, visit, &context) < 0) {
    throw InputError(path + ": corrupt checkpoint" +
                     (context.error.empty() ? "" : " (" + context.error + ")"));
  }
  // Every dataset against its checksum, and every listed dataset present.
  const auto listed = result.texts_.find(kChecksums.substr(2));
  if (listed == result.texts_.end())
    throw InputError(path + ": not a checkpoint of this version (no dataset checksums)");
  std::map<std::string, std::string> expected;
  std::istringstream lines(listed->second);
  std::string stored, crc;
  while (lines >> stored >> crc) expected[stored] = crc;
  for (const auto& [stored_name, want] : expected) {
    const std::string name =
        decode(stored_name.substr(std::min<std::size_t>(2, stored_name.size())));
    std::string have;
    if (stored_name.rfind("n:", 0) == 0 && result.numbers_.count(name) > 0) {
      const std::vector<double>& values = result.numbers_.at(name);
      have = crc_hex(values.data(), values.size() * sizeof(double));
    } else if (stored_name.rfind("t:", 0) == 0 && result.texts_.count(name) > 0) {
      const std::string& text = result.texts_.at(name);
      have = crc_hex(text.data(), text.size());
    } else {
      throw InputError(path + ": checkpoint dataset " + name + " is missing");
    }
    if (have != want) {
      throw InputError(path + ": checkpoint dataset " + name + " is damaged (its checksum is " +
                       have + ", the file lists " + want + ")");
    }
  }
  const std::size_t n_datasets = result.numbers_.size() + result.texts_.size() - 1;
  if (expected.size() != n_datasets) {
    throw InputError(path + ": checkpoint holds " + std::to_string(n_datasets) +
                     " datasets, its checksums list " + std::to_string(expected.size()));
  }
  result.texts_.erase(listed);
  return result;
}

void put_particles(CheckpointFile& file, const Particles& p) {
  file.put("particles/position", flatten(p.position));
  file.put("particles/reference_position", flatten(p.reference_position));
  file.put("particles/velocity", flatten(p.velocity));
  file.put("particles/mass", p.mass);
  file.put("particles/volume", p.volume);
  file.put("particles/initial_volume", p.initial_volume);
  file.put("particles/half_length", flatten(p.half_length));
  file.put("particles/stress", flatten(p.stress));
  std::vector<double> plastic(p.size()), material(p.size()), body(p.size());
  for (std::size_t k = 0; k < p.size(); ++k) {
    plastic[k] = p.state[k].plastic_strain;
    material[k] = p.material[k];
    body[k] = p.body[k];
  }
  file.put("particles/plastic_strain", plastic);
  file.put("particles/deformation_gradient", flatten(p.deformation_gradient));
  file.put("particles/material", material);
  file.put("particles/body", body);
}

void get_particles(const CheckpointFile& file, Particles& p) {
  const std::size_t n = p.size();  // the case's fill
  const auto field = [&](const std::string& name, std::size_t per_particle) {
    return file.get("particles/" + name, n * per_particle);
  };
  // Fixed at the fill: the checkpoint's must be the case's, bit for bit.
  const auto same = [&](const std::string& name, const std::vector<double>& fill) {
    if (field(name, fill.size() / std::max<std::size_t>(n, 1)) != fill)
      file.fail("particles/" + name, "differs from the case's particles (another case?)");
  };
  std::vector<double> material(n), body(n);
  for (std::size_t k = 0; k < n; ++k) {
    material[k] = p.material[k];
    body[k] = p.body[k];
  }
  same("reference_position", flatten(p.reference_position));
  same("mass", p.mass);
  same("initial_volume", p.initial_volume);
  same("half_length", flatten(p.half_length));
  same("material", material);
  same("body", body);

  p.position = unflatten<Vec2>(field("position", 2));
  p.velocity = unflatten<Vec2>(field("velocity", 2));
  p.volume = field("volume", 1);
  p.stress = unflatten<Stress>(field("stress", 4));
  p.deformation_gradient = unflatten<Mat2>(field("deformation_gradient", 4));
  const std::vector<double>& plastic = field("plastic_strain", 1);
  for (std::size_t k = 0; k < n; ++k) {
    if (!(p.volume[k] > 0.0))
      file.fail("particles/volume", "particle " + std::to_string(k) + " has a volume <= 0");
    if (!(p.deformation_gradient[k].determinant() > 0.0)) {
      file.fail("particles/deformation_gradient",
                "particle " + std::to_string(k) + " has det F <= 0");
    }
    if (!(plastic[k] >= 0.0))
      file.fail("particles/plastic_strain", "particle " + std::to_string(k) + " is negative");
    p.state[k].plastic_strain = plastic[k];
  }
}

void put_energy_ledger(CheckpointFile& file, const EnergyLedger& ledger) {
  EnergyLedger copy = ledger;
  const auto fields = copy.fields();
  for (std::size_t k = 0; k < fields.size(); ++k)
    file.put("solver/energy/" + std::string(EnergyLedger::kNames[k]), *fields[k]);
  if (!ledger.load_work_by_load.empty())
    file.put("solver/energy/load_work_by_load", ledger.load_work_by_load);
}

EnergyLedger get_energy_ledger(const CheckpointFile& file, std::size_t n_loads) {
  EnergyLedger ledger;
  const auto fields = ledger.fields();
  for (std::size_t k = 0; k < fields.size(); ++k)
    *fields[k] = file.scalar("solver/energy/" + std::string(EnergyLedger::kNames[k]));  // finite
  ledger.load_work_by_load.assign(n_loads, 0.0);
  if (n_loads > 0) ledger.load_work_by_load = file.get("solver/energy/load_work_by_load", n_loads);
  return ledger;
}

void put_solver_counters(CheckpointFile& file, const SolverCounters& counters) {
  file.put("solver/time", counters.time);
  file.put("solver/step", static_cast<double>(counters.step));
  file.put("solver/dt", counters.dt);
  file.put("solver/damping", counters.damping);
  file.put("solver/loads_active", counters.loads_active ? 1.0 : 0.0);
  file.put("solver/gravity_full", counters.gravity_full ? 1.0 : 0.0);
  file.put("solver/initial_stress_steps", static_cast<double>(counters.initial_stress_steps));
  put_energy_ledger(file, counters.energy);
}

SolverCounters get_solver_counters(const CheckpointFile& file, const Case& c, double dt,
                                   long n_steps) {
  SolverCounters n;
  n.dt = file.scalar("solver/dt");
  if (n.dt != dt) file.fail("solver/dt", "is not the case's time step");
  n.step = file.integer("solver/step", 0, n_steps - 1);
  n.time = file.scalar("solver/time", 0.0, c.time.end_time);
  if (std::abs(n.time - static_cast<double>(n.step) * n.dt) > 1e-6 * (n.time + n.dt))
    file.fail("solver/time", "is not the step count times the time step");
  n.damping = file.scalar("solver/damping", 0.0, 1e300);
  n.loads_active = file.integer("solver/loads_active", 0, 1) == 1;
  n.gravity_full = file.integer("solver/gravity_full", 0, 1) == 1;
  n.initial_stress_steps =
      file.integer("solver/initial_stress_steps", 0, static_cast<long>(c.time.max_steps));
  n.energy = get_energy_ledger(file, c.loads.size());
  return n;
}

}  // namespace pfm

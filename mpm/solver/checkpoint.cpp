#include "mpm/solver/checkpoint.hpp"

#include <hdf5.h>

#include <cstdio>
#include <filesystem>
#include <stdexcept>

#include "mpm/core/json_input.hpp"
#include "mpm/solver/hdf5_untimed.hpp"

namespace pfm {

namespace {

/// Closes an HDF5 handle when it goes out of scope.
class Handle {
 public:
  Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~Handle() {
    if (id_ >= 0) close_(id_);
  }
  Handle(const Handle&) = delete;
  Handle& operator=(const Handle&) = delete;
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

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

void write_array(hid_t file, const std::string& name, hid_t file_type, hid_t memory_type,
                 const void* data, std::size_t count) {
  hsize_t dims[1] = {count};
  const Handle space(H5Screate_simple(1, dims, nullptr), H5Sclose);
  const Handle set(H5Dcreate2(file, name.c_str(), file_type, space.get(), H5P_DEFAULT,
                              UntimedCreation(H5P_DATASET_CREATE).get(), H5P_DEFAULT),
                   H5Dclose);
  if (!set.ok()) throw std::runtime_error("checkpoint: cannot create dataset " + name);
  if (count > 0 && H5Dwrite(set.get(), memory_type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) < 0)
    throw std::runtime_error("checkpoint: cannot write dataset " + name);
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

const std::vector<double>& CheckpointFile::get(const std::string& name) const {
  const auto it = numbers_.find(name);
  if (it == numbers_.end()) throw InputError(file_ + ": checkpoint has no dataset " + name);
  return it->second;
}

double CheckpointFile::scalar(const std::string& name) const {
  const std::vector<double>& values = get(name);
  if (values.size() != 1)
    throw InputError(file_ + ": checkpoint dataset " + name + " is not a single value");
  return values[0];
}

const std::string& CheckpointFile::text(const std::string& name) const {
  const auto it = texts_.find(name);
  if (it == texts_.end()) throw InputError(file_ + ": checkpoint has no text " + name);
  return it->second;
}

void CheckpointFile::write(const std::string& path) const {
  const std::string temporary = path + ".tmp";
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  {
    const Handle file(H5Fcreate(temporary.c_str(), H5F_ACC_TRUNC,
                                UntimedCreation(H5P_FILE_CREATE).get(), H5P_DEFAULT),
                      H5Fclose);
    if (!file.ok()) throw std::runtime_error("cannot create " + temporary);
    for (const auto& [name, values] : numbers_) {
      write_array(file.get(), "n:" + encode(name), H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, values.data(),
                  values.size());
    }
    for (const auto& [name, text] : texts_) {
      write_array(file.get(), "t:" + encode(name), H5T_STD_U8LE, H5T_NATIVE_UCHAR, text.data(),
                  text.size());
    }
    if (H5Fflush(file.get(), H5F_SCOPE_GLOBAL) < 0)
      throw std::runtime_error("cannot flush " + temporary);
  }
  std::filesystem::rename(temporary, path);
}

CheckpointFile CheckpointFile::read(const std::string& path) {
  CheckpointFile result;
  result.file_ = path;
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  if (!std::filesystem::exists(path)) throw InputError(path + ": no checkpoint");
  const Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) throw InputError(path + ": not a readable HDF5 checkpoint");
  ReadContext context{&result, &result.numbers_, &result.texts_, path, ""};
  auto visit = [](hid_t group, const char* raw_name, const H5L_info_t*, void* data) -> herr_t {
    auto* c = static_cast<ReadContext*>(data);
    const std::string name(raw_name);
    const Handle set(H5Dopen2(group, raw_name, H5P_DEFAULT), H5Dclose);
    const Handle space(H5Dget_space(set.get()), H5Sclose);
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
  const std::size_t n = file.get("particles/mass").size();
  auto sized = [&](const std::string& name, std::size_t per_particle) {
    const std::vector<double>& values = file.get("particles/" + name);
    if (values.size() != n * per_particle)
      throw InputError("checkpoint: particles/" + name + " has the wrong length");
    return values;
  };
  p.position = unflatten<Vec2>(sized("position", 2));
  p.reference_position = unflatten<Vec2>(sized("reference_position", 2));
  p.velocity = unflatten<Vec2>(sized("velocity", 2));
  p.mass = sized("mass", 1);
  p.volume = sized("volume", 1);
  p.initial_volume = sized("initial_volume", 1);
  p.half_length = unflatten<Vec2>(sized("half_length", 2));
  p.stress = unflatten<Stress>(sized("stress", 4));
  p.deformation_gradient = unflatten<Mat2>(sized("deformation_gradient", 4));
  const std::vector<double> plastic = sized("plastic_strain", 1);
  const std::vector<double> material = sized("material", 1);
  const std::vector<double> body = sized("body", 1);
  p.state.assign(n, PointState{});
  p.material.assign(n, 0);
  p.body.assign(n, 0);
  for (std::size_t k = 0; k < n; ++k) {
    p.state[k].plastic_strain = plastic[k];
    p.material[k] = static_cast<int>(material[k]);
    p.body[k] = static_cast<int>(body[k]);
  }
}

void put_energy_ledger(CheckpointFile& file, const EnergyLedger& ledger) {
  EnergyLedger copy = ledger;
  const auto fields = copy.fields();
  for (std::size_t k = 0; k < fields.size(); ++k)
    file.put("solver/energy/" + std::string(EnergyLedger::kNames[k]), *fields[k]);
}

EnergyLedger get_energy_ledger(const CheckpointFile& file) {
  EnergyLedger ledger;
  const auto fields = ledger.fields();
  for (std::size_t k = 0; k < fields.size(); ++k)
    *fields[k] = file.scalar("solver/energy/" + std::string(EnergyLedger::kNames[k]));
  return ledger;
}

}  // namespace pfm

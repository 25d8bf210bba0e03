#include "mpm/step/particle_input.hpp"

#include <hdf5.h>

#include <cmath>
#include <vector>

#include "mpm/core/json_input.hpp"
#include "mpm/step/hdf5_untimed.hpp"

namespace pfm {

namespace {

bool ends_with(const std::string& s, const std::string& tail) {
  return s.size() >= tail.size() && s.compare(s.size() - tail.size(), tail.size(), tail) == 0;
}

// One dataset of `group` read as doubles: its values and its shape (rows, columns: 1 for a
// vector). Empty values when `required` is false and the dataset is not there.
struct Dataset {
  std::vector<double> values;
  std::size_t rows = 0, columns = 0;
};

Dataset read_dataset(hid_t group, const std::string& where, const char* name, bool required) {
  Dataset out;
  if (H5Lexists(group, name, H5P_DEFAULT) <= 0) {
    if (required) throw InputError(where + ": no dataset \"" + name + "\"");
    return out;
  }
  const H5Handle set(H5Dopen2(group, name, H5P_DEFAULT), H5Dclose);
  if (!set.ok()) throw InputError(where + "/" + name + ": not a dataset");
  const H5Handle space(H5Dget_space(set.get()), H5Sclose);
  const int rank = H5Sget_simple_extent_ndims(space.get());
  hsize_t dims[2] = {0, 1};
  if (rank < 1 || rank > 2 || H5Sget_simple_extent_dims(space.get(), dims, nullptr) < 0) {
    throw InputError(where + "/" + name + ": expected a dataset of rank 1 or 2");
  }
  out.rows = dims[0];
  out.columns = rank == 2 ? dims[1] : 1;
  out.values.resize(out.rows * out.columns);
  if (!out.values.empty() &&
      H5Dread(set.get(), H5T_NATIVE_DOUBLE, H5S_ALL, H5S_ALL, H5P_DEFAULT, out.values.data()) < 0) {
    throw InputError(where + "/" + name + ": cannot be read as numbers");
  }
  for (std::size_t k = 0; k < out.values.size(); ++k) {
    if (!std::isfinite(out.values[k])) {
      throw InputError(where + "/" + name + ": row " + std::to_string(k / out.columns + 1) +
                       " is not finite");
    }
  }
  return out;
}

// A dataset of n rows and `columns` columns (or, with columns 0, any of 2 or 3).
void require_shape(const Dataset& d, std::size_t n, std::size_t columns, const std::string& where,
                   const char* name) {
  const bool ok =
      d.rows == n && (columns == 0 ? (d.columns == 2 || d.columns == 3) : d.columns == columns);
  if (!ok) {
    throw InputError(where + "/" + name + ": expected " + std::to_string(n) + " rows" +
                     (columns == 0   ? " of 2 or 3 columns"
                      : columns == 1 ? ""
                                     : " of 2 columns") +
                     ", got " + std::to_string(d.rows) + " x " + std::to_string(d.columns));
  }
}

}  // namespace

ParticleTable read_particle_h5(const std::string& path, const std::string& group_name) {
  const std::string where = path + ":" + group_name;
  // HDF5 prints its error stack on failure by default; the messages here say what went wrong.
  H5Eset_auto2(H5E_DEFAULT, nullptr, nullptr);
  if (H5Fis_hdf5(path.c_str()) <= 0) throw InputError(path + ": not an HDF5 file");
  const H5Handle file(H5Fopen(path.c_str(), H5F_ACC_RDONLY, H5P_DEFAULT), H5Fclose);
  if (!file.ok()) throw InputError(path + ": cannot open the HDF5 file");
  const H5Handle group(H5Gopen2(file.get(), group_name.c_str(), H5P_DEFAULT), H5Gclose);
  if (!group.ok()) throw InputError(where + ": no such group");

  const Dataset volume = read_dataset(group.get(), where, "volume", true);
  const std::size_t n = volume.rows;
  require_shape(volume, n, 1, where, "volume");
  if (n == 0) throw InputError(where + "/volume: no particles");
  ParticleTable table;
  const Dataset position = read_dataset(group.get(), where, "position", false);
  if (!position.values.empty()) {
    require_shape(position, n, 0, where, "position");
    for (std::size_t k = 0; k < n; ++k) {
      table.position.emplace_back(position.values[k * position.columns],
                                  position.values[k * position.columns + 1]);
    }
  } else {
    const Dataset x = read_dataset(group.get(), where, "x", true);
    const Dataset y = read_dataset(group.get(), where, "y", true);
    require_shape(x, n, 1, where, "x");
    require_shape(y, n, 1, where, "y");
    for (std::size_t k = 0; k < n; ++k) table.position.emplace_back(x.values[k], y.values[k]);
  }
  for (std::size_t k = 0; k < n; ++k) {
    if (!(volume.values[k] > 0.0)) {
      throw InputError(where + "/volume: row " + std::to_string(k + 1) + " must be > 0");
    }
    table.volume.push_back(volume.values[k]);
  }
  const char* stress_names[4] = {"sxx", "syy", "sxy", "szz"};
  Dataset stress[4];
  int n_stress = 0;
  for (int c = 0; c < 4; ++c) {
    stress[c] = read_dataset(group.get(), where, stress_names[c], false);
    if (H5Lexists(group.get(), stress_names[c], H5P_DEFAULT) > 0) {
      require_shape(stress[c], n, 1, where, stress_names[c]);
      ++n_stress;
    }
  }
  if (n_stress != 0 && n_stress != 4) {
    throw InputError(where + ": stress datasets must be all of sxx, syy, sxy, szz or none");
  }
  if (n_stress == 4) {
    for (std::size_t k = 0; k < n; ++k) {
      table.stress.emplace_back(stress[0].values[k], stress[1].values[k], stress[2].values[k],
                                stress[3].values[k]);
    }
  }
  const Dataset material = read_dataset(group.get(), where, "material", false);
  if (H5Lexists(group.get(), "material", H5P_DEFAULT) > 0) {
    require_shape(material, n, 1, where, "material");
    for (std::size_t k = 0; k < n; ++k) {
      const double m = material.values[k];
      if (!(m >= 0.0 && m == std::floor(m) && m < 1e9)) {
        throw InputError(where + "/material: row " + std::to_string(k + 1) +
                         " must be a whole number >= 0 (an index into the case's materials)");
      }
      table.material.push_back(static_cast<int>(m));
    }
  }
  return table;
}

ParticleTable read_particle_file(const std::string& name) {
  const std::size_t colon = name.find(".h5:/") != std::string::npos     ? name.find(".h5:/") + 3
                            : name.find(".hdf5:/") != std::string::npos ? name.find(".hdf5:/") + 5
                                                                        : std::string::npos;
  if (colon != std::string::npos) {
    return read_particle_h5(name.substr(0, colon), name.substr(colon + 1));
  }
  if (ends_with(name, ".h5") || ends_with(name, ".hdf5")) return read_particle_h5(name, "/");
  return read_particle_csv(name);
}

}  // namespace pfm

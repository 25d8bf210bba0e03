// HDF5 helpers. Creation properties without object times: by default HDF5 stamps every dataset
// (and, on request, group) with the second it was made, so two runs of the same input wrote files
// that differed in those bytes. With these, the same input and thread count give byte-identical .h5
// files.
#pragma once

#include <hdf5.h>

#include <algorithm>
#include <string>
#include <vector>

namespace pfm {

/// Writes `data` (rows x cols, row-major; 1-D when cols is 1) as dataset `name` of `group` in
/// the output file `file`, compressed when `compress` (UntimedCreation::compressed): doubles as
/// IEEE binary64, integers as 64-bit integers; IoError naming the file and dataset when HDF5
/// fails.
void write_h5_dataset(hid_t group, const std::string& file, const char* name,
                      const std::vector<double>& data, std::size_t rows, std::size_t cols,
                      bool compress);
void write_h5_dataset(hid_t group, const std::string& file, const char* name,
                      const std::vector<long long>& data, std::size_t rows, std::size_t cols,
                      bool compress);
/// Attaches the attribute `name` = value (a double, or a string) to the object `object`.
void write_h5_attribute(hid_t object, const std::string& file, const char* name, double value);
void write_h5_attribute(hid_t object, const std::string& file, const char* name,
                        const std::string& value);

/// A creation property list of `kind` (H5P_FILE_CREATE, H5P_GROUP_CREATE, H5P_DATASET_CREATE)
/// that does not record object times; closed at the end of its scope (a temporary lives to the
/// end of the call it is passed to).
class UntimedCreation {
 public:
  explicit UntimedCreation(hid_t kind) : id_(H5Pcreate(kind)) {
    if (id_ >= 0) H5Pset_obj_track_times(id_, false);
  }
  ~UntimedCreation() {
    if (id_ >= 0) H5Pclose(id_);
  }
  UntimedCreation(const UntimedCreation&) = delete;
  UntimedCreation& operator=(const UntimedCreation&) = delete;
  hid_t get() const { return id_ >= 0 ? id_ : H5P_DEFAULT; }
  /// For a dataset creation list: chunks of at most 65,536 rows, byte shuffle and gzip level 1
  /// (output.compression "gzip"; `rows` > 0). Returns *this.
  UntimedCreation& compressed(std::size_t rows, std::size_t cols) {
    if (id_ < 0 || rows == 0) return *this;
    const hsize_t chunk[2] = {std::min<hsize_t>(rows, 65536), cols};
    H5Pset_chunk(id_, cols == 1 ? 1 : 2, chunk);
    H5Pset_shuffle(id_);
    H5Pset_deflate(id_, 1);
    return *this;
  }

 private:
  hid_t id_;
};

/// Closes an HDF5 handle when it goes out of scope (also when a write throws).
class H5Handle {
 public:
  H5Handle(hid_t id, herr_t (*close)(hid_t)) : id_(id), close_(close) {}
  ~H5Handle() {
    if (id_ >= 0) close_(id_);
  }
  H5Handle(const H5Handle&) = delete;
  H5Handle& operator=(const H5Handle&) = delete;
  hid_t get() const { return id_; }
  bool ok() const { return id_ >= 0; }
  /// Gives the handle up to the caller, who closes it.
  hid_t release() {
    const hid_t id = id_;
    id_ = -1;
    return id;
  }

 private:
  hid_t id_;
  herr_t (*close_)(hid_t);
};

/// Creates the group "step_<step, 8 digits>" of an output series in `file` (path `path`, for
/// messages) with its attributes `time` (s) and `step`; returns it open (close with H5Gclose).
/// IoError naming the file when HDF5 fails.
hid_t create_step_group(hid_t file, const std::string& path, long step, double time);

/// Ends an output step of a series: flushes `file` (IoError naming the step's group and the
/// file when HDF5 fails) and appends the step's time (s) and group name to `times` and `groups`.
void end_series_step(hid_t file, const std::string& path, long step, double time,
                     std::vector<double>& times, std::vector<std::string>& groups);

}  // namespace pfm

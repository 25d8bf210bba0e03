// HDF5 creation properties without object times: by default HDF5 stamps every dataset (and, on
// request, group) with the second it was made, so two runs of the same input wrote files that
// differed in those bytes. With these, the same input and thread count give byte-identical
// .h5 files.
#pragma once

#include <hdf5.h>

namespace pfm {

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

 private:
  hid_t id_;
};

}  // namespace pfm

// VTK XML output of the particles (output.vtk): one particles_<step>.vtu per output step, a
// vertex cell per point, and particles.pvd, the collection ParaView opens as a time series.
// Binary data, zlib-compressed, inline as base64 (the VTK XML format's "binary" encoding with
// vtkZLibDataCompressor and UInt64 headers), which ParaView, VTK and meshio read.
//
// Point data per step (float64 unless said): displacement and velocity (3 components, z = 0),
// sxx, syy, sxy, szz (kPa), eps_p, volume (m^2 per m), id (int64), material and body (int32),
// F11, F12, F21, F22.
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "mpm/core/output_folder.hpp"
#include "mpm/solver/particles.hpp"

namespace pfm {

class VtkSeriesWriter {
 public:
  explicit VtkSeriesWriter(OutputFolder& folder);
  /// Resumes the series of a restarted run with the given output steps (time, step): their
  /// .vtu files are the old run's, particles.pvd lists them and the steps written after.
  VtkSeriesWriter(OutputFolder& folder, const std::vector<std::pair<double, long>>& keep);

  void write(double time, long step, const Particles& particles);

 private:
  void write_pvd() const;
  OutputFolder& folder_;
  std::vector<std::pair<double, std::string>> files_;  // (time, file name)
};

/// The .vtu file's text of the particles (exposed for tests).
std::string particles_vtu(const Particles& particles);

}  // namespace pfm

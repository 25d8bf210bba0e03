// VTK XML output (output.vtk): per output step particles_<step>.vtu, a vertex cell per point,
// and with detection boundary_<step>.vtu, the detected loops as 2-node line cells, each series
// listed with its times in particles.pvd and boundary.pvd, which ParaView opens as time series.
// Binary data, zlib-compressed, inline as base64 (the VTK XML format's "binary" encoding with
// vtkZLibDataCompressor and UInt64 headers), which ParaView, VTK and meshio read.
//
// Point data of the particles (float64 unless said): displacement and velocity (3 components,
// z = 0), sxx, syy, sxy, szz (kPa), eps_p, volume (m^2 per m), id (int64), material and body
// (int32), F11, F12, F21, F22. Of the boundary: loop (int32, the loop of each point, as in
// boundary_<step>.csv).
#pragma once

#include <span>
#include <string>
#include <utility>
#include <vector>

#include "mpm/core/output_folder.hpp"
#include "mpm/step/particles.hpp"

namespace pfm {

/// One series: <name>_<step>.vtu per output step and <name>.pvd listing them.
class VtkSeriesWriter {
 public:
  VtkSeriesWriter(OutputFolder& folder, std::string name);
  /// Resumes the series of a restarted run with the given output steps (time, step): their
  /// files are the old run's, the .pvd lists them and the steps written after.
  VtkSeriesWriter(OutputFolder& folder, std::string name,
                  const std::vector<std::pair<double, long>>& keep);

  /// Writes the step's file (particles_vtu or boundary_vtu) and the .pvd.
  void write(double time, long step, const std::string& vtu);

 private:
  std::string file_name(long step) const;
  void write_pvd() const;
  OutputFolder& folder_;
  std::string name_;
  std::vector<std::pair<double, std::string>> files_;  // (time, file name)
};

/// The .vtu text of the particles.
std::string particles_vtu(const Particles& particles, std::span<const Stress> recovered = {});
/// The .vtu text of the loops of a detected boundary; closed[k]: loop k closes on itself.
std::string boundary_vtu(const std::vector<std::vector<Vec2>>& loops,
                         const std::vector<bool>& closed);

}  // namespace pfm

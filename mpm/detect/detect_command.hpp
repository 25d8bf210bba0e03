// `pfm-mpm detect PARTICLES.csv --config CONFIG.json --out OUT_DIR`: boundary detection on a
// particle file, with any detector of detector.hpp.
//
// PARTICLES.csv: a header line naming the columns, then one particle per line. Required columns
// x, y (m) and volume (m^2); optional F11, F12, F21, F22 (all four or none: the total deformation
// gradient), sxx, syy, sxy, szz (all four or none: the stress, kPa, tension positive) and
// material (an index into a case's materials, from 0); the detector uses x, y, volume and F, a
// body from a file (bodies[].particles) x, y, volume, the stress and the material. Other columns
// are ignored; blank lines and lines starting with '#' are skipped.
//
// CONFIG.json: the detector configuration of parse_detector_config() plus optional
//   "initial_spacing": m (default: sqrt of the median volume),
//   "grid": {"origin": [x, y] (m), "cell_size": m, "n_cells": [nx, ny]}
//     (default: cell_size = 2 initial_spacing, the particles' box plus 3 kernel radii and a cell).
//
// OUT_DIR (created only after the input has been read and the detection has succeeded):
//   boundary.csv  "loop,x,y": the contours in the order of contour.hpp, loop numbered from 0
//   summary.json  loops, closed/open counts, points per loop, timings (s), refinement, grid
// Both files are written to a temporary name and renamed, so a reader never sees half a file.
#pragma once

#include <string>
#include <vector>

#include "mpm/core/grid.hpp"
#include "mpm/core/json_input.hpp"
#include "mpm/core/types.hpp"

namespace pfm {

/// Particles read from a CSV file (see above). Throws InputError naming file, line and column.
struct ParticleTable {
  std::vector<Vec2> position;
  std::vector<double> volume;
  std::vector<Mat2> deformation_gradient;  ///< empty when the file has no F columns
  std::vector<Stress> stress;  ///< kPa (xx, yy, xy, zz); empty without the sxx..szz columns
  std::vector<int> material;   ///< index into a case's materials; empty without the column
};
ParticleTable read_particle_csv(const std::string& path);

/// The detection grid of a "grid" block {"origin": [x, y], "cell_size": m, "n_cells": [nx, ny]}
/// (at most 5e7 nodes); InputError with the block's JSON pointer.
Grid parse_detection_grid(const JsonView& grid);

/// Runs the command on `threads` OpenMP threads (0: every core; the boundary is the same for any
/// count); returns 0 on success. Bad input throws InputError before OUT_DIR exists. summary.json
/// records the provenance: program, git revision, build type, the two input files, the command
/// line, the thread count, the start time and the units.
int run_detect_command(const std::string& particles_csv, const std::string& config_json,
                       const std::string& out_dir, int threads = 0,
                       const std::string& command_line = "", bool overwrite = false);

}  // namespace pfm

// Particle files that bodies are read from (bodies[].particles): CSV (read_particle_csv,
// mpm/detect/detect_command.hpp) or HDF5.
#pragma once

#include <string>

#include "mpm/detect/detect_command.hpp"

namespace pfm {

/// The particles of an HDF5 file: the datasets of the group `group` ("/" for the root), either
/// x and y (n) or position (n, 2) or (n, 3) (m; a third column, z, is not read), volume (n, m^2
/// per m), and optionally sxx, syy, sxy, szz (all four or none: kPa, tension positive) and
/// material (n integers, an index into the case's materials). A step group of a run's
/// particles.h5 is such a group (its positions and volumes are the state of that step).
/// InputError naming the file, the group and the dataset when one is missing, of the wrong
/// shape, not finite, or a volume is not positive.
ParticleTable read_particle_h5(const std::string& path, const std::string& group);

/// A particle file by its name: "file.h5" or "file.hdf5" (root group), "file.h5:/group", or a
/// CSV file (any other name).
ParticleTable read_particle_file(const std::string& name);

}  // namespace pfm

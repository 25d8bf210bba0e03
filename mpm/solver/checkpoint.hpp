// Checkpoints: the complete state of a run in one HDF5 file (checkpoint.h5 in the output
// directory), so that `pfm-mpm run --restart DIR` continues a killed run and ends bitwise where
// the uninterrupted run ends.
//
// The file is a flat set of named datasets: arrays of doubles (IEEE 754 binary64, so values
// round-trip bitwise; integers are stored exactly below 2^53) and texts (bytes), and the text
// "checksums": one line "<dataset> <CRC-32 of its bytes, 8 hex digits>" per dataset (zlib's
// CRC-32, as Python's zlib.crc32). It is written to checkpoint.h5.tmp and renamed, so a reader
// sees the previous checkpoint or the new one, never half of one.
//
// Reading verifies every checksum and that the listed datasets are all there; a restart then
// validates every restored value (finite, in range, sizes and indices consistent with the case)
// as the case reader validates input. Any failure is an InputError naming the file and the
// dataset (exit 2), so a damaged checkpoint is refused, never continued.
#pragma once

#include <map>
#include <span>
#include <string>
#include <vector>

#include "mpm/step/case.hpp"
#include "mpm/step/energy_ledger.hpp"
#include "mpm/step/initial_stress.hpp"
#include "mpm/step/particles.hpp"

namespace pfm {

class CheckpointFile {
 public:
  void put(const std::string& name, std::span<const double> values);
  void put(const std::string& name, double value) { put(name, std::span<const double>(&value, 1)); }
  void put_text(const std::string& name, const std::string& text);

  bool has(const std::string& name) const;
  /// The array `name`; InputError naming the file and the dataset when it is missing or holds a
  /// value that is not finite (no state of a run that went on is).
  const std::vector<double>& get(const std::string& name) const;
  /// The array `name` with `size` values.
  const std::vector<double>& get(const std::string& name, std::size_t size) const;
  /// A single value (an array of length 1), in [lo, hi].
  double scalar(const std::string& name, double lo = -1e300, double hi = 1e300) const;
  /// A single value that is an integer in [lo, hi].
  long integer(const std::string& name, long lo, long hi) const;
  const std::string& text(const std::string& name) const;
  /// Throws InputError "<file>: checkpoint dataset <name>: <message>".
  [[noreturn]] void fail(const std::string& name, const std::string& message) const;

  /// Writes `path`.tmp, then renames it to `path`; IoError when a write fails (the temporary
  /// is removed, the previous checkpoint stays).
  void write(const std::string& path) const;
  /// Reads a checkpoint; InputError when the file is missing, unreadable, not a checkpoint, or
  /// a dataset is missing or fails its checksum.
  static CheckpointFile read(const std::string& path);

 private:
  std::string file_;  ///< where it was read from (messages)
  std::map<std::string, std::vector<double>> numbers_;
  std::map<std::string, std::string> texts_;
};

/// Every particle field under "particles/<field>".
void put_particles(CheckpointFile& file, const Particles& particles);
/// Restores every particle field over `particles`, which hold the case's fill: InputError if a
/// field is missing, has another length, or a value is out of range (volume, det F <= 0), or
/// a field fixed at the fill (reference position, mass, initial volume, material, body) differs
/// from the case's.
void get_particles(const CheckpointFile& file, Particles& particles);

/// The energy ledger under "solver/energy/<term>" (EnergyLedger::kNames).
void put_energy_ledger(CheckpointFile& file, const EnergyLedger& ledger);
/// Restores it (with the work of each of the case's n_loads loads); InputError naming the
/// dataset when a term is missing.
EnergyLedger get_energy_ledger(const CheckpointFile& file, std::size_t n_loads);

/// The solver's counters (SolverCounters: time, step, time step, damping, load switches,
/// initial-stress steps) under "solver/<name>", with the energy ledger.
void put_solver_counters(CheckpointFile& file, const SolverCounters& counters);
/// Restores them for case `c` run with time step `dt` for `n_steps` steps, each value checked as
/// the case reader would check it: InputError naming the dataset when the time step is not the
/// case's, the step is not before the last, the time is not the step count times the time step,
/// or a value is out of its range.
SolverCounters get_solver_counters(const CheckpointFile& file, const Case& c, double dt,
                                   long n_steps);

/// Flattens arrays of Eigen fixed-size vectors/matrices (column-major) and back.
template <typename T>
std::vector<double> flatten(const std::vector<T>& values) {
  std::vector<double> out;
  out.reserve(values.size() * static_cast<std::size_t>(T::SizeAtCompileTime));
  for (const T& v : values) out.insert(out.end(), v.data(), v.data() + T::SizeAtCompileTime);
  return out;
}
template <typename T>
std::vector<T> unflatten(const std::vector<double>& data) {
  constexpr auto size = static_cast<std::size_t>(T::SizeAtCompileTime);
  std::vector<T> out(data.size() / size);
  for (std::size_t k = 0; k < out.size(); ++k)
    std::copy(data.begin() + static_cast<std::ptrdiff_t>(k * size),
              data.begin() + static_cast<std::ptrdiff_t>((k + 1) * size), out[k].data());
  return out;
}

}  // namespace pfm

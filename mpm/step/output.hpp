// Output writers. Every file is complete whenever it can be seen: CSV and JSON files are written
// to a temporary name and renamed; the XDMF index of the HDF5 particle series is rewritten (also
// by rename) after each HDF5 step is flushed, so it never names a step that is not on disk.
#pragma once

#include <nlohmann/json.hpp>
#include <span>
#include <sstream>
#include <string>
#include <vector>

#include "mpm/core/exact_text.hpp"
#include "mpm/core/output_folder.hpp"
#include "mpm/step/energy_ledger.hpp"
#include "mpm/step/particles.hpp"

namespace pfm {

/// Pieces of the XDMF 3 files that index a time series of HDF5 groups (ParaView, meshio): a
/// temporal collection of one uniform grid per output step. `path`: "FILE.h5:/GROUP/DATASET".
namespace xdmf {
/// The file's head, up to the opening of the collection `name`.
std::string open(const std::string& name);
/// The opening of a step's grid: its group name and time (s).
std::string step(const std::string& group, double time);
/// A dataset of `dimensions` ("N" or "N 3") 8-byte integers or floats.
std::string data_item(const std::string& dimensions, bool integer, const std::string& path);
/// The step's topology: `type` (Polyvertex, Polyline, Quadrilateral), its element count and,
/// when > 0, the nodes per element, with the connectivity `item` (data_item()).
std::string topology(const char* type, std::size_t elements, int nodes_per_element,
                     const std::string& item);
/// The step's geometry: n points (x, y, z) at `path`.
std::string geometry(std::size_t n, const std::string& path);
/// An attribute of n values (`vector`: n x 3) on the nodes or, with `cell`, the cells.
std::string attribute(const char* name, bool vector, bool cell, std::size_t n, bool integer,
                      const std::string& path);
/// The closing of a step's grid.
inline constexpr const char* kEndStep = "</Grid>\n";
/// The file's tail: the closing of the collection, the domain and the file.
inline constexpr const char* kClose = "</Grid>\n</Domain>\n</Xdmf>\n";
}  // namespace xdmf

/// timeseries.csv, held in memory: time, kinetic_energy, external_work, internal_work,
/// damping_work, momentum_x, momentum_y; with surface loads the resultants of the loads
/// (load_target, load_applied, load_lost, load_off_grid, each _fx and _fy), the numbers of
/// loaded and lost nodes and the lost moment (load_lost_moment, kN m/m about (0, 0)); then the
/// energy ledger (mpm/step/energy_ledger.hpp): elastic_energy, plastic_dissipation, gravity_work,
/// load_work, constraint_work, transfer_to_grid, transfer_to_particles, internal_force_work,
/// rotation_work, volume_work and energy_error (internal_work is the ledger's stress_power,
/// external_work gravity_work + load_work); last, the work of each of the case's loads,
/// load_work_0, load_work_1, ... (EnergyLedger::load_work_by_load); the moving boundary
/// conditions' reactions; and per constraint on the detected boundary its force on the body
/// and its gap, constraint_<k>_fx, constraint_<k>_fy (kN/m), constraint_<k>_gap (m, the
/// root-mean-square gap; ConstraintReport). The same columns for the MPM and the UL-FEM runs.
class TimeSeriesTable {
 public:
  /// with_loads: the resultant columns; n_loads: the number of the case's loads; reactions:
  /// the names of the moving boundary conditions (reaction_names, prescribed_velocity.hpp),
  /// whose reactions (EnergyBalance::reactions) are the columns reaction_<name>_fx,
  /// reaction_<name>_fy (kN/m).
  /// n_constraints: the number of constraints on the detected boundary.
  TimeSeriesTable(bool with_loads, std::size_t n_loads,
                  const std::vector<std::string>& reactions = {}, std::size_t n_constraints = 0);
  /// One line. `loads` (read only with the load columns): target, applied, lost, off_grid,
  /// loaded_nodes and lost_nodes.
  template <class Loads>
  void record(double time, const EnergyBalance& e, const Loads& loads,
              std::span<const ConstraintReport> constraints = {}) {
    text_ << format_exact(time) << ',' << format_exact(e.kinetic_energy) << ','
          << format_exact(e.external_work()) << ',' << format_exact(e.internal_work()) << ','
          << format_exact(e.damping_work()) << ',' << format_exact(e.momentum.x()) << ','
          << format_exact(e.momentum.y());
    if (with_loads_) {
      for (const auto& f : {loads.target, loads.applied, loads.lost, loads.off_grid})
        text_ << ',' << format_exact(f.x()) << ',' << format_exact(f.y());
      text_ << ',' << loads.loaded_nodes << ',' << loads.lost_nodes << ','
            << format_exact(loads.lost_moment);
    }
    const EnergyLedger& l = e.ledger;
    for (const double v : {e.elastic_energy, l.plastic_dissipation, l.gravity_work, l.load_work,
                           l.constraint_work, l.transfer_to_grid, l.transfer_to_particles,
                           l.internal_force_work, l.rotation_work, l.volume_work, e.energy_error()})
      text_ << ',' << format_exact(v);
    for (std::size_t k = 0; k < n_loads_; ++k)
      text_ << ',' << format_exact(k < l.load_work_by_load.size() ? l.load_work_by_load[k] : 0.0);
    for (std::size_t k = 0; k < n_reactions_; ++k) {
      const Vec2 r = k < e.reactions.size() ? e.reactions[k] : Vec2::Zero();
      text_ << ',' << format_exact(r.x()) << ',' << format_exact(r.y());
    }
    for (std::size_t k = 0; k < n_constraints_; ++k) {
      const ConstraintReport r = k < constraints.size() ? constraints[k] : ConstraintReport{};
      text_ << ',' << format_exact(r.force.x()) << ',' << format_exact(r.force.y()) << ','
            << format_exact(r.rms_gap);
    }
    text_ << '\n';
  }
  std::string text() const { return text_.str(); }
  /// Continues a table saved with text() (restart).
  void restore(const std::string& text);

 private:
  bool with_loads_;
  std::size_t n_loads_;
  std::size_t n_reactions_;
  std::size_t n_constraints_;
  std::ostringstream text_;
};

/// Particle time series: particles.h5 (one group per output step) + particles.xdmf (a temporal
/// collection of Polyvertex grids that ParaView and meshio open).
///
/// Per step, datasets of length N (N = number of particles): position (N x 3, z = 0),
/// displacement (N x 3), velocity (N x 3), sxx, syy, sxy, szz (kPa), eps_p, volume (m^2),
/// id, material, body, F11, F12, F21, F22 (the deformation gradient since the start),
/// sxx_rec, syy_rec, sxy_rec, szz_rec (kPa: the stress recovered next to a boundary of known
/// traction, mpm/core/stress_recovery.hpp; the point's own elsewhere, and everywhere when the
/// run has no recovery). The XDMF
/// gives position as the geometry and again as a point attribute: meshio's TimeSeriesReader
/// keeps the first step's geometry for every step, and reads each step's positions from it.
class ParticleSeriesWriter {
 public:
  /// `compress`: the datasets gzip-compressed (the case's output.compression).
  ParticleSeriesWriter(OutputFolder& folder, bool compress);
  /// Resumes the series of a restarted run: particles.h5 is rebuilt with only the given
  /// output steps (time, step) of the old file, in that order (later steps are dropped).
  ParticleSeriesWriter(OutputFolder& folder, bool compress,
                       const std::vector<std::pair<double, long>>& keep);
  ~ParticleSeriesWriter();
  ParticleSeriesWriter(const ParticleSeriesWriter&) = delete;
  ParticleSeriesWriter& operator=(const ParticleSeriesWriter&) = delete;

  /// recovered: per particle the recovered stress (empty: the particles' own).
  void write(double time, long step, const Particles& particles,
             std::span<const Stress> recovered = {});
  /// Extra polylines (detected boundary) listed beside the particles of the last step written.
  int n_steps() const { return static_cast<int>(times_.size()); }
  /// Before a checkpoint: copies particles.h5 as it is now to particles.h5.checkpoint (by a
  /// temporary and a rename; not again while no output step has been added), which a restart
  /// rebuilds the series from. HDF5 appends an output step by rewriting the file's metadata in
  /// place, so a run killed during that write can leave particles.h5 unreadable.
  void copy_for_checkpoint(OutputFolder& folder);

 private:
  void write_xdmf() const;
  std::string h5_path_, xdmf_path_;
  std::size_t steps_at_copy_ = static_cast<std::size_t>(-1);  // none yet
  bool compress_ = false;
  long file_ = -1;  // hid_t
  std::vector<double> times_;
  std::vector<std::string> groups_;
  std::vector<std::size_t> counts_;
};

/// Boundary time series beside the particles: boundary.h5 (one group per output step) +
/// boundary.xdmf (a temporal collection of Polyline grids with 2-node segments; a closed loop
/// includes its closing segment). Per step: position (P x 3, z = 0), segments (S x 2, int64
/// point indices), loop (P, the loop number of each point, as in the boundary CSV); in the XDMF
/// position is also a point attribute (as for the particles).
class BoundarySeriesWriter {
 public:
  BoundarySeriesWriter(OutputFolder& folder, bool compress);
  /// Resumes the series of a restarted run (as ParticleSeriesWriter).
  BoundarySeriesWriter(OutputFolder& folder, bool compress,
                       const std::vector<std::pair<double, long>>& keep);
  ~BoundarySeriesWriter();
  BoundarySeriesWriter(const BoundarySeriesWriter&) = delete;
  BoundarySeriesWriter& operator=(const BoundarySeriesWriter&) = delete;

  /// loops[k] is a polyline; closed[k] says whether it closes on itself.
  void write(double time, long step, const std::vector<std::vector<Vec2>>& loops,
             const std::vector<bool>& closed);
  /// Before a checkpoint: boundary.h5 to boundary.h5.checkpoint (as ParticleSeriesWriter).
  void copy_for_checkpoint(OutputFolder& folder);

 private:
  void write_xdmf() const;
  std::string h5_path_, xdmf_path_;
  std::size_t steps_at_copy_ = static_cast<std::size_t>(-1);  // none yet
  bool compress_ = false;
  long file_ = -1;  // hid_t
  std::vector<double> times_;
  std::vector<std::string> groups_;
  std::vector<std::size_t> points_, segments_;
};

/// final_particles.csv: id,x,y,vx,vy,sxx,syy,sxy,szz,eps_p,volume (+ ux,uy,material,body, the
/// deformation gradient F11,F12,F21,F22 and the recovered stress sxx_rec,syy_rec,sxy_rec,szz_rec,
/// as ParticleSeriesWriter).
/// run.json's summary.energy: every energy and ledger term (kJ/m), energy_error, the largest
/// term and their ratio.
nlohmann::json energy_summary(const EnergyBalance& e);

std::string particles_csv(const Particles& particles, std::span<const Stress> recovered = {});

}  // namespace pfm

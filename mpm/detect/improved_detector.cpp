// The improved detector's pipeline (see detector.hpp): one survey of the cloud, the narrow band of
// cells near the boundary, the coarse screening, the guards, and the contours of the exact field
// (improved_field.cpp) on the refined grid with their containment check.
#include <omp.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <functional>
#include <limits>
#include <memory>
#include <optional>
#include <span>
#include <unordered_map>
#include <vector>

#include "mpm/detect/detect_internal.hpp"
#include "mpm/detect/improved_field.hpp"
#include "mpm/detect/loop_classes.hpp"
#include "mpm/detect/marching_squares.hpp"
#include "mpm/detect/vector_loops.hpp"

namespace pfm::detail {

namespace {

// The loops on the OpenMP threads share their work by chunks of some 30-60 microseconds (more
// than a thread takes to join; a loop of one chunk stays on the calling thread). Chunks, not
// threads, decide what is added in which order, so the results do not depend on the thread
// count. Particles per chunk of the survey's sweep (about 4 ns each):
constexpr std::size_t kParticleChunk = 16384;
// Particles per chunk of the loops over the band's particles (copies, containment verdicts: 10-20
// ns each):
constexpr std::size_t kBandChunk = 4096;
// Field evaluations per chunk of a batch (about 60 ns each):
constexpr std::size_t kEvaluationChunk = 512;
// Cells per chunk of the loops over grid rows (about 1 ns each):
constexpr std::size_t kCellChunk = 32768;

// Rows of `width` cells per chunk of a loop over grid rows.
std::size_t rows_per_chunk(int width) {
  return std::max<std::size_t>(1, kCellChunk / static_cast<std::size_t>(std::max(width, 1)));
}

}  // namespace

// Values of type T on the fine field grid stored in blocks of r x r, one per coarse (grid) cell,
// allocated on first use: the narrow band touches few blocks of a large refined grid. Block
// (bi, bj) holds the fine indices [bi r, bi r + r) x [bj r, bj r + r); the blocks run one past
// the last coarse cell so the last node row and column have a home.
template <class T>
class BlockStore {
 public:
  BlockStore(int n_coarse_x, int n_coarse_y, int r, T fill)
      : n_x_(n_coarse_x + 1),
        r_(r),
        fill_(fill),
        offset_(static_cast<std::size_t>(n_coarse_x + 1) * (n_coarse_y + 1), -1) {
    // The block and the place in it of every fine index 0 .. max(n_coarse) r + r - 1, looked up:
    // a division by the run-time r costs more than the rest of a read, and the contouring reads
    // each fine node several times.
    const int n = (std::max(n_coarse_x, n_coarse_y) + 1) * r;
    block_.resize(static_cast<std::size_t>(n));
    within_.resize(static_cast<std::size_t>(n));
    for (int k = 0; k < n; ++k) {
      block_[static_cast<std::size_t>(k)] = k / r;
      within_[static_cast<std::size_t>(k)] = k % r;
    }
  }
  T& at(int i, int j) { return pool_[index(i, j)]; }
  /// Where (i, j) is kept (its block allocated now if it was not): stays valid while more blocks
  /// are allocated, unlike a reference.
  std::size_t index(int i, int j) {
    long& offset = offset_[block_index(i, j)];
    if (offset < 0) {
      offset = static_cast<long>(pool_.size());
      pool_.resize(pool_.size() + static_cast<std::size_t>(r_) * r_, fill_);
    }
    return static_cast<std::size_t>(offset) + place(i, j);
  }
  T& operator[](std::size_t index) { return pool_[index]; }
  /// The value at (i, j), or nullptr where its block is not allocated yet.
  const T* find(int i, int j) const {
    const long offset = offset_[block_index(i, j)];
    return offset < 0 ? nullptr : &pool_[static_cast<std::size_t>(offset) + place(i, j)];
  }
  /// Whether fine index k lies on a coarse grid line (a multiple of r).
  bool on_grid_line(int k) const { return within_[static_cast<std::size_t>(k)] == 0; }
  /// Calls visit(i, j, value) for every fine node (i, j) of block (bi, bj), if the block is
  /// allocated.
  template <class Visitor>
  void for_each_in_block(int bi, int bj, Visitor&& visit) {
    const long offset = offset_[static_cast<std::size_t>(bj) * n_x_ + bi];
    if (offset < 0) return;
    T* block = pool_.data() + offset;
    for (int b = 0; b < r_; ++b) {
      for (int a = 0; a < r_; ++a) visit(bi * r_ + a, bj * r_ + b, block[b * r_ + a]);
    }
  }

 private:
  std::size_t block_index(int i, int j) const {
    return static_cast<std::size_t>(block_[static_cast<std::size_t>(j)]) * n_x_ +
           block_[static_cast<std::size_t>(i)];
  }
  std::size_t place(int i, int j) const {
    return static_cast<std::size_t>(within_[static_cast<std::size_t>(j)]) * r_ +
           within_[static_cast<std::size_t>(i)];
  }
  int n_x_, r_;
  T fill_;
  std::vector<long> offset_;
  std::vector<int> block_, within_;
  std::vector<T> pool_;
};

namespace {

// Runs of consecutive particles in one cell (the usual order: particles are made cell by cell and
// move slowly): run r holds particles start[r] .. start[r + 1] - 1 (start has one entry more), in
// cell[r] (-1: outside the grid), of volume[r] (m^2, added in particle order).
struct Runs {
  std::vector<std::uint32_t> start;
  std::vector<int> cell;
  std::vector<double> volume;
};

// What one sweep over every particle of the cloud tells (survey_cloud()).
struct CloudSurvey {
  Vec2 lo = Vec2::Zero(), hi = Vec2::Zero();  ///< bounding box of the positions, m
  double largest_stretch = 1.0;               ///< largest singular value of any F (1 without F)
  double largest_volume = 0.0;                ///< m^2
  double smallest_det = 1.0;                  ///< smallest det F (1 without F)
  std::vector<double> cell_volume;            ///< particle volume per grid cell, m^2 (narrow band)
  std::vector<Runs> runs;  ///< every particle's run, by chunk of the cloud (narrow band)
};

// The particles' volumes as the stretch cap shrinks them (shrink_volumes()), taken only in the
// chunks of kParticleChunk particles where some F lies beyond the cap: particle q's is value[q]
// where taken[q / kParticleChunk], else its own volume. (`value` is left uninitialised: the
// pages of the chunks not taken are never touched.)
struct ShrunkByChunk {
  std::unique_ptr<double[]> value;
  std::vector<char> taken;
};

// The runs that start in [begin, end) of the n particles (the last may end beyond), with the
// particles' volumes as the cap shrinks them.
Runs runs_starting_in(const int* cell, const double* volume, const ShrunkByChunk& shrunk,
                      std::size_t begin, std::size_t end, std::size_t n) {
  Runs runs;
  std::size_t p = begin;
  if (p > 0) {
    while (p < end && cell[p] == cell[p - 1]) ++p;
  }
  if (p == end) return runs;
  runs.start.resize(end - p + 1);  // room for every index; shrunk to the runs found
  std::uint32_t* start = runs.start.data();
  start[0] = static_cast<std::uint32_t>(p);
  const std::size_t count = 1 + cell_changes(cell, p + 1, end, start + 1);
  runs.start.resize(count + 1);
  runs.cell.resize(count);
  runs.volume.resize(count);
  std::size_t last = end;  // the last run goes on while its cell does
  while (last < n && cell[last] == cell[end - 1]) ++last;
  start[count] = static_cast<std::uint32_t>(last);
  for (std::size_t r = 0; r < count; ++r) {
    double sum = 0.0;
    for (std::size_t q = start[r]; q < start[r + 1]; ++q) {
      sum += shrunk.taken[q / kParticleChunk] ? shrunk.value[q] : volume[q];
    }
    runs.volume[r] = sum;
    runs.cell[r] = cell[start[r]];
  }
  return runs;
}

// The one pass over every particle the improved detector makes: checks each particle (with the
// messages of check_particle()), and gathers the box, the largest stretch and, for the narrow
// band, the cell of each particle and the volume in each cell (sweep_cloud(), vectorised), the
// volumes as the stretch cap `cap` (0: none) shrinks them, never raised (shrink_volumes(), taken
// on a chunk whose F are not all within the cap while its F are still in the cache: reading
// them again costs more than the arithmetic). Large clouds are swept by chunks on the OpenMP
// threads; the chunks' minima and maxima, the volumes of the runs (each added in particle order)
// and the cells' volumes (the runs added in run order) are those of one sweep, whatever the
// thread count.
CloudSurvey survey_cloud(const ParticleCloud& cloud, const Grid& grid, double cap) {
  CloudSurvey survey;
  const std::size_t n = cloud.position.size();
  if (n == 0) return survey;
  const double* position = cloud.position.data()->data();
  const double* volume = cloud.volume.data();
  const double* deformation =
      cloud.deformation_gradient.empty() ? nullptr : cloud.deformation_gradient.data()->data();
  const int n_x = grid.n_cells_x, n_y = grid.n_cells_y;
  const CellLattice lattice = cell_lattice(grid);
  std::vector<int> cell_of(n);  // grid cell of each particle, -1 outside
  const std::size_t n_chunks = (n + kParticleChunk - 1) / kParticleChunk;
  const auto chunk_begin = [&](std::size_t k) { return k * kParticleChunk; };
  const auto chunk_end = [&](std::size_t k) { return std::min(n, (k + 1) * kParticleChunk); };
  std::vector<CloudTotals> chunk_totals(n_chunks);
  ShrunkByChunk shrunk;
  shrunk.taken.assign(n_chunks, 0);
  if (cap > 0.0 && deformation) shrunk.value = std::make_unique_for_overwrite<double[]>(n);
  for_each_on_threads(n_chunks, 1, [&](std::size_t k) {
    const std::size_t b = chunk_begin(k), e = chunk_end(k);
    chunk_totals[k] =
        sweep_cloud(position + 2 * b, volume + b, deformation ? deformation + 4 * b : nullptr,
                    e - b, lattice, cell_of.data() + b);
    // detect_improved()'s test for the whole cloud, on the chunk: a chunk that passes holds
    // every F the cap changes.
    const VolumeTotals& t = chunk_totals[k].volumes;
    if (deformation && may_exceed_stretch_cap(std::sqrt(t.largest_squared), t.smallest_det, cap)) {
      shrink_volumes(volume + b, deformation + 4 * b, e - b, cap, shrunk.value.get() + b);
      shrunk.taken[k] = 1;
    }
  });
  CloudTotals totals = chunk_totals[0];
  for (std::size_t k = 1; k < n_chunks; ++k) {
    include(totals.positions, chunk_totals[k].positions);
    include(totals.volumes, chunk_totals[k].volumes);
  }
  if (!totals.valid()) {
    for (std::size_t p = 0; p < n; ++p) check_particle(cloud, p);
  }
  // (After every cell is known: a run may go on into the next chunk.)
  std::vector<Runs> chunk_runs(n_chunks);
  for_each_on_threads(chunk_runs.size(), 1, [&](std::size_t k) {
    chunk_runs[k] =
        runs_starting_in(cell_of.data(), volume, shrunk, chunk_begin(k), chunk_end(k), n);
  });
  survey.lo = Vec2(totals.positions.lo_x, totals.positions.lo_y);
  survey.hi = Vec2(totals.positions.hi_x, totals.positions.hi_y);
  survey.largest_stretch = std::sqrt(totals.volumes.largest_squared);
  survey.largest_volume = totals.volumes.largest_volume;
  survey.smallest_det = totals.volumes.smallest_det;
  survey.cell_volume.assign(static_cast<std::size_t>(n_x) * n_y, 0.0);
  for (const Runs& r : chunk_runs) {
    for (std::size_t k = 0; k < r.cell.size(); ++k) {
      if (r.cell[k] >= 0) survey.cell_volume[static_cast<std::size_t>(r.cell[k])] += r.volume[k];
    }
  }
  survey.runs = std::move(chunk_runs);
  return survey;
}

// A filter of the n_x x n_y cells along every row, then along every column. Along a line of n
// cells it reads cell k (unset for k >= n) into a state, state = next(state, set, k), and writes
// cell k - rings as keep(state, k - rings), k = 0 .. n + rings - 1. The columns are swept row by
// row with one state per column, so that both passes read and write contiguous rows (in vector
// lanes) instead of striding down the columns; rows and blocks of columns on the threads.
template <class Next, class Keep>
std::vector<char> rows_then_columns(const std::vector<char>& in, int n_x, int n_y, int rings,
                                    int start, Next next, Keep keep) {
  std::vector<char> rows(in.size(), 0), out(in.size(), 0);
  // Everything by value in the loops: a char store may alias anything reached by reference,
  // which would then be read again at every cell.
  const char* const source = in.data();
  char* const across = rows.data();
  char* const result = out.data();
  for_each_on_threads(static_cast<std::size_t>(n_y), rows_per_chunk(n_x), [=](std::size_t j) {
    const char* a = source + j * n_x;
    char* b = across + j * n_x;
    int state = start;
    for (int k = 0; k < n_x + rings; ++k) {
      state = next(state, k < n_x && a[k] != 0, k);
      if (k >= rings) b[k - rings] = keep(state, k - rings) ? 1 : 0;
    }
  });
  // The columns by blocks of kColumns, each block swept over every row.
  constexpr int kColumns = 256;
  const auto column_block = [=](std::size_t block) {
    const int i0 = static_cast<int>(block) * kColumns;
    const int width = std::min(kColumns, n_x - i0);
    int s[kColumns];
    std::fill(s, s + width, start);
    for (int k = 0; k < n_y + rings; ++k) {
      const char* a = across + static_cast<std::size_t>(k) * n_x + i0;
      if (k < n_y) {
        for (int i = 0; i < width; ++i) s[i] = next(s[i], a[i] != 0, k);
      } else {
        for (int i = 0; i < width; ++i) s[i] = next(s[i], false, k);
      }
      if (k >= rings) {
        char* b = result + static_cast<std::size_t>(k - rings) * n_x + i0;
        for (int i = 0; i < width; ++i) b[i] = keep(s[i], k - rings) ? 1 : 0;
      }
    }
  };
  const std::size_t n_blocks = static_cast<std::size_t>((n_x + kColumns - 1) / kColumns);
  const std::size_t cells_per_block = static_cast<std::size_t>(kColumns) * (n_y + rings);
  for_each_on_threads(n_blocks, std::max<std::size_t>(1, kCellChunk / cells_per_block),
                      column_block);
  return out;
}

// Cells whose every neighbour within `rings` (Chebyshev) is set in `in`; outside the grid counts
// as unset.
std::vector<char> erode(const std::vector<char>& in, int n_x, int n_y, int rings) {
  // State: the set cells in a row ending at k; cell k - rings is kept when it is 2 rings + 1.
  return rows_then_columns(
      in, n_x, n_y, rings, 0, [](int run, bool set, int) { return set ? run + 1 : 0; },
      [rings](int run, int) { return run > 2 * rings; });
}

// Cells with a set cell within `rings` (Chebyshev) in `in`.
std::vector<char> dilate(const std::vector<char>& in, int n_x, int n_y, int rings) {
  // State: the last set cell at or before k; cell k - rings is covered when it lies within rings.
  return rows_then_columns(
      in, n_x, n_y, rings, -1000000000, [](int last, bool set, int k) { return set ? k : last; },
      [rings](int last, int target) { return last >= target - rings; });
}

// Wall-clock laps of the improved detector's parts (DetectionTimings::FieldParts).
class Laps {
 public:
  /// Adds the time since the last lap (or restart()) to `part`.
  void operator()(double& part) {
    part += seconds_since(start_);
    start_ = std::chrono::steady_clock::now();
  }
  void restart() { start_ = std::chrono::steady_clock::now(); }

 private:
  std::chrono::steady_clock::time_point start_ = std::chrono::steady_clock::now();
};

// The narrow band (detect_improved(), step 0): the cells interior by their volume alone, the wall
// contacts of the whole cloud, and copies of the particles within reach of the other cells.
struct Band {
  std::vector<char> interior_by_volume;  ///< per grid cell
  std::vector<char> needed;              ///< per grid cell: its particles are in the band
  ImprovedField::WallContacts contacts;  ///< of every particle, not only the band's
  std::vector<Vec2> position;            ///< m
  std::vector<double> volume;            ///< m^2
  std::vector<Mat2> deformation;         ///< empty without F
};

// A solid cell, with every cell within a kernel reach of it solid too, is interior without any
// field evaluation. The field opens a gap where the material leaves one of about half a kernel
// radius (tested: 0.3 h at 5 points per cell, a0 = 0.6 h); such a gap empties one of the two
// cells it may straddle by a quarter of a0 / h or more, so a solid cell must be fuller than
// solid_fraction = 1 - 0.15 a0 / h. A cell that lost a point to its neighbour in a deforming body
// (a quarter of its volume at 2 x 2 points per cell) is solid too when each of the four windows
// of 2 x 2 cells around its corners is fuller than solid_fraction: a straight gap through the
// cell crosses one of those windows along at least sqrt(2) h and so empties it by 0.18 a0 / h or
// more. Where the volume alone cannot tell, the field screening decides (screen_cells()). Only
// the particles within reach (particle_reach, m) of the cells that are not interior enter the
// field; kernel_reach (m) is the largest kernel semi-axis.
// The band's particles: those of the cells it needs (band.needed) and those outside the grid,
// copied in the survey's run order. Selected indices first, then the copies; the selection run
// by run, each chunk of the survey's runs on its own, joined in order.
void copy_needed_particles(const ParticleCloud& cloud, const CloudSurvey& survey, Band& band) {
  const bool deformed = !cloud.deformation_gradient.empty();
  std::vector<std::vector<std::uint32_t>> chunk_selected(survey.runs.size());
  for_each_on_threads(survey.runs.size(), 1, [&](std::size_t chunk) {
    const Runs& runs = survey.runs[chunk];
    if (runs.cell.empty()) return;
    std::vector<std::uint32_t>& chosen = chunk_selected[chunk];
    chosen.resize(runs.start.back() - runs.start.front());
    std::size_t m = 0;
    for (std::size_t r = 0; r < runs.cell.size(); ++r) {
      const int c = runs.cell[r];
      if (c >= 0 && !band.needed[static_cast<std::size_t>(c)]) continue;
      for (std::uint32_t p = runs.start[r]; p < runs.start[r + 1]; ++p) chosen[m++] = p;
    }
    chosen.resize(m);
  });
  std::vector<std::uint32_t> selected;
  for (std::size_t chunk = 0; chunk < survey.runs.size(); ++chunk) {
    selected.insert(selected.end(), chunk_selected[chunk].begin(), chunk_selected[chunk].end());
  }
  const std::size_t m = selected.size();
  band.position.resize(m);
  band.volume.resize(m);
  if (deformed) band.deformation.resize(m);
  for_each_on_threads(m, kBandChunk, [&](std::size_t k) {
    const std::size_t p = selected[k];
    band.position[k] = cloud.position[p];
    band.volume[k] = cloud.volume[p];
    if (deformed) band.deformation[k] = cloud.deformation_gradient[p];
  });
}

Band select_band(const ParticleCloud& cloud, const Grid& grid, const ImprovedConfig& config,
                 const CloudSurvey& survey, double kernel_reach, double particle_reach) {
  const double h = grid.cell_size;
  const int ncx = grid.n_cells_x, ncy = grid.n_cells_y;
  const double a0 = config.radius_factor * cloud.initial_spacing;
  const double solid_fraction = 1.0 - 0.15 * a0 / h;
  const int kernel_rings = std::max(1, static_cast<int>(std::ceil(kernel_reach / h)));
  const int particle_rings = std::max(1, static_cast<int>(std::ceil(particle_reach / h)));
  Band band;
  // The particles that may touch a grid edge: those in the cells along it or outside the grid
  // (closer to the edge than one initial spacing <= h; a larger spacing takes every particle).
  const bool every_particle_may_touch = cloud.initial_spacing > h;
  const auto on_rim = [&](int c) {
    return every_particle_may_touch || c < 0 || c % ncx == 0 || c / ncx == 0 ||
           c % ncx == ncx - 1 || c / ncx == ncy - 1;
  };
  std::vector<Vec2> touching;
  if (config.mirror_grid_edges) {
    for (const Runs& runs : survey.runs) {
      for (std::size_t r = 0; r < runs.cell.size(); ++r) {
        if (!on_rim(runs.cell[r])) continue;
        for (std::uint32_t p = runs.start[r]; p < runs.start[r + 1]; ++p) {
          touching.push_back(cloud.position[p]);
        }
      }
    }
    band.contacts = ImprovedField::find_wall_contacts(touching, survey.lo, survey.hi, grid,
                                                      cloud.initial_spacing);
  }
  // Where the body rests on a grid edge the field mirrors each particle across it if the edge is
  // touched within the particle's reach along it (ImprovedField::mirror_sides()). Beyond such a
  // wall a cell is the mirror image of the cell inside where the wall is touched all along that
  // cell (every bin of one spacing it spans: then every particle of the cell is mirrored), for
  // the erosion and for the dilation (a particle whose image reaches an open cell reaches that
  // cell's image). Elsewhere the outside is void, which errs on the side of a wider band. The
  // padding holds both operations' reach; the erosion's artefacts at its outer rim stay more
  // than particle_rings away from the grid.
  std::array<std::vector<char>, 4> mirrored_along;  // by row (walls 0, 1) or column (2, 3)
  // The bins touched closely enough for the image cell to be as full as its source: a particle
  // within half a spacing + 0.075 a0 of the wall (its image lies within one spacing + 0.15 a0 of
  // it, the slack the solid test leaves). A body that left the wall by more keeps its mirror in
  // the field, where the gaps along two walls meeting at a corner open a hole the volumes do
  // not show (a failing body cut by the grid edge 0.8 spacings from its points).
  const ImprovedField::WallContacts close =
      ImprovedField::find_wall_contacts(touching, survey.lo, survey.hi, grid, cloud.initial_spacing,
                                        0.5 * cloud.initial_spacing + 0.075 * a0);
  for (int w = 0; w < 4; ++w) {
    const int n = w < 2 ? ncy : ncx;
    mirrored_along[w].assign(static_cast<std::size_t>(n), 0);
    const std::vector<char>& bins = close.touched[w];
    if (!band.contacts.wall[w] || bins.empty()) continue;
    // Cell k spans [k h, (k + 1) h) along the wall: bins floor(k h / s) .. ceil((k + 1) h / s) - 1
    // (a point at the wall's far end is in the last bin of the last cell).
    const long last = static_cast<long>(bins.size()) - 1;
    const double s = cloud.initial_spacing;
    for (int k = 0; k < n; ++k) {
      const long b0 = std::min(last, static_cast<long>(std::floor(k * h / s)));
      const long b1 = std::min(last, static_cast<long>(std::ceil((k + 1) * h / s)) - 1);
      bool all = true;
      for (long b = b0; b <= std::max(b0, b1); ++b) all = all && bins[b] != 0;
      mirrored_along[w][static_cast<std::size_t>(k)] = all ? 1 : 0;
    }
  }
  const int pad = kernel_rings + particle_rings;
  const int px = ncx + 2 * pad, py = ncy + 2 * pad;
  // Index of the grid cell that padded cell (a, b) images, or -1 for the void.
  const auto source = [&](int a, int b) {
    int i = a - pad, j = b - pad;
    const int wall_x = i < 0 ? 0 : (i >= ncx ? 1 : -1), wall_y = j < 0 ? 2 : (j >= ncy ? 3 : -1);
    if (wall_x >= 0) i = i < 0 ? -1 - i : 2 * ncx - 1 - i;
    if (wall_y >= 0) j = j < 0 ? -1 - j : 2 * ncy - 1 - j;
    if (i < 0 || i >= ncx || j < 0 || j >= ncy) return -1;
    if (wall_x >= 0 && !mirrored_along[wall_x][static_cast<std::size_t>(j)]) return -1;
    if (wall_y >= 0 && !mirrored_along[wall_y][static_cast<std::size_t>(i)]) return -1;
    return j * ncx + i;
  };
  std::vector<double> padded_volume(static_cast<std::size_t>(px) * py, 0.0);
  // (The loops over rows run on the threads, by chunks of rows.)
  const std::size_t padded_rows = rows_per_chunk(px);
  double* const volume = padded_volume.data();
  const double* const cell_volume = survey.cell_volume.data();
  for_each_on_threads(static_cast<std::size_t>(py), padded_rows, [&](std::size_t row) {
    const int b = static_cast<int>(row);
    for (int a = 0; a < px; ++a) {
      const int c = source(a, b);
      if (c >= 0) volume[static_cast<std::size_t>(b) * px + a] = cell_volume[c];
    }
  });
  // The volume of padded cell (a, b), 0 beyond the padding.
  const auto volume_at = [=](int a, int b) {
    return a < 0 || b < 0 || a >= px || b >= py ? 0.0
                                                : volume[static_cast<std::size_t>(b) * px + a];
  };
  const double solid_cell = solid_fraction * h * h, solid_window = 4.0 * solid_cell;
  // Whether the 2 x 2 cells around padded node (a, b) are fuller than solid_fraction.
  const auto full_window = [=](int a, int b) {
    return volume_at(a - 1, b - 1) + volume_at(a, b - 1) + volume_at(a - 1, b) + volume_at(a, b) >=
           solid_window;
  };
  std::vector<char> padded_solid(static_cast<std::size_t>(px) * py, 0);
  char* const solid_out = padded_solid.data();
  for_each_on_threads(static_cast<std::size_t>(py), padded_rows, [=](std::size_t row) {
    const int b = static_cast<int>(row);
    for (int a = 0; a < px; ++a) {
      const double v = volume[static_cast<std::size_t>(b) * px + a];
      solid_out[static_cast<std::size_t>(b) * px + a] =
          v >= solid_cell || (v > 0.0 && full_window(a, b) && full_window(a + 1, b) &&
                              full_window(a, b + 1) && full_window(a + 1, b + 1));
    }
  });
  const std::vector<char> padded_interior = erode(padded_solid, px, py, kernel_rings);
  std::vector<char> padded_open(padded_interior.size());
  for (std::size_t c = 0; c < padded_open.size(); ++c) padded_open[c] = !padded_interior[c];
  const std::vector<char> padded_needed = dilate(padded_open, px, py, particle_rings);
  // The grid's cells out of the padded ones: interior by volume, and whether the particles of
  // each cell enter the field (needed[c + 1] of the particle's cell c; c = -1 outside the grid,
  // always). (Raw pointers: a char store could alias a vector's own pointer, which would then be
  // read again at every cell.)
  band.interior_by_volume.assign(static_cast<std::size_t>(ncx) * ncy, 0);
  band.needed.assign(band.interior_by_volume.size(), 0);
  char* const interior_out = band.interior_by_volume.data();
  char* const needed_out = band.needed.data();
  const char* const interior_in = padded_interior.data();
  const char* const needed_in = padded_needed.data();
  for_each_on_threads(static_cast<std::size_t>(ncy), rows_per_chunk(ncx), [=](std::size_t row) {
    const std::size_t padded = (row + pad) * px + pad;
    std::copy_n(interior_in + padded, ncx, interior_out + row * ncx);
    std::copy_n(needed_in + padded, ncx, needed_out + row * ncx);
  });
  copy_needed_particles(cloud, survey, band);
  return band;
}

// The particles of the cloud in the grid cells within `reach` (m) of the band's cells, and those
// outside the grid (which the band takes all of), run by run from the survey: every particle
// within `reach` of a band particle is among them.
struct NeighbourCloud {
  std::vector<Vec2> position;
  std::vector<double> volume;
};

NeighbourCloud neighbours_of_band(const ParticleCloud& cloud, const Grid& grid,
                                  const CloudSurvey& survey, const Band& band, double reach) {
  const int rings = std::max(1, static_cast<int>(std::ceil(reach / grid.cell_size)));
  const std::vector<char> near = dilate(band.needed, grid.n_cells_x, grid.n_cells_y, rings);
  NeighbourCloud out;
  for (const Runs& runs : survey.runs) {
    for (std::size_t r = 0; r < runs.cell.size(); ++r) {
      const int c = runs.cell[r];
      if (c >= 0 && !near[static_cast<std::size_t>(c)]) continue;
      for (std::uint32_t p = runs.start[r]; p < runs.start[r + 1]; ++p) {
        out.position.push_back(cloud.position[p]);
        out.volume.push_back(cloud.volume[p]);
      }
    }
  }
  return out;
}

// The coarse screening of the grid cells (narrow band, step 1), per grid cell.
struct Screening {
  std::vector<char> reached;  ///< some kernel reaches the cell
  std::vector<char> deep;     ///< interior: by volume, or corners and centre above the band
  std::vector<char> far;      ///< exterior: corners and centre below the band
  /// phi at grid node (i, j) = coarse[j (n_cells_x + 1) + i] where the screening evaluated it,
  /// else NaN.
  std::vector<double> coarse;
};

// With phi alone (the guards are not decided yet; max(phi, guard) >= phi): cells no kernel
// reaches are exactly void; reached cells whose corners and centre all exceed level +
// band_margin are interior ("deep"), those all below level - band_margin are exterior ("far")
// unless they hold a guarded particle. The rest is "active". The screening is a heuristic
// (detector.hpp). Cells interior by volume (empty span: none) are deep without evaluation.
Screening screen_cells(const ImprovedField& field, const Grid& grid, const ImprovedConfig& config,
                       std::span<const char> interior_by_volume, long& field_evaluations) {
  const int ncx = grid.n_cells_x, ncy = grid.n_cells_y;
  const std::size_t n_cells = static_cast<std::size_t>(ncx) * ncy;
  const double h = grid.cell_size;
  const auto positions = field.positions();
  Screening screen;
  screen.reached.assign(n_cells, 0);
  // The cells each particle's box reaches, as the 2D prefix sums of +-1 at the corners of the
  // boxes (four writes per particle instead of one per cell of its box).
  const std::size_t stride = static_cast<std::size_t>(ncx) + 1;
  std::vector<int> boxes(stride * (static_cast<std::size_t>(ncy) + 1), 0);
  for (std::size_t p = 0; p < positions.size(); ++p) {
    const Vec2 half = field.reach_box(p);
    const int i0 = std::max(grid.cell_i(positions[p].x() - half.x()), 0);
    const int i1 = std::min(grid.cell_i(positions[p].x() + half.x()), ncx - 1);
    const int j0 = std::max(grid.cell_j(positions[p].y() - half.y()), 0);
    const int j1 = std::min(grid.cell_j(positions[p].y() + half.y()), ncy - 1);
    if (i0 > i1 || j0 > j1) continue;
    const std::size_t low = static_cast<std::size_t>(j0) * stride;
    const std::size_t high = static_cast<std::size_t>(j1 + 1) * stride;
    ++boxes[low + static_cast<std::size_t>(i0)];
    --boxes[low + static_cast<std::size_t>(i1) + 1];
    --boxes[high + static_cast<std::size_t>(i0)];
    ++boxes[high + static_cast<std::size_t>(i1) + 1];
  }
  for (int j = 0; j < ncy; ++j) {
    int* row = boxes.data() + static_cast<std::size_t>(j) * stride;
    if (j > 0) {
      const int* below = row - stride;
      for (int i = 0; i < ncx; ++i) row[i] += below[i];  // the column sums, up to this row
    }
    int along = 0;
    char* reached = screen.reached.data() + static_cast<std::size_t>(j) * ncx;
    for (int i = 0; i < ncx; ++i) {
      along += row[i];
      reached[i] = along > 0 ? 1 : 0;
    }
  }
  // phi at the corners of the reached cells that the volume does not call interior (the coarse
  // nodes are sparse: a particle would visit few of them, a block evaluation would cost more).
  const std::size_t n_nodes = static_cast<std::size_t>(ncx + 1) * (ncy + 1);
  std::vector<char> listed_node(n_nodes, 0);
  std::vector<int> screened, listed;  // cells, nodes
  for (int j = 0; j < ncy; ++j) {
    for (int i = 0; i < ncx; ++i) {
      const std::size_t c = static_cast<std::size_t>(j) * ncx + i;
      if (!screen.reached[c] || (!interior_by_volume.empty() && interior_by_volume[c])) continue;
      screened.push_back(static_cast<int>(c));
      for (const int k : {j * (ncx + 1) + i, j * (ncx + 1) + i + 1, (j + 1) * (ncx + 1) + i,
                          (j + 1) * (ncx + 1) + i + 1}) {
        if (listed_node[static_cast<std::size_t>(k)]) continue;
        listed_node[static_cast<std::size_t>(k)] = 1;
        listed.push_back(k);
      }
    }
  }
  screen.coarse.assign(n_nodes, std::numeric_limits<double>::quiet_NaN());
  for_each_on_threads(listed.size(), kEvaluationChunk, [&](std::size_t k) {
    const int i = listed[k] % (ncx + 1), j = listed[k] / (ncx + 1);
    screen.coarse[static_cast<std::size_t>(listed[k])] =
        field.volume_fraction(grid.node_position(i, j));
  });
  field_evaluations += static_cast<long>(listed.size());
  // A screened cell all of whose corners lie above (below) the band is deep (far) if its centre
  // does too; cells interior by volume are deep.
  if (interior_by_volume.empty()) {
    screen.deep.assign(n_cells, 0);
  } else {
    screen.deep.assign(interior_by_volume.begin(), interior_by_volume.end());
  }
  screen.far.assign(n_cells, 0);
  const double interior = config.level + config.band_margin;
  const double exterior = config.level - config.band_margin;
  std::vector<int> centred;
  for (const int cell : screened) {
    const auto c = static_cast<std::size_t>(cell);
    const int i = cell % ncx, j = cell / ncx;
    const double* corner = screen.coarse.data() + static_cast<std::size_t>(j) * (ncx + 1) + i;
    const double v[4] = {corner[0], corner[1], corner[ncx + 1], corner[ncx + 2]};
    screen.deep[c] = v[0] > interior && v[1] > interior && v[2] > interior && v[3] > interior;
    screen.far[c] = v[0] < exterior && v[1] < exterior && v[2] < exterior && v[3] < exterior;
    if (screen.deep[c] || screen.far[c]) centred.push_back(cell);
  }
  for_each_on_threads(centred.size(), kEvaluationChunk, [&](std::size_t k) {
    const auto c = static_cast<std::size_t>(centred[k]);
    const int i = centred[k] % ncx, j = centred[k] / ncx;
    const double vc = field.volume_fraction(grid.node_position(i, j) + Vec2(0.5 * h, 0.5 * h));
    screen.deep[c] = screen.deep[c] && vc > interior;
    screen.far[c] = screen.far[c] && vc < exterior;
  });
  field_evaluations += static_cast<long>(centred.size());
  return screen;
}

// Guard candidates (step 2): every particle outside the deep cells.
std::vector<char> guard_candidates(std::span<const Vec2> positions, const Grid& grid,
                                   const std::vector<char>& deep) {
  const int ncx = grid.n_cells_x, ncy = grid.n_cells_y;
  std::vector<char> candidate(positions.size(), 1);
  for (std::size_t p = 0; p < positions.size(); ++p) {
    const int i = grid.cell_i(positions[p].x()), j = grid.cell_j(positions[p].y());
    if (i >= 0 && j >= 0 && i < ncx && j < ncy && deep[static_cast<std::size_t>(j) * ncx + i]) {
      candidate[p] = 0;
    }
  }
  return candidate;
}

// The slots reaching one gather square (FineNodes::square_box()), gathered on first use: a sum
// over them is bitwise the field's own (ImprovedField::slots_reaching()).
struct GatheredSquare {
  long key = -1;
  ImprovedField::KernelArrays slots;
};

// The field max(phi, guard) on the nodes of the grid refined r times, each evaluated on first use
// and kept (the narrow band touches few blocks of a large refined grid). A node's sum runs over
// the slots gathered for its gather square, a square of `square` x `square` fine cells no wider
// than a kernel radius, or over the bins around it: the bins are sized by the widest kernel,
// which in a failing body is at the stretch cap (2 a0), and at the boundary of the 150 kPa
// collapse they hold 157 slots per point, of which 36 have a box that meets the point.
class FineNodes {
 public:
  /// Nodes of one gather square from which evaluate() gathers its slots: a gather costs about
  /// ten sums over the bins of an intact body.
  static constexpr std::size_t kGatherFrom = 8;
  FineNodes(const Grid& grid, int r, int square, const ImprovedField& field, double level,
            long& evaluations)
      : grid_(grid),
        field_(field),
        level_(level),
        evaluations_(evaluations),
        r_(r),
        square_(square),
        cache_(grid.n_cells_x, grid.n_cells_y, r, std::numeric_limits<double>::quiet_NaN()) {
    geometry_.origin = grid.origin;
    geometry_.spacing = grid.cell_size / r;
    geometry_.n_x = grid.n_cells_x * r + 1;
    geometry_.n_y = grid.n_cells_y * r + 1;
    n_squares_x_ = grid.n_cells_x * r / square;
    n_squares_y_ = grid.n_cells_y * r / square;
  }
  /// The largest divisor of r whose square of fine cells is no wider than `radius` (m; at least
  /// one fine cell): a whole grid cell at 2 or 3 points per cell, half of one at 5.
  static int gather_square(int r, double cell_size, double radius) {
    int square = 1;
    for (int d = 1; d <= r; ++d) {
      if (r % d == 0 && d * cell_size / r <= radius) square = d;
    }
    return square;
  }
  /// The gather square of fine node (i, j): the closed square of square x square fine cells
  /// from fine node (square si, square sj) that holds it (a node on the grid's upper or right
  /// edge in the last one).
  long square_key(int i, int j) const {
    const int si = std::min(i / square_, n_squares_x_ - 1);
    const int sj = std::min(j / square_, n_squares_y_ - 1);
    return static_cast<long>(sj) * n_squares_x_ + si;
  }
  /// The lower and upper corners of gather square `key` (m), bitwise the positions of its
  /// corner nodes.
  std::pair<Vec2, Vec2> square_box(long key) const {
    const int si = static_cast<int>(key % n_squares_x_), sj = static_cast<int>(key / n_squares_x_);
    return {position(si * square_, sj * square_), position((si + 1) * square_, (sj + 1) * square_)};
  }
  /// The slots of gather square `key` in `g`, gathered unless `g` holds them already.
  const ImprovedField::KernelArrays& gathered(long key, GatheredSquare& g) const {
    if (g.key != key) {
      g.key = key;
      const auto [lo, hi] = square_box(key);
      field_.slots_reaching(lo, hi, g.slots);
    }
    return g.slots;
  }
  /// Origin, spacing and node counts (no values).
  const NodalField& geometry() const { return geometry_; }
  const Grid& grid() const { return grid_; }
  int refinement() const { return r_; }
  int n_cells_x() const { return geometry_.n_x - 1; }
  int n_cells_y() const { return geometry_.n_y - 1; }
  /// The fine cell (i, j) holding x, clamped to the grid; false when x lies outside the grid.
  bool cell_of(const Vec2& x, int& i, int& j) const { return fine_cell(geometry_, x, i, j); }
  /// Takes phi at the grid nodes from the screening (`coarse`, NaN where it has none) where the
  /// field is phi alone (no guard) and the fine node lies bitwise where the grid node does.
  void reuse_grid_nodes(std::span<const double> coarse) { coarse_ = coarse; }
  /// The field at fine node (i, j).
  double value(int i, int j) {
    double& slot = cache_.at(i, j);
    if (std::isnan(slot) && !from_grid_node(i, j, slot)) {
      slot = field_(position(i, j));
      ++evaluations_;
    }
    return slot;
  }
  /// Evaluates the fine nodes `wanted` (fine index pairs, repeats allowed) that are not known
  /// yet, on the OpenMP threads by chunks.
  void evaluate(std::span<const std::array<int, 2>> wanted) {
    // Unknown nodes are marked, so each is listed once; the marks are overwritten below.
    constexpr double kListed = std::numeric_limits<double>::infinity();
    struct Listed {
      long square;
      std::size_t index;  // in cache_ (its block made here, on the calling thread)
      int i, j;
    };
    std::vector<Listed> listed;
    for (const auto& [i, j] : wanted) {
      const std::size_t k = cache_.index(i, j);
      double& slot = cache_[k];
      if (std::isnan(slot) && !from_grid_node(i, j, slot)) {
        slot = kListed;
        listed.push_back({square_key(i, j), k, i, j});
      }
    }
    // Square by square: a square with kGatherFrom nodes or more is gathered (once per chunk),
    // the others sum over their bins.
    std::stable_sort(listed.begin(), listed.end(),
                     [](const Listed& a, const Listed& b) { return a.square < b.square; });
    const std::size_t n = listed.size(), n_chunks = (n + kEvaluationChunk - 1) / kEvaluationChunk;
    std::vector<char> gather(n, 0);
    for (std::size_t k = 0, end = 0; k < n; k = end) {
      while (end < n && listed[end].square == listed[k].square) ++end;
      if (end - k >= kGatherFrom) std::fill(gather.begin() + k, gather.begin() + end, 1);
    }
    for_each_on_threads(n_chunks, 1, [&](std::size_t c) {
      GatheredSquare g;
      for (std::size_t k = c * kEvaluationChunk; k < std::min(n, (c + 1) * kEvaluationChunk); ++k) {
        const Listed& l = listed[k];
        const Vec2 x = position(l.i, l.j);
        cache_[l.index] = gather[k] ? field_(x, gathered(l.square, g)) : field_(x);
      }
    });
    evaluations_ += static_cast<long>(n);
  }
  bool inside(int i, int j) { return value(i, j) > level_; }
  /// Takes in the guards and bridges added since the values were found: every known fine node
  /// in the closed square of each grid cell set in `changed` (n_cells_x x n_cells_y) becomes
  /// max(value, guards and bridges there), which is bitwise the field's value now (the field
  /// is max(phi, guards, bridges), and the added terms only raise the maxima).
  void raise(const std::vector<char>& changed) {
    const int ncx = grid_.n_cells_x, ncy = grid_.n_cells_y;
    // The square's upper and right node lines belong to the next blocks.
    std::vector<char> block(static_cast<std::size_t>(ncx + 1) * (ncy + 1), 0);
    for (int cj = 0; cj < ncy; ++cj) {
      for (int ci = 0; ci < ncx; ++ci) {
        if (!changed[static_cast<std::size_t>(cj) * ncx + ci]) continue;
        for (int b = 0; b < 4; ++b) {
          block[static_cast<std::size_t>(cj + (b >> 1)) * (ncx + 1) + ci + (b & 1)] = 1;
        }
      }
    }
    for (int bj = 0; bj <= ncy; ++bj) {
      for (int bi = 0; bi <= ncx; ++bi) {
        if (!block[static_cast<std::size_t>(bj) * (ncx + 1) + bi]) continue;
        cache_.for_each_in_block(bi, bj, [&](int i, int j, double& value) {
          if (!std::isnan(value))
            value = std::max(value, field_.guards_and_bridges(position(i, j)));
        });
      }
    }
  }
  /// The value at (i, j) if its block holds it already (maybe NaN: not evaluated), else nullptr.
  const double* known(int i, int j) const { return cache_.find(i, j); }

 private:
  Vec2 position(int i, int j) const {
    return Vec2(geometry_.origin.x() + static_cast<double>(i) * geometry_.spacing,
                geometry_.origin.y() + static_cast<double>(j) * geometry_.spacing);
  }
  // Whether phi at (i, j) comes from the screening (the node lies bitwise on a grid node it
  // evaluated; only without guards): then it is written to `slot`.
  bool from_grid_node(int i, int j, double& slot) const {
    if (coarse_.empty() || !cache_.on_grid_line(i) || !cache_.on_grid_line(j)) return false;
    const int gi = i / r_, gj = j / r_;
    const double known = coarse_[static_cast<std::size_t>(gj) * (grid_.n_cells_x + 1) + gi];
    if (std::isnan(known) || grid_.node_position(gi, gj) != position(i, j)) return false;
    slot = known;
    return true;
  }

  const Grid& grid_;
  const ImprovedField& field_;
  double level_;
  long& evaluations_;
  int r_, square_;
  int n_squares_x_ = 0, n_squares_y_ = 0;
  NodalField geometry_;
  BlockStore<double> cache_;
  std::span<const double> coarse_;
};

// The seed from a particle: the first fine cell with a sign change in its row, from its cell to
// the right; if the row has none up to the grid edge (a contour cut by the edge), to the left,
// then in its column upwards and downwards. Cells found interior by their volume are passed as
// inside without evaluation: the particles deep inside them are not in the field, whose values
// there would be too low. That first cell, along each direction, is a function of the cell a
// walk starts from: it is remembered for every cell a walk passes (-1: none up to the grid's
// edge), so the particles of one row (a cloud of collinear points, whose row is inside from end
// to end) do not walk the same cells again. Only walks longer than kRememberedWalk cells are
// remembered: a body's particles find their sign change within a few cells, where the table
// would cost more than the walk.
class SeedWalk {
 public:
  static constexpr std::size_t kRememberedWalk = 16;
  SeedWalk(FineNodes& nodes, std::span<const char> interior_by_volume, int ncx)
      : nodes_(nodes),
        interior_by_volume_(interior_by_volume),
        ncx_(ncx),
        r_(nodes.refinement()),
        n_fine_x_(nodes.n_cells_x()),
        n_fine_y_(nodes.n_cells_y()) {}
  /// The seed cell (j n_fine_x + i) from x's fine cell (the nearest one for x off the grid), or -1.
  int first_cell(const Vec2& x) {
    int i0 = 0, j0 = 0;
    nodes_.cell_of(x, i0, j0);
    const int steps[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
    for (int d = 0; d < 4; ++d) {
      const auto [di, dj] = steps[d];
      std::unordered_map<int, int>& memo = first_change_[static_cast<std::size_t>(d)];
      walked_.clear();
      int found = -1;
      for (int i = i0, j = j0; i >= 0 && j >= 0 && i < n_fine_x_ && j < n_fine_y_;
           i += di, j += dj) {
        const int cell = j * n_fine_x_ + i;
        if (!memo.empty()) {
          if (const auto known = memo.find(cell); known != memo.end()) {
            found = known->second;
            break;
          }
        }
        walked_.push_back(cell);
        if (!interior_by_volume_.empty() &&
            interior_by_volume_[static_cast<std::size_t>(j / r_) * ncx_ + i / r_]) {
          continue;
        }
        if (sign_change(i, j)) {
          found = cell;
          break;
        }
      }
      if (walked_.size() > kRememberedWalk) {
        for (const int cell : walked_) memo.emplace(cell, found);
      }
      if (found >= 0) return found;
    }
    return -1;
  }

 private:
  bool sign_change(int i, int j) {
    const bool a = nodes_.inside(i, j);
    return a != nodes_.inside(i + 1, j) || a != nodes_.inside(i, j + 1) ||
           a != nodes_.inside(i + 1, j + 1);
  }
  FineNodes& nodes_;
  std::span<const char> interior_by_volume_;
  int ncx_, r_, n_fine_x_, n_fine_y_;
  std::array<std::unordered_map<int, int>, 4> first_change_;
  std::vector<int> walked_;
};

// Step 3 (narrow band): the fine cells to contour, traced from seeds, fine cell by fine cell: a
// cell with a sign change passes its contour on through every edge whose nodes differ, so a
// contour is followed wherever it goes. Seeds: (a) in the active coarse cells (screen), the field
// on a lattice of every stride-th fine node (stride: the largest divisor of the refinement up to
// half of it, so the lattice is at most half a grid cell; every fine node within guard_reach (m)
// of a guarded particle), and along every lattice segment whose two ends differ and along the
// grid edge, the fine cells beside each fine edge with a sign change; (b) for each guarded
// particle, and each other particle of an island that may hold no lattice node, the first cell
// with a sign change from it. Cells interior by volume (empty span: none) count as inside.
std::vector<int> trace_band_cells(FineNodes& nodes, const Grid& grid, const ImprovedField& field,
                                  const Screening& screen, std::span<const char> interior_by_volume,
                                  const std::vector<char>& candidate, double guard_reach) {
  const int ncx = grid.n_cells_x, ncy = grid.n_cells_y;
  const int r = nodes.refinement();
  const int n_fine_x = nodes.n_cells_x(), n_fine_y = nodes.n_cells_y();
  const auto positions = field.positions();
  const auto inside = [&](int i, int j) { return nodes.inside(i, j); };
  BlockStore<char> visited(ncx, ncy, r, 0);
  std::vector<int> queue;
  const auto push = [&](int i, int j) {
    if (i < 0 || j < 0 || i >= n_fine_x || j >= n_fine_y) return;
    char& v = visited.at(i, j);
    if (v) return;
    v = 1;
    queue.push_back(j * n_fine_x + i);
  };
  std::vector<char> guard_here(screen.reached.size(), 0);
  for (std::size_t p = 0; p < positions.size(); ++p) {
    if (!field.guarded(p)) continue;
    const int i = grid.cell_i(positions[p].x()), j = grid.cell_j(positions[p].y());
    if (i >= 0 && j >= 0 && i < ncx && j < ncy)
      guard_here[static_cast<std::size_t>(j) * ncx + i] = 1;
  }
  const auto active = [&](int i, int j) {
    const std::size_t c = static_cast<std::size_t>(j) * ncx + i;
    return screen.reached[c] && !screen.deep[c] && (!screen.far[c] || guard_here[c]);
  };
  int coarse_stride = 1;
  for (int d = 1; 2 * d <= r; ++d) {
    if (r % d == 0) coarse_stride = d;
  }
  // Near a guarded particle (its cell and the cells its guard reaches, at least the ring around
  // it) the guards' small ellipses and the gaps between them make sub-lattice islands and holes:
  // every fine node there.
  const double widest = std::max(ncx, ncy);
  const int guard_rings =
      static_cast<int>(std::clamp(std::ceil(guard_reach / grid.cell_size), 1.0, widest));
  const std::vector<char> near_guard = dilate(guard_here, ncx, ncy, guard_rings);
  // Seeds along the fine edges from fine node (i, j) to (i + stride di, j + stride dj), whose
  // two ends differ: beside each fine edge with a sign change, both cells.
  const auto seed_segment = [&](int i, int j, int di, int dj, int stride) {
    bool previous = inside(i, j);
    for (int t = 1; t <= stride; ++t) {
      const bool next = inside(i + t * di, j + t * dj);
      if (next != previous) {
        // The fine edge from (i + (t - 1) di, j + (t - 1) dj) to (i + t di, j + t dj).
        const int ei = i + (t - 1) * di, ej = j + (t - 1) * dj;
        if (di != 0) {
          push(ei, ej - 1);
          push(ei, ej);
        } else {
          push(ei - 1, ej);
          push(ei, ej);
        }
      }
      previous = next;
    }
  };
  // The runs of active cells along each row with or without guards near: run(i, end, j, stride)
  // for cells i .. end - 1 of row j, with the lattice stride in fine cells.
  const auto for_each_run = [&](const auto& run) {
    for (int j = 0; j < ncy; ++j) {
      for (int i = 0; i < ncx;) {
        if (!active(i, j)) {
          ++i;
          continue;
        }
        const bool fine = near_guard[static_cast<std::size_t>(j) * ncx + i] != 0;
        int end = i + 1;
        while (end < ncx && active(end, j) &&
               (near_guard[static_cast<std::size_t>(j) * ncx + end] != 0) == fine) {
          ++end;
        }
        run(i, end, j, fine ? 1 : coarse_stride);
        i = end;
      }
    }
  };
  // Their lattice nodes first, all at once: square by square, on the threads.
  std::vector<std::array<int, 2>> lattice;
  for_each_run([&](int i, int end, int j, int stride) {
    for (int fj = j * r; fj <= (j + 1) * r; fj += stride) {
      for (int fi = i * r; fi <= end * r; fi += stride) lattice.push_back({fi, fj});
    }
  });
  nodes.evaluate(lattice);
  for_each_run([&](int i, int end, int j, int stride) {
    // The lattice segments of the run (every fine node near guards): along its rows and up its
    // columns.
    const int last_i = end * r, last_j = (j + 1) * r;
    for (int fj = j * r; fj <= last_j; fj += stride) {
      for (int fi = i * r; fi <= last_i; fi += stride) {
        const bool here = inside(fi, fj);
        if (fi < last_i && inside(fi + stride, fj) != here) seed_segment(fi, fj, 1, 0, stride);
        if (fj < last_j && inside(fi, fj + stride) != here) seed_segment(fi, fj, 0, 1, stride);
      }
    }
    // Along the grid edge every fine edge: a region cut by the edge has a contour for each
    // stretch of the edge it leaves, which may start and end between two lattice nodes.
    if (j == 0) seed_segment(i * r, 0, 1, 0, last_i - i * r);
    if (j == ncy - 1) seed_segment(i * r, n_fine_y, 1, 0, last_i - i * r);
    if (i == 0) seed_segment(0, j * r, 0, 1, r);
    if (end == ncx) seed_segment(n_fine_x, j * r, 0, 1, r);
  });
  SeedWalk walk(nodes, interior_by_volume, ncx);
  const auto seed_from = [&](std::size_t p) {
    const int cell = walk.first_cell(positions[p]);
    if (cell >= 0) push(cell % n_fine_x, cell / n_fine_x);
  };
  for (std::size_t p = 0; p < positions.size(); ++p) {
    if (field.guarded(p)) seed_from(p);
  }
  // Islands that hold no lattice node: an unguarded candidate particle (phi > level there) seeds
  // like a guarded one when its coarse cell is not active (no lattice there) or when all four
  // corners of its lattice square are outside.
  for (std::size_t p = 0; p < positions.size(); ++p) {
    int i = 0, j = 0;
    if (!candidate[p] || field.guarded(p) || !nodes.cell_of(positions[p], i, j)) continue;
    const std::size_t c = static_cast<std::size_t>(j / r) * ncx + i / r;
    const int stride = near_guard[c] ? 1 : coarse_stride;
    const int ci = i / stride * stride, cj = j / stride * stride;
    if (!active(i / r, j / r) || (!inside(ci, cj) && !inside(ci + stride, cj) &&
                                  !inside(ci, cj + stride) && !inside(ci + stride, cj + stride))) {
      seed_from(p);
    }
  }
  // Trace: a cell with a sign change passes the contour on through each edge whose two nodes
  // differ; cells reached without a sign change (none in exact arithmetic) are dropped.
  std::vector<int> cells;
  for (std::size_t q = 0; q < queue.size(); ++q) {
    const int i = queue[q] % n_fine_x, j = queue[q] / n_fine_x;
    const bool c00 = inside(i, j), c10 = inside(i + 1, j);
    const bool c11 = inside(i + 1, j + 1), c01 = inside(i, j + 1);
    if (c00 == c10 && c00 == c11 && c00 == c01) continue;
    cells.push_back(queue[q]);
    if (c00 != c10) push(i, j - 1);
    if (c10 != c11) push(i + 1, j);
    if (c11 != c01) push(i, j + 1);
    if (c01 != c00) push(i - 1, j);
  }
  return cells;
}

// Edge points (step 4): Brent's root of the exact field along a fine edge. Every evaluation of a
// root lies on its edge, in the square of `square` x `square` fine cells (about h/2) that holds
// the edge's middle (a closed box): the slots reaching that square are gathered once for the
// consecutive edges in it (the contours are followed cell by cell). A whole grid cell would
// gather twice the slots at 5 points per cell. The crossings are shared among the OpenMP threads
// by chunks, each with its own slots; the sums do not depend on which slots hold their nonzero
// terms, so neither do the points.
class EdgeRoots {
 public:
  /// The roots found, by the edge's ends (bits of a.x, a.y, b.x, b.y).
  struct EdgeHash {
    std::size_t operator()(const std::array<double, 4>& e) const {
      std::uint64_t h = 0;
      for (const double v : e) h = (h ^ std::bit_cast<std::uint64_t>(v)) * 0x100000001b3ULL;
      return static_cast<std::size_t>(h ^ (h >> 29));
    }
  };
  /// The roots a pass found: listed as they are found (cheap: most detections make one pass),
  /// indexed by edge only when a later pass at the same refinement takes them again.
  class Memo {
   public:
    void add(const std::array<double, 4>& edge, const Vec2& point) {
      found_.emplace_back(edge, point);
    }
    /// Indexes what was found since the last call (a later root of an edge replaces an earlier).
    void index() {
      for (const auto& [edge, point] : found_) map_.insert_or_assign(edge, point);
      found_.clear();
    }
    const Vec2* find(const std::array<double, 4>& edge) const {
      const auto it = map_.find(edge);
      return it == map_.end() ? nullptr : &it->second;
    }
    bool empty() const { return map_.empty(); }
    void clear() {
      found_.clear();
      map_.clear();
    }

   private:
    std::vector<std::pair<std::array<double, 4>, Vec2>> found_;
    std::unordered_map<std::array<double, 4>, Vec2, EdgeHash> map_;
  };

  /// `memo`: the roots of an earlier pass at the same refinement, taken again for the edges
  /// whose grid cell (of the edge's middle) is not set in `changed` (the field there is as it
  /// was, so the root is bitwise the same); the roots found are added to it. nullptr: none.
  EdgeRoots(const ImprovedField& field, const FineNodes& nodes, double level, double root_tolerance,
            Memo* memo = nullptr, const std::vector<char>* changed = nullptr)
      : field_(field),
        nodes_(nodes),
        level_(level),
        tolerance_t_(root_tolerance * nodes.refinement()),  // fraction of the fine edge
        memo_(memo),
        changed_(changed) {}
  void operator()(std::span<const EdgeCrossing> crossing, std::span<Vec2> point) {
    const auto start = std::chrono::steady_clock::now();
    // The crossings whose root is known from the earlier pass, then the others on the threads.
    // Square by square (FineNodes::gathered()), each gathered once per chunk.
    std::vector<std::pair<long, std::size_t>> open;  // gather square, crossing
    open.reserve(crossing.size());
    for (std::size_t c = 0; c < crossing.size(); ++c) {
      if (!known(crossing[c], point[c])) open.emplace_back(square_of(crossing[c]), c);
    }
    std::stable_sort(open.begin(), open.end(),
                     [](const auto& a, const auto& b) { return a.first < b.first; });
    const std::size_t n = open.size(), n_chunks = (n + kCrossingChunk - 1) / kCrossingChunk;
    std::vector<long> evaluations(n_chunks, 0);
    for_each_on_threads(n_chunks, 1, [&](std::size_t k) {
      GatheredSquare g;
      for (std::size_t o = k * kCrossingChunk; o < std::min(n, (k + 1) * kCrossingChunk); ++o) {
        const auto [square, c] = open[o];
        point[c] = root(crossing[c], nodes_.gathered(square, g), evaluations[k]);
      }
    });
    if (memo_ != nullptr) {
      for (const auto& [square, c] : open) memo_->add(key(crossing[c]), point[c]);
    }
    count_ += static_cast<long>(crossing.size());
    for (const long e : evaluations) evaluations_ += e;
    seconds_ += seconds_since(start);
  }
  /// Edge points found.
  long count() const { return count_; }
  /// Field evaluations spent on them.
  long evaluations() const { return evaluations_; }
  double seconds() const { return seconds_; }

 private:
  static constexpr std::size_t kCrossingChunk = 128;  // about 3.5 evaluations each

  static std::array<double, 4> key(const EdgeCrossing& c) {
    return {c.a.x(), c.a.y(), c.b.x(), c.b.y()};
  }
  // The root of an earlier pass, where the field has not changed since.
  bool known(const EdgeCrossing& c, Vec2& point) const {
    if (memo_ == nullptr || changed_ == nullptr || memo_->empty()) return false;
    const Grid& grid = nodes_.grid();
    const Vec2 middle = 0.5 * (c.a + c.b);
    const int i = std::clamp(grid.cell_i(middle.x()), 0, grid.n_cells_x - 1);
    const int j = std::clamp(grid.cell_j(middle.y()), 0, grid.n_cells_y - 1);
    if ((*changed_)[static_cast<std::size_t>(j) * grid.n_cells_x + i]) return false;
    const Vec2* found = memo_->find(key(c));
    if (found == nullptr) return false;
    point = *found;
    return true;
  }

  // The gather square of the fine cell holding the crossing's middle: its closed square holds
  // the edge, whose ends are fine nodes.
  long square_of(const EdgeCrossing& c) const {
    int fi = 0, fj = 0;
    nodes_.cell_of(0.5 * (c.a + c.b), fi, fj);
    return nodes_.square_key(fi, fj);
  }

  Vec2 root(const EdgeCrossing& c, const ImprovedField::KernelArrays& slots,
            long& evaluations) const {
    const Vec2 d = c.b - c.a;
    const double t = brent_root([&](double s) { return field_(c.a + s * d, slots) - level_; },
                                c.value_a, c.value_b, tolerance_t_, &evaluations);
    return Vec2(c.a + t * d);
  }

  const ImprovedField& field_;
  const FineNodes& nodes_;
  double level_, tolerance_t_;
  Memo* memo_;
  const std::vector<char>* changed_;
  long count_ = 0, evaluations_ = 0;
  double seconds_ = 0.0;
};

// Containment (step 5): the particles (of the candidates; all with an empty `candidate`) the
// contours leave outside. An unguarded particle in a fine cell that a contour crosses must lie
// on the material side of the cell's segment nearest to it (left of it: one segment, or two in a
// saddle cell, which the nearest one decides); in a fine cell without a contour, the cell's
// corners must be inside. The first pass's contours can cut off a particle whose phi is above the
// guard margin where the level set curves within a fine cell (a small island).
std::vector<std::size_t> particles_left_out(const DetectedBoundary& boundary, FineNodes& nodes,
                                            const Grid& grid, std::span<const Vec2> positions,
                                            const std::vector<char>& candidate, double level) {
  const int ncx = grid.n_cells_x, ncy = grid.n_cells_y;
  const int r = nodes.refinement(), n_fine_x = nodes.n_cells_x();
  const std::vector<CellSegment> segments = segments_by_cell(boundary, nodes.geometry());
  std::vector<char> crossed(static_cast<std::size_t>(ncx) * ncy, 0);
  for (const CellSegment& s : segments) {
    crossed[static_cast<std::size_t>(s.cell / n_fine_x / r) * ncx + s.cell % n_fine_x / r] = 1;
  }
  // Each particle's verdict on the threads: 0 inside, 1 outside, 2 its fine cell holds no
  // contour and none of its corners is known (evaluated after, on this thread: the node store
  // grows).
  std::vector<char> verdict(positions.size(), 0);
  for_each_on_threads(positions.size(), kBandChunk, [&](std::size_t p) {
    if (!candidate.empty() && !candidate[p]) return;
    const Vec2& x = positions[p];
    int fi = 0, fj = 0;
    if (!nodes.cell_of(x, fi, fj)) return;
    const int ci = fi / r, cj = fj / r;
    std::span<const CellSegment> near;
    if (crossed[static_cast<std::size_t>(cj) * ncx + ci]) {
      near = segments_in(segments, fj * n_fine_x + fi);
    }
    if (near.empty()) {
      // No contour in p's fine cell: its corners share one sign, which must be inside (a few
      // stacked points make an island smaller than a fine cell, which no node sees). Any corner
      // tells; one already evaluated (the lattice holds one of every fine cell at stride 2)
      // saves an evaluation.
      for (int k = 0; k < 4; ++k) {
        const double* known = nodes.known(fi + (k & 1), fj + (k >> 1));
        if (known != nullptr && !std::isnan(*known)) {
          verdict[p] = *known > level ? 0 : 1;
          return;
        }
      }
      verdict[p] = 2;
      return;
    }
    verdict[p] = outside_nearest_segment(near, x) ? 1 : 0;
  });
  std::vector<std::size_t> left_out;
  for (std::size_t p = 0; p < positions.size(); ++p) {
    if (verdict[p] == 2) {
      int fi = 0, fj = 0;
      nodes.cell_of(positions[p], fi, fj);
      verdict[p] = nodes.value(fi, fj) > level ? 0 : 1;
    }
    if (verdict[p] == 1) left_out.push_back(p);
  }
  return left_out;
}

// The grid cells where the field of the next pass may differ from the last one's: those met by
// the support of each newly guarded particle's guard (within `guard_reach` m of it) and of each
// bridge (2.5 fine cells, `cell` m, about its segment), each widened by a millionth of a cell
// against rounding at its rim (the guards and bridges add exactly 0 beyond their supports).
std::vector<char> cells_changed_by(const Grid& grid, std::span<const Vec2> positions,
                                   std::span<const std::size_t> guarded,
                                   std::span<const std::array<std::size_t, 2>> pairs,
                                   double guard_reach, double cell) {
  const int ncx = grid.n_cells_x, ncy = grid.n_cells_y;
  std::vector<char> changed(static_cast<std::size_t>(ncx) * ncy, 0);
  const Vec2 hair = Vec2::Constant(1e-6 * grid.cell_size);
  const auto index = [&](double v, double origin, int n) {
    return static_cast<int>(
        std::clamp(std::floor((v - origin) / grid.cell_size), 0.0, static_cast<double>(n - 1)));
  };
  const auto mark = [&](const Vec2& lo, const Vec2& hi) {
    const int i0 = index(lo.x() - hair.x(), grid.origin.x(), ncx);
    const int i1 = index(hi.x() + hair.x(), grid.origin.x(), ncx);
    const int j0 = index(lo.y() - hair.y(), grid.origin.y(), ncy);
    const int j1 = index(hi.y() + hair.y(), grid.origin.y(), ncy);
    for (int j = j0; j <= j1; ++j) {
      for (int i = i0; i <= i1; ++i) changed[static_cast<std::size_t>(j) * ncx + i] = 1;
    }
  };
  const Vec2 guard = Vec2::Constant(guard_reach), support = Vec2::Constant(2.5 * cell);
  for (const std::size_t p : guarded) {
    mark(positions[p] - guard.cwiseMax(support), positions[p] + guard.cwiseMax(support));
  }
  for (const auto& [p, q] : pairs) {
    mark(positions[p].cwiseMin(positions[q]) - support,
         positions[p].cwiseMax(positions[q]) + support);
  }
  return changed;
}

}  // namespace

namespace {
std::atomic<bool> keep_nodes{true};
}  // namespace

bool keep_nodes_between_passes(bool on) {
  return keep_nodes.exchange(on);
}

namespace {

// The deformation of the field's particles with their kernels shaped by their neighbours: for the
// band, the neighbours in the cells within a kernel reach of its particles' (the sums do not
// depend on which other particles the search holds).
std::vector<Mat2> shaped_kernels(const ParticleCloud& cloud, const Grid& grid,
                                 const CloudSurvey& survey, const std::optional<Band>& band,
                                 const ParticleCloud& field_cloud, const ImprovedConfig& config,
                                 double kernel_reach) {
  NeighbourCloud near;
  if (band) near = neighbours_of_band(cloud, grid, survey, *band, kernel_reach);
  const NeighbourSearch search(
      band ? ParticleCloud{near.position, near.volume, {}, cloud.initial_spacing} : cloud,
      kernel_reach);
  return neighbour_shaped_deformation(search, field_cloud, config);
}

// The fine nodes of a pass at refinement r: the pass before's, raised by the guards and bridges
// added where the field changed (`changed`), when it had the same refinement (its edge roots kept
// outside those cells: `memo`); else new ones.
FineNodes& pass_nodes(std::optional<FineNodes>& kept_nodes, EdgeRoots::Memo& memo,
                      const std::vector<char>& changed, int r, const Grid& grid,
                      const ImprovedField& field, const ImprovedConfig& config,
                      double initial_spacing, long& field_evaluations) {
  const double h = grid.cell_size;
  if (kept_nodes && kept_nodes->refinement() == r && keep_nodes) {
    kept_nodes->raise(changed);
    memo.index();
  } else {
    kept_nodes.emplace(grid, r,
                       FineNodes::gather_square(r, h, config.radius_factor * initial_spacing),
                       field, config.level, field_evaluations);
    memo.clear();
  }
  return *kept_nodes;
}

// The contours of the fine cells `cells` by marching squares, their edge points Brent's roots
// (`roots`) and the saddles decided on the exact field.
DetectedBoundary contour_cells(FineNodes& nodes, const ImprovedField& field,
                               const ImprovedConfig& config, const std::vector<int>& cells,
                               EdgeRoots& roots, long& field_evaluations) {
  const std::function<double(const Vec2&)> exact_sample = [&](const Vec2& x) {
    ++field_evaluations;
    return field(x);
  };
  return marching_squares_cells(
      nodes.geometry(), [&nodes](int i, int j) { return nodes.value(i, j); }, cells, config.level,
      config.saddle_rule, std::ref(roots), exact_sample);
}

// The passes' totals in the timings: the edge points' and the contours' seconds and counts, and
// the field evaluations (nodes, screening, guards and roots), the field's parts summed.
void record_pass_totals(double edge_seconds, double connection_seconds, long edge_points,
                        long root_evaluations, long field_evaluations, DetectionTimings& timings) {
  const auto& parts = timings.field_parts;
  timings.edge_points = edge_seconds;
  timings.connection = connection_seconds;
  timings.edge_point_count = edge_points;
  timings.root_evaluations = root_evaluations;
  timings.field_evaluations = field_evaluations + root_evaluations;
  timings.field = parts.survey + parts.band + parts.shape + parts.setup + parts.screening +
                  parts.guards + parts.nodes;
}

}  // namespace

// The pipeline: survey (0), band (0), field setup, coarse screening (1), guards (2), then per
// contour pass the fine cells (3), the contours with their edge points (4) and the containment
// check (5); a second pass, with bridges (join_spurious_loops) or the particles left outside
// guarded, only if a particle is outside or an island is in contact; a third at the guards'
// refinement if a particle is still outside; then the spurious loops are removed.
DetectedBoundary detect_improved(const ParticleCloud& input, const Grid& grid,
                                 const ImprovedConfig& config, DetectionTimings& timings) {
  const double h = grid.cell_size;
  auto& parts = timings.field_parts;
  Laps lap;

  // 0. One sweep over the cloud. The fixed-point unit of the kernel sums follows from the whole
  //    cloud's largest weight, so that a field built on part of the particles gives bitwise the
  //    sums of one built on all of them (the sums are of integers: any order gives the same).
  CloudSurvey survey = survey_cloud(input, grid, config.max_stretch);
  //    The kernels' stretch cap (ImprovedConfig::max_stretch, cap_stretch()): F with its
  //    singular values clamped to [1 / cap, cap], the volume following det F both ways, so that
  //    a kernel holds the volume of its own capped ellipse. The survey's cell volumes, which the
  //    band's solid cells read, take the capped volumes where they shrank but not where they
  //    grew: a cell the band calls interior is then interior for the field too. The cap is taken
  //    only when some F may be outside it: by the narrow band on its own copies (the particles
  //    away from the boundary are neither copied nor capped); without the band, or with kernels
  //    shaped by the neighbours (which read the capped volumes outside the band), on a copy of
  //    all. The weight bound V / det F (weight_bound()) holds for V' / det F' = V / det F.
  ParticleCloud cloud = input;
  std::vector<Mat2> capped;
  std::vector<double> capped_volume;
  const bool capping =
      !input.deformation_gradient.empty() &&
      may_exceed_stretch_cap(survey.largest_stretch, survey.smallest_det, config.max_stretch);
  if (capping) survey.largest_stretch = std::min(survey.largest_stretch, config.max_stretch);
  const double kernel_reach = config.radius_factor * cloud.initial_spacing * survey.largest_stretch;
  const double particle_reach =
      ImprovedField::reference_reach(config, cloud.initial_spacing) * survey.largest_stretch;
  const double widest = std::max(grid.n_cells_x, grid.n_cells_y);
  const bool banded = !cloud.position.empty() && particle_reach / h < widest;
  const bool band_caps = capping && banded && config.neighbour_shape == 0.0;
  if (capping && !band_caps) {
    capped.assign(input.deformation_gradient.begin(), input.deformation_gradient.end());
    capped_volume.assign(input.volume.begin(), input.volume.end());
    cap_stretch(capped, config.max_stretch, capped_volume);
    cloud.deformation_gradient = capped;
    cloud.volume = capped_volume;
  }
  lap(parts.survey);
  //    Kernels shaped by the neighbours only narrow (det F' >= (1 - beta) det F): the reaches of
  //    F bound theirs, and their weights are at most 1 / (1 - beta) times those of F.
  const double shaped_weights = 1.0 / (1.0 - config.neighbour_shape);
  const ImprovedField::CloudBounds bounds{
      shaped_weights * ImprovedField::weight_bound(config, cloud.initial_spacing,
                                                   survey.largest_volume, survey.smallest_det),
      4 * cloud.position.size()};
  //    The narrow band; a kernel reaching across the whole grid (a huge stretch or radius) leaves
  //    nothing to screen.
  std::optional<Band> band;
  if (banded) {
    band = select_band(cloud, grid, config, survey, kernel_reach, particle_reach);
    if (band_caps) cap_stretch(band->deformation, config.max_stretch, band->volume);
  }
  ParticleCloud field_cloud =
      band ? ParticleCloud{band->position, band->volume, band->deformation, cloud.initial_spacing}
           : cloud;
  const std::span<const char> interior_by_volume =
      band ? std::span<const char>(band->interior_by_volume) : std::span<const char>();
  lap(parts.band);
  std::vector<Mat2> shaped;
  if (config.neighbour_shape > 0.0) {
    shaped = shaped_kernels(cloud, grid, survey, band, field_cloud, config, kernel_reach);
    field_cloud.deformation_gradient = shaped;
  }
  lap(parts.shape);
  // The wall contacts found by the band are those of the whole cloud, which the band holds a
  // part of.
  ImprovedField field(field_cloud, config, ImprovedField::DeferGuards{},
                      config.mirror_grid_edges ? &grid : nullptr, &bounds,
                      band && config.mirror_grid_edges ? &band->contacts : nullptr);
  timings.field_particles = static_cast<long>(field_cloud.position.size());
  lap(parts.setup);
  long field_evaluations = 0;
  const auto positions = field.positions();

  // 1. Coarse screening.
  const Screening screen = screen_cells(field, grid, config, interior_by_volume, field_evaluations);
  lap(parts.screening);
  // 2. Guards: every particle outside the deep cells is a candidate.
  const std::vector<char> candidate = guard_candidates(positions, grid, screen.deep);
  field.decide_guards(candidate);
  field_evaluations += static_cast<long>(std::count(candidate.begin(), candidate.end(), 1));
  lap(parts.guards);

  // Steps 3-5 run again when the contours of the first pass leave a particle outside (step 5) or
  // split material in contact: bridges, then, for a particle still outside, guards.
  const double guard_reach =
      ImprovedField::reference_guard_reach(config, cloud.initial_spacing) * survey.largest_stretch;
  double edge_seconds = 0.0, connection_seconds = 0.0;
  long root_evaluations = 0, edge_points = 0;
  DetectedBoundary boundary;
  // The fine nodes and edge roots a pass keeps from the one before (pass_nodes()).
  std::optional<FineNodes> kept_nodes;
  EdgeRoots::Memo memo;
  std::vector<char> changed;
  // The loops' classes of the last pass's contours, when they were taken (for the bridges).
  std::optional<LoopClasses> classes;
  for (int pass = 0;; ++pass) {
    classes.reset();
    lap.restart();
    const int r = pass_refinement(config, pass, field.smallest_guard_axis(), h);
    timings.refinement = r;
    FineNodes& nodes = pass_nodes(kept_nodes, memo, changed, r, grid, field, config,
                                  cloud.initial_spacing, field_evaluations);
    // Without guards the field is phi, which the screening evaluated at the grid nodes.
    const bool phi_alone = field.n_guarded() == 0 && field.n_bridges() == 0;
    nodes.reuse_grid_nodes(phi_alone ? std::span<const double>(screen.coarse)
                                     : std::span<const double>());
    // 3. The fine cells to contour.
    const std::vector<int> cells =
        trace_band_cells(nodes, grid, field, screen, interior_by_volume, candidate, guard_reach);
    lap(parts.nodes);

    // 4. Edge points and contours.
    const auto contour_start = std::chrono::steady_clock::now();
    EdgeRoots roots(field, nodes, config.level, config.root_tolerance, &memo, &changed);
    boundary = contour_cells(nodes, field, config, cells, roots, field_evaluations);
    timings.processed_cells = static_cast<long>(cells.size());

    // 5. Containment; the particles left outside get their guard and the contours are found
    //    again.
    const std::vector<std::size_t> left_out =
        particles_left_out(boundary, nodes, grid, positions, candidate, config.level);
    edge_seconds += roots.seconds();
    edge_points += roots.count();
    root_evaluations += roots.evaluations();
    connection_seconds += seconds_since(contour_start) - roots.seconds();
    const auto next = next_pass(config, pass, boundary, positions, left_out, cloud.initial_spacing,
                                classes, timings);
    if (!next) break;
    timings.particles_guarded_after_contouring += static_cast<long>(field.add_guards(left_out));
    if (next->bridging) {
      field.add_bridges(left_out, next->pairs, h / r);
      timings.bridges = static_cast<long>(field.n_bridges());
    }
    changed = cells_changed_by(grid, positions, left_out, next->pairs, guard_reach, h / r);
  }
  remove_unresolved_loops(config, boundary, positions, cloud.initial_spacing, classes, timings);
  record_pass_totals(edge_seconds, connection_seconds, edge_points, root_evaluations,
                     field_evaluations, timings);
  if (config.curvature_correction) {
    const auto start = std::chrono::steady_clock::now();
    correct_curvature(boundary, field.curvature_moment(),
                      config.radius_factor * cloud.initial_spacing);
    timings.filters = seconds_since(start);
  }
  return boundary;
}

}  // namespace pfm::detail

// The improved detector's parts, shared by its files (internal to mpm/detect): the narrow band
// (improved_band.cpp), the fine nodes and the tracing of the cells to contour, the edge roots and
// the containment check (improved_tracing.cpp); improved_detector.cpp runs them (detect_improved).
#pragma once

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

// The loops on the OpenMP threads share their work by chunks of some 30-60 microseconds (more
// than a thread takes to join; a loop of one chunk stays on the calling thread). Chunks, not
// threads, decide what is added in which order, so the results do not depend on the thread
// count. Particles per chunk of the survey's sweep (about 4 ns each):
inline constexpr std::size_t kParticleChunk = 16384;
// Particles per chunk of the loops over the band's particles (copies, containment verdicts: 10-20
// ns each):
inline constexpr std::size_t kBandChunk = 4096;
// Field evaluations per chunk of a batch (about 60 ns each):
inline constexpr std::size_t kEvaluationChunk = 512;
// Cells per chunk of the loops over grid rows (about 1 ns each):
inline constexpr std::size_t kCellChunk = 32768;

// Rows of `width` cells per chunk of a loop over grid rows.
inline std::size_t rows_per_chunk(int width) {
  return std::max<std::size_t>(1, kCellChunk / static_cast<std::size_t>(std::max(width, 1)));
}

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

// The one pass over every particle the improved detector makes: checks each particle (with the
// messages of check_particle()), and gathers the box, the largest stretch and, for the narrow
// band, the cell of each particle and the volume in each cell (sweep_cloud(), vectorised), the
// volumes as the stretch cap `cap` (0: none) shrinks them, never raised (shrink_volumes(), taken
// on a chunk whose F are not all within the cap while its F are still in the cache: reading
// them again costs more than the arithmetic). Large clouds are swept by chunks on the OpenMP
// threads; the chunks' minima and maxima, the volumes of the runs (each added in particle order)
// and the cells' volumes (the runs added in run order) are those of one sweep, whatever the
// thread count.
CloudSurvey survey_cloud(const ParticleCloud& cloud, const Grid& grid, double cap);

// Cells whose every neighbour within `rings` (Chebyshev) is set in `in`; outside the grid counts
// as unset.
std::vector<char> erode(const std::vector<char>& in, int n_x, int n_y, int rings);
// Cells with a set cell within `rings` (Chebyshev) in `in`.
std::vector<char> dilate(const std::vector<char>& in, int n_x, int n_y, int rings);

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
Band select_band(const ParticleCloud& cloud, const Grid& grid, const ImprovedConfig& config,
                 const CloudSurvey& survey, double kernel_reach, double particle_reach);

// The particles of the cloud in the grid cells within `reach` (m) of the band's cells, and those
// outside the grid (which the band takes all of), run by run from the survey: every particle
// within `reach` of a band particle is among them.
struct NeighbourCloud {
  std::vector<Vec2> position;
  std::vector<double> volume;
};
NeighbourCloud neighbours_of_band(const ParticleCloud& cloud, const Grid& grid,
                                  const CloudSurvey& survey, const Band& band, double reach);

// The coarse screening of the grid cells (narrow band, step 1), per grid cell.
struct Screening {
  std::vector<char> reached;  ///< some kernel reaches the cell
  std::vector<char> deep;     ///< interior: by volume, or corners and centre above the band
  std::vector<char> far;      ///< exterior: corners and centre below the band
  /// phi at grid node (i, j) = coarse[j (n_cells_x + 1) + i] where the screening evaluated it,
  /// else NaN.
  std::vector<double> coarse;
};

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
    listed.reserve(wanted.size());  // address space only: the pages not written are not touched
    for (const auto& [i, j] : wanted) {
      const std::size_t k = cache_.index(i, j);
      double& slot = cache_[k];
      if (std::isnan(slot) && !from_grid_node(i, j, slot)) {
        slot = kListed;
        listed.push_back({square_key(i, j), k, i, j});
      }
    }
    // Square by square: a square with kGatherFrom nodes or more is gathered (once per chunk),
    // the others sum over their bins. A node's value does not depend on the order of the nodes
    // in its square or on the chunks (the sums are exact), so the sort need not be stable.
    std::sort(listed.begin(), listed.end(),
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
                                  const std::vector<char>& candidate, double guard_reach);

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
    /// Indexes what was found since the last call (a later root of an edge replaces an earlier),
    /// except the roots in the grid cells set in `changed`, which the coming pass does not take.
    /// A later pass does not want them either: the field only rises, so an edge it crosses was
    /// crossed by every pass since, and the coming pass's root of it replaces this one.
    void index(const Grid& grid, const std::vector<char>& changed) {
      for (const auto& [edge, point] : found_) {
        const Vec2 middle(0.5 * (edge[0] + edge[2]), 0.5 * (edge[1] + edge[3]));
        if (!changed[cell_of_middle(grid, middle)]) map_.insert_or_assign(edge, point);
      }
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
    std::sort(open.begin(), open.end());  // by square, then crossing: a stable sort by square
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

  // The grid cell (j n_cells_x + i) of an edge's middle, clamped to the grid.
  static std::size_t cell_of_middle(const Grid& grid, const Vec2& middle) {
    const int i = std::clamp(grid.cell_i(middle.x()), 0, grid.n_cells_x - 1);
    const int j = std::clamp(grid.cell_j(middle.y()), 0, grid.n_cells_y - 1);
    return static_cast<std::size_t>(j) * grid.n_cells_x + i;
  }
  static std::array<double, 4> key(const EdgeCrossing& c) {
    return {c.a.x(), c.a.y(), c.b.x(), c.b.y()};
  }
  // The root of an earlier pass, where the field has not changed since.
  bool known(const EdgeCrossing& c, Vec2& point) const {
    if (memo_ == nullptr || changed_ == nullptr || memo_->empty()) return false;
    if ((*changed_)[cell_of_middle(nodes_.grid(), 0.5 * (c.a + c.b))]) return false;
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
                                            const std::vector<char>& candidate, double level);

// The grid cells where the field of the next pass may differ from the last one's: those met by
// the support of each newly guarded particle's guard (within `guard_reach` m of it) and of each
// bridge (2.5 fine cells, `cell` m, about its segment), each widened by a millionth of a cell
// against rounding at its rim (the guards and bridges add exactly 0 beyond their supports).
std::vector<char> cells_changed_by(const Grid& grid, std::span<const Vec2> positions,
                                   std::span<const std::size_t> guarded,
                                   std::span<const std::array<std::size_t, 2>> pairs,
                                   double guard_reach, double cell);

}  // namespace pfm::detail

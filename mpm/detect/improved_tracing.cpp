// The improved detector's fine cells (detect_improved(), steps 3 and 5): the cells to contour,
// traced from the particles along the sign changes of the field on the fine nodes, and the
// particles the contours leave outside.
#include "mpm/detect/improved_pipeline.hpp"

namespace pfm::detail {

namespace {

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

}  // namespace

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

}  // namespace pfm::detail

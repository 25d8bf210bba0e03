// The improved detector's narrow band (detect_improved(), step 0): one survey of the cloud, the
// cells interior by their volume, and the particles within reach of the others.
#include "mpm/detect/improved_pipeline.hpp"

namespace pfm::detail {

namespace {

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

}  // namespace

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

namespace {

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

}  // namespace

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

namespace {

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

}  // namespace

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

}  // namespace pfm::detail

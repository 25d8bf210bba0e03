#include "mpm/step/body_fill.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

namespace pfm {

namespace {

/// Area and first moment of a polygon (shoelace), m^2 and m^3.
struct Piece {
  double area = 0.0;
  Vec2 moment = Vec2::Zero();
  bool whole = false;          ///< a whole sub-square (fill_bodies)
  Vec2 centre = Vec2::Zero();  ///< its equal-placement point
};

Piece piece_of(const std::vector<Vec2>& polygon) {
  Piece piece;
  for (std::size_t k = 0; k < polygon.size(); ++k) {
    const Vec2& a = polygon[k];
    const Vec2& b = polygon[(k + 1) % polygon.size()];
    const double twice = a.x() * b.y() - b.x() * a.y();
    piece.area += 0.5 * twice;
    piece.moment += twice / 6.0 * (a + b);
  }
  return piece;
}

/// The part of `polygon` inside the box [lo, hi] (Sutherland and Hodgman's clipping against
/// each side in turn: for a simple polygon, convex or not, the result has the area and the
/// centroid of the intersection, possibly with zero-width parts along the box).
std::vector<Vec2> clip_to_box(std::vector<Vec2> polygon, const Vec2& lo, const Vec2& hi) {
  std::vector<Vec2> out;
  for (int side = 0; side < 4 && !polygon.empty(); ++side) {
    const int axis = side / 2;
    const bool upper = side % 2 == 1;
    const double bound = upper ? hi[axis] : lo[axis];
    const auto inside = [&](const Vec2& x) { return upper ? x[axis] <= bound : x[axis] >= bound; };
    out.clear();
    for (std::size_t k = 0; k < polygon.size(); ++k) {
      const Vec2& a = polygon[k];
      const Vec2& b = polygon[(k + 1) % polygon.size()];
      if (inside(a)) out.push_back(a);
      if (inside(a) != inside(b)) {
        Vec2 x = a + (bound - a[axis]) / (b[axis] - a[axis]) * (b - a);
        x[axis] = bound;
        out.push_back(x);
      }
    }
    polygon.swap(out);
  }
  return polygon;
}

/// Whether the segment a-b meets the closed box [lo, hi] (Liang and Barsky's clipping).
bool segment_meets_box(const Vec2& a, const Vec2& b, const Vec2& lo, const Vec2& hi) {
  double t0 = 0.0, t1 = 1.0;
  const Vec2 d = b - a;
  for (int axis = 0; axis < 2; ++axis) {
    if (d[axis] == 0.0) {
      if (a[axis] < lo[axis] || a[axis] > hi[axis]) return false;
      continue;
    }
    double ta = (lo[axis] - a[axis]) / d[axis], tb = (hi[axis] - a[axis]) / d[axis];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return false;
  }
  return true;
}

}  // namespace

void Particles::reserve(std::size_t n) {
  position.reserve(n);
  reference_position.reserve(n);
  velocity.reserve(n);
  mass.reserve(n);
  volume.reserve(n);
  initial_volume.reserve(n);
  half_length.reserve(n);
  stress.reserve(n);
  state.reserve(n);
  deformation_gradient.reserve(n);
  material.reserve(n);
  body.reserve(n);
}

double largest_density(const Particles& particles) {
  double density = 0.0;
  for (std::size_t p = 0; p < particles.size(); ++p)
    density = std::max(density, particles.mass[p] / particles.initial_volume[p]);
  return density;
}

void Particles::add(const Vec2& x, double particle_volume, double density, const Vec2& half_size,
                    int material_index, int body_index) {
  position.push_back(x);
  reference_position.push_back(x);
  velocity.push_back(Vec2::Zero());
  mass.push_back(density * particle_volume);
  volume.push_back(particle_volume);
  initial_volume.push_back(particle_volume);
  half_length.push_back(half_size);
  stress.push_back(Stress::Zero());
  state.push_back(PointState{});
  deformation_gradient.push_back(Mat2::Identity());
  material.push_back(material_index);
  body.push_back(body_index);
}

double polygon_top(const std::vector<Vec2>& polygon, double x) {
  double top = std::numeric_limits<double>::quiet_NaN();
  const std::size_t n = polygon.size();
  for (std::size_t i = 0, j = n - 1; i < n; j = i++) {
    const Vec2& a = polygon[i];
    const Vec2& b = polygon[j];
    const double lo = std::min(a.x(), b.x()), hi = std::max(a.x(), b.x());
    if (x < lo || x > hi) continue;
    double y;
    if (hi == lo) {
      y = std::max(a.y(), b.y());  // vertical edge
    } else {
      y = a.y() + (x - a.x()) * (b.y() - a.y()) / (b.x() - a.x());
    }
    if (std::isnan(top) || y > top) top = y;
  }
  return top;
}

void placement_points_1d(Placement placement, int n, std::vector<double>& position,
                         std::vector<double>& weight) {
  position.assign(static_cast<std::size_t>(n), 0.0);
  weight.assign(static_cast<std::size_t>(n), 1.0 / n);
  if (placement != Placement::kGauss) {  // equal spacing (conforming: inside the polygon)
    for (int a = 0; a < n; ++a) position[static_cast<std::size_t>(a)] = (a + 0.5) / n;
    return;
  }
  // Gauss-Legendre points on [-1, 1] by Newton on P_n (Golub-Welsch is overkill for n <= 8).
  for (int a = 0; a < n; ++a) {
    double t = std::cos(M_PI * (a + 0.75) / (n + 0.5));
    double derivative = 1.0;
    for (int iteration = 0; iteration < 100; ++iteration) {
      double p0 = 1.0, p1 = t;
      for (int k = 2; k <= n; ++k) {
        const double p2 = ((2.0 * k - 1.0) * t * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
      }
      derivative = n * (t * p1 - p0) / (t * t - 1.0);
      const double dt = p1 / derivative;
      t -= dt;
      if (std::abs(dt) < 1e-16) break;
    }
    // Newton converges to the roots in descending order; store ascending.
    const std::size_t slot = static_cast<std::size_t>(n - 1 - a);
    position[slot] = 0.5 * (t + 1.0);
    weight[slot] = 1.0 / ((1.0 - t * t) * derivative * derivative);  // 2 / (...) on [-1,1], /2
  }
}

namespace {

/// The points of body `b` from its particle file, each the square of its volume; a point inside
/// an earlier body is that body's, as for the cells' points.
void add_file_points(const Case& c, std::size_t b, double g, Particles& particles) {
  const BodySpec& body = c.bodies[b];
  for (std::size_t k = 0; k < body.point_position.size(); ++k) {
    const Vec2& x = body.point_position[k];
    const double v = body.point_volume[k];
    bool taken = false;
    for (std::size_t other = 0; other < b && !taken; ++other)
      taken = point_in_polygon(c.bodies[other].polygon, x);
    if (taken) continue;
    const double half = 0.5 * std::sqrt(v);
    const int material = body.point_material.empty() ? body.material : body.point_material[k];
    particles.add(x, v, c.materials[static_cast<std::size_t>(material)].unit_weight / g,
                  Vec2(half, half), material, static_cast<int>(b));
    if (!body.point_stress.empty()) particles.stress.back() = body.point_stress[k];
  }
}

/// The grid cells [i0, i1] x [j0, j1] of a polygon's bounding box, numbered row by row.
struct CellBox {
  int i0 = 0, i1 = 0, j0 = 0, j1 = 0;
  int columns() const { return i1 - i0 + 1; }
  std::size_t size() const { return static_cast<std::size_t>(columns()) * (j1 - j0 + 1); }
  std::size_t index(int i, int j) const {
    return static_cast<std::size_t>((j - j0) * columns() + (i - i0));
  }
};

CellBox cell_box(const Grid& grid, const std::vector<Vec2>& polygon) {
  Vec2 lo = polygon.front(), hi = polygon.front();
  for (const Vec2& v : polygon) {
    lo = lo.cwiseMin(v);
    hi = hi.cwiseMax(v);
  }
  return {std::max(0, grid.cell_i(lo.x())), std::min(grid.n_cells_x - 1, grid.cell_i(hi.x())),
          std::max(0, grid.cell_j(lo.y())), std::min(grid.n_cells_y - 1, grid.cell_j(hi.y()))};
}

/// The cells of `box` that the polygon's edges touch (1), the others 0.
std::vector<char> cut_cells(const Grid& grid, const std::vector<Vec2>& polygon,
                            const CellBox& box) {
  std::vector<char> cut(box.size(), 0);
  for (std::size_t k = 0; k < polygon.size(); ++k) {
    const Vec2& a = polygon[k];
    const Vec2& e = polygon[(k + 1) % polygon.size()];
    const Vec2 low = a.cwiseMin(e), high = a.cwiseMax(e);
    for (int j = std::max(box.j0, grid.cell_j(low.y()));
         j <= std::min(box.j1, grid.cell_j(high.y())); ++j) {
      for (int i = std::max(box.i0, grid.cell_i(low.x()));
           i <= std::min(box.i1, grid.cell_i(high.x())); ++i) {
        if (segment_meets_box(a, e, grid.node_position(i, j), grid.node_position(i + 1, j + 1)))
          cut[box.index(i, j)] = 1;
      }
    }
  }
  return cut;
}

/// Conforming placement: the sub-squares' parts inside the polygon in each cut cell; a part below
/// a quarter of a sub-square (`small_part`) joins the nearest other part of its cell (areas and
/// first moments add, so the sums stay exact), lest a sliver make a point of almost no mass.
/// `local`: the sub-squares' centres in the cell (fractions of h), n per axis.
std::vector<std::vector<Piece>> cut_cell_pieces(const Grid& grid, const std::vector<Vec2>& polygon,
                                                const CellBox& box, const std::vector<char>& cut,
                                                const std::vector<double>& local, int n,
                                                double small_part) {
  const double h = grid.cell_size;
  const double full = h * h / (n * n);
  std::vector<std::vector<Piece>> cut_pieces(cut.size());
  for (int j = box.j0; j <= box.j1 && !cut.empty(); ++j) {
    for (int i = box.i0; i <= box.i1; ++i) {
      if (!cut[box.index(i, j)]) continue;
      const Vec2 corner = grid.node_position(i, j);
      const std::vector<Vec2> in_cell =
          clip_to_box(polygon, corner, grid.node_position(i + 1, j + 1));
      std::vector<Piece>& pieces = cut_pieces[box.index(i, j)];
      for (int bj = 0; bj < n && !in_cell.empty(); ++bj) {
        for (int ai = 0; ai < n; ++ai) {
          const Vec2 sub = corner + h / n * Vec2(ai, bj);
          Piece piece = piece_of(clip_to_box(in_cell, sub, sub + Vec2(h / n, h / n)));
          if (!(piece.area > 1e-12 * full)) continue;  // outside, or a rounding sliver
          piece.whole = piece.area >= (1.0 - 1e-12) * full;
          piece.centre = corner + h * Vec2(local[static_cast<std::size_t>(ai)],
                                           local[static_cast<std::size_t>(bj)]);
          pieces.push_back(piece);
        }
      }
      while (pieces.size() > 1) {
        std::size_t small = 0;
        for (std::size_t k = 1; k < pieces.size(); ++k)
          if (pieces[k].area < pieces[small].area) small = k;
        if (pieces[small].area >= small_part) break;
        const Vec2 at = pieces[small].moment / pieces[small].area;
        std::size_t nearest = small == 0 ? 1 : 0;
        for (std::size_t k = 0; k < pieces.size(); ++k) {
          if (k != small && (pieces[k].moment / pieces[k].area - at).squaredNorm() <
                                (pieces[nearest].moment / pieces[nearest].area - at).squaredNorm())
            nearest = k;
        }
        pieces[nearest].area += pieces[small].area;
        pieces[nearest].moment += pieces[small].moment;
        pieces[nearest].whole = false;
        pieces.erase(pieces.begin() + static_cast<std::ptrdiff_t>(small));
      }
    }
  }
  return cut_pieces;
}

/// A cell whose only part is still below `small_part` (the polygon clips its corner) gives it to
/// the nearest part of a neighbouring cut cell, cells in row order: alone on its nodes, a point
/// that light would be flung by any force there.
void merge_lone_slivers(std::vector<std::vector<Piece>>& cut_pieces, const CellBox& box,
                        double small_part) {
  for (int j = box.j0; j <= box.j1 && !cut_pieces.empty(); ++j) {
    for (int i = box.i0; i <= box.i1; ++i) {
      std::vector<Piece>& pieces = cut_pieces[box.index(i, j)];
      if (pieces.size() != 1 || pieces[0].area >= small_part) continue;
      const Vec2 at = pieces[0].moment / pieces[0].area;
      Piece* nearest = nullptr;
      double best = std::numeric_limits<double>::infinity();
      for (int nj = std::max(box.j0, j - 1); nj <= std::min(box.j1, j + 1); ++nj) {
        for (int ni = std::max(box.i0, i - 1); ni <= std::min(box.i1, i + 1); ++ni) {
          if (ni == i && nj == j) continue;
          for (Piece& other : cut_pieces[box.index(ni, nj)]) {
            const double d = (other.moment / other.area - at).squaredNorm();
            if (d < best) {
              best = d;
              nearest = &other;
            }
          }
        }
      }
      if (nearest == nullptr) continue;
      nearest->area += pieces[0].area;
      nearest->moment += pieces[0].moment;
      nearest->whole = false;
      pieces.clear();
    }
  }
}

}  // namespace

Particles fill_bodies(const Case& c) {
  Particles particles;
  const Grid& grid = c.grid;
  const double h = grid.cell_size;
  const double g = c.gravity.g > 0.0 ? c.gravity.g : 9.81;
  for (std::size_t b = 0; b < c.bodies.size(); ++b) {
    const BodySpec& body = c.bodies[b];
    const double density = c.materials[static_cast<std::size_t>(body.material)].unit_weight / g;
    if (body.from_file()) {
      add_file_points(c, b, g, particles);
      continue;
    }
    std::vector<double> local, weight;
    placement_points_1d(body.placement, body.points_per_cell, local, weight);
    const Vec2 half_size(0.5 * h / body.points_per_cell, 0.5 * h / body.points_per_cell);
    const CellBox box = cell_box(grid, body.polygon);
    const int n = body.points_per_cell;
    const double full = h * h / (n * n);  // a sub-square (equal and conforming placement)
    // Conforming placement: the cells that the polygon's edges touch are filled with the pieces
    // of their sub-squares inside the polygon.
    std::vector<char> cut;
    if (body.placement == Placement::kConforming) cut = cut_cells(grid, body.polygon, box);
    const auto add = [&](const Vec2& x, double v) {
      for (std::size_t other = 0; other < b; ++other)
        if (point_in_polygon(c.bodies[other].polygon, x)) return;  // the first body's
      particles.add(x, v, density, half_size, body.material, static_cast<int>(b));
    };
    const double small_part = 0.25 * full;
    std::vector<std::vector<Piece>> cut_pieces =
        cut_cell_pieces(grid, body.polygon, box, cut, local, n, small_part);
    merge_lone_slivers(cut_pieces, box, small_part);
    // Cell by cell, row by row, so particle ids follow the cells (good memory locality).
    for (int j = box.j0; j <= box.j1; ++j) {
      for (int i = box.i0; i <= box.i1; ++i) {
        const Vec2 corner = grid.node_position(i, j);
        if (cut.empty() || !cut[box.index(i, j)]) {
          for (int bj = 0; bj < n; ++bj) {
            for (int ai = 0; ai < n; ++ai) {
              const Vec2 x = corner + h * Vec2(local[static_cast<std::size_t>(ai)],
                                               local[static_cast<std::size_t>(bj)]);
              if (point_in_polygon(body.polygon, x)) {
                add(x, h * h * weight[static_cast<std::size_t>(ai)] *
                           weight[static_cast<std::size_t>(bj)]);
              }
            }
          }
          continue;
        }
        for (const Piece& piece : cut_pieces[box.index(i, j)]) {
          if (piece.whole) {
            add(piece.centre, full);  // a whole sub-square: as the equal placement
          } else {
            add(piece.moment / piece.area, piece.area);  // at the centroid of the part
          }
        }
      }
    }
  }
  return particles;
}

void apply_k0_stress(const Case& c, Particles& particles) {
  for (std::size_t p = 0; p < particles.size(); ++p) {
    const BodySpec& body = c.bodies[static_cast<std::size_t>(particles.body[p])];
    const MaterialRecord& m = c.materials[static_cast<std::size_t>(particles.material[p])];
    const double nu = elastic_parameters(m.model).poisson_ratio;
    const double k0 = c.initial_stress.k0 ? *c.initial_stress.k0 : nu / (1.0 - nu);
    const Vec2& x = particles.position[p];
    const double depth = polygon_top(body.polygon, x.x()) - x.y();
    const double sigma_v = -m.unit_weight * std::max(depth, 0.0);
    particles.stress[p] = Stress(k0 * sigma_v, sigma_v, 0.0, k0 * sigma_v);
  }
}

double initial_particle_spacing(const Case& c) {
  double spacing = std::numeric_limits<double>::infinity();
  for (const BodySpec& body : c.bodies) {
    if (body.from_file()) {
      for (const double v : body.point_volume) spacing = std::min(spacing, std::sqrt(v));
    } else {
      spacing = std::min(spacing, c.grid.cell_size / body.points_per_cell);
    }
  }
  return spacing;
}

}  // namespace pfm

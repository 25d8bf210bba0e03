// Volume of Fluid (thesis 3.4.2, 4.3): volume of material per cell (eq. 4.8), the Sobel operator
// (eq. 3.36) for the interface normal, and a piecewise-linear interface (PLIC, Youngs' method)
// in every mixed cell. The thesis stopped before reconstructing the interface (4.3.2); we finish
// the method the standard way so it can be compared.
//
// Result: the boundary of the reconstructed material region, i.e. the union over the cells of
// the full squares and, in mixed cells, the part of the square behind the PLIC line (the area
// of that part equals the cell's fraction). It consists of the PLIC chords plus the pieces of
// cell faces where the material of the two cells on either side does not match (the jumps
// between neighbouring chords, which PLIC does not make continuous). Pieces on the edge of the
// VOF grid are left out, so a body cut by the grid edge gives open chains ending on it
// (contour.hpp). Where two material parts touch in a single point (diagonal cells, or chords
// meeting on a face) the point is split, moving each copy 1e-9 cells into its own part, so no
// point belongs to two contours.
#include <algorithm>
#include <cmath>
#include <map>
#include <numbers>
#include <utility>

#include "mpm/detect/detect_internal.hpp"

namespace pfm::detail {

namespace {

using Clock = std::chrono::steady_clock;

// The VOF grid: nx x ny cells of size h from origin. Faces: horizontal face (i, j) is the bottom
// face of cell (i, j), at y = y0 + j h, x in [x0 + i h, x0 + (i + 1) h], index j nx + i
// (j in [0, ny]); vertical face (i, j) is the left face of cell (i, j), index
// n_horizontal + j (nx + 1) + i (i in [0, nx]). A face's parameter t runs from its lower-left
// node (t = 0) along +x or +y to its other node (t = 1).
struct VofGrid {
  Vec2 origin;
  double h = 1.0;
  int nx = 0, ny = 0;
  int n_horizontal() const { return nx * (ny + 1); }
  int horizontal(int i, int j) const { return j * nx + i; }
  int vertical(int i, int j) const { return n_horizontal() + j * (nx + 1) + i; }
  bool is_horizontal(int face) const { return face < n_horizontal(); }
  // Lower-left node of a face as (i, j).
  std::pair<int, int> low_node(int face) const {
    if (is_horizontal(face)) return {face % nx, face / nx};
    const int f = face - n_horizontal();
    return {f % (nx + 1), f / (nx + 1)};
  }
  Vec2 node_position(int i, int j) const { return origin + Vec2(i * h, j * h); }
  bool on_grid_edge(int face) const {
    const auto [i, j] = low_node(face);
    return is_horizontal(face) ? (j == 0 || j == ny) : (i == 0 || i == nx);
  }
};

// Sub-interval [lo, hi] of a face's parameter covered by one cell's material; empty if lo >= hi.
struct Interval {
  double lo = 1.0, hi = 0.0;
  bool empty() const { return !(lo < hi); }
};

// Parameter of the zero of the linear function with values g_low at t = 0 and g_high at t = 1
// (of opposite signs); snapped to the nodes within 1e-12 so that a crossing at a node is the node.
double crossing(double g_low, double g_high) {
  const double t = g_low / (g_low - g_high);
  if (t < 1e-12) return 0.0;
  if (t > 1.0 - 1e-12) return 1.0;
  return t;
}

// Material part {g >= 0} of a face whose end values are g_low (t = 0) and g_high (t = 1).
Interval covered(double g_low, double g_high) {
  if (g_low >= 0.0 && g_high >= 0.0) return {0.0, 1.0};
  if (g_low < 0.0 && g_high < 0.0) return {};
  const double t = crossing(g_low, g_high);
  return g_low >= 0.0 ? Interval{0.0, t} : Interval{t, 1.0};
}

// Area of {x in the square [-h/2, h/2]^2 : n.x <= s} (Sutherland-Hodgman clip + shoelace).
double cut_area(const Vec2& n, double s, double h) {
  const double a = 0.5 * h;
  const Vec2 corner[4] = {Vec2(-a, -a), Vec2(a, -a), Vec2(a, a), Vec2(-a, a)};
  Vec2 polygon[8];
  int m = 0;
  for (int k = 0; k < 4; ++k) {
    const Vec2& p = corner[k];
    const Vec2& q = corner[(k + 1) % 4];
    const double gp = s - n.dot(p), gq = s - n.dot(q);
    if (gp >= 0.0) polygon[m++] = p;
    if ((gp >= 0.0) != (gq >= 0.0)) polygon[m++] = p + (gp / (gp - gq)) * (q - p);
  }
  double area = 0.0;
  for (int k = 0; k < m; ++k) {
    const Vec2& p = polygon[k];
    const Vec2& q = polygon[(k + 1) % m];
    area += p.x() * q.y() - q.x() * p.y();
  }
  return 0.5 * area;
}

// PLIC: the offset s of the line n.x = s (x from the cell centre) behind which the material
// fills `fraction` of the cell. Bisection on the monotone area; 64 halvings reach round-off.
double plic_offset(const Vec2& n, double fraction, double h) {
  const double reach = 0.5 * h * (std::abs(n.x()) + std::abs(n.y()));
  double lo = -reach, hi = reach;
  const double target = fraction * h * h;
  for (int k = 0; k < 64 && hi - lo > 1e-15 * h; ++k) {
    const double mid = 0.5 * (lo + hi);
    (cut_area(n, mid, h) < target ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

double angle_of(const Vec2& v) {
  return std::atan2(v.y(), v.x());
}

// Clockwise angle from direction a to direction b, in (0, 2 pi].
double clockwise_angle(const Vec2& a, const Vec2& b) {
  double d = angle_of(a) - angle_of(b);
  while (d <= 0.0) d += 2.0 * std::numbers::pi;
  while (d > 2.0 * std::numbers::pi) d -= 2.0 * std::numbers::pi;
  return d;
}

// Points and directed segments of the boundary, with point identity by node or (face, t).
class BoundaryBuilder {
 public:
  explicit BoundaryBuilder(const VofGrid& g)
      : grid_(g), node_point_(static_cast<std::size_t>(g.nx + 1) * (g.ny + 1), -1) {}

  int point_on_face(int face, double t) {
    const auto [i, j] = grid_.low_node(face);
    const bool horizontal = grid_.is_horizontal(face);
    if (t <= 0.0) return node(i, j);
    if (t >= 1.0) return horizontal ? node(i + 1, j) : node(i, j + 1);
    // Crossings computed from the two cells' own lines may differ in the last bits where both
    // lines meet the face at the same point: parameters within 1e-12 are one point.
    auto& on_face = face_point_[face];
    for (const auto& [t_known, id] : on_face) {
      if (std::abs(t_known - t) <= 1e-12) return id;
    }
    const int id = static_cast<int>(points_.size());
    const Vec2 base = grid_.node_position(i, j);
    points_.push_back(horizontal ? Vec2(base.x() + t * grid_.h, base.y())
                                 : Vec2(base.x(), base.y() + t * grid_.h));
    on_face.emplace_back(t, id);
    return id;
  }

  void add_segment(int from, int to) {
    if (from != to) segments_.push_back({from, to});
  }

  // Splits points joined to more than one incoming or outgoing segment (see the file comment)
  // and assembles the contours.
  DetectedBoundary assemble() {
    const int n = static_cast<int>(points_.size());
    std::vector<std::vector<int>> outgoing(n), incoming(n);
    for (int s = 0; s < static_cast<int>(segments_.size()); ++s) {
      outgoing[segments_[s].from].push_back(s);
      incoming[segments_[s].to].push_back(s);
    }
    const double nudge = 1e-9 * grid_.h;
    for (int p = 0; p < n; ++p) {
      if (outgoing[p].size() <= 1 && incoming[p].size() <= 1) continue;
      const Vec2 centre = points_[p];
      std::vector<char> taken(outgoing[p].size(), 0);
      std::vector<int> unpaired_in;
      for (const int in : incoming[p]) {
        // The material of the incoming segment lies clockwise of it (seen from the point): its
        // boundary goes on along the first outgoing ray clockwise from the incoming one.
        const Vec2 ray_in = points_[segments_[in].from] - centre;
        int best = -1;
        double best_angle = 1e300;
        for (std::size_t k = 0; k < outgoing[p].size(); ++k) {
          if (taken[k]) continue;
          const double a = clockwise_angle(ray_in, points_[segments_[outgoing[p][k]].to] - centre);
          if (a < best_angle) {
            best_angle = a;
            best = static_cast<int>(k);
          }
        }
        if (best < 0) {
          unpaired_in.push_back(in);
          continue;
        }
        taken[best] = 1;
        const int out = outgoing[p][best];
        // A copy of the point moved into the material wedge, which spans best_angle
        // counter-clockwise from the outgoing ray to the incoming one.
        const Vec2 ray_out = (points_[segments_[out].to] - centre).normalized();
        const double half = 0.5 * best_angle;
        const Vec2 into(std::cos(half) * ray_out.x() - std::sin(half) * ray_out.y(),
                        std::sin(half) * ray_out.x() + std::cos(half) * ray_out.y());
        const int copy = static_cast<int>(points_.size());
        points_.push_back(centre + nudge * into);
        segments_[in].to = copy;
        segments_[out].from = copy;
      }
      // Unpaired segments (chains ending on the grid edge) end or start at copies of their own.
      for (const int in : unpaired_in) {
        segments_[in].to = static_cast<int>(points_.size());
        points_.push_back(centre);
      }
      for (std::size_t k = 0; k < outgoing[p].size(); ++k) {
        if (taken[k]) continue;
        segments_[outgoing[p][k]].from = static_cast<int>(points_.size());
        points_.push_back(centre);
      }
    }
    return assemble_contours(points_, segments_);
  }

 private:
  int node(int i, int j) {
    int& slot = node_point_[static_cast<std::size_t>(j) * (grid_.nx + 1) + i];
    if (slot < 0) {
      slot = static_cast<int>(points_.size());
      points_.push_back(grid_.node_position(i, j));
    }
    return slot;
  }

  const VofGrid& grid_;
  std::vector<int> node_point_;
  std::map<int, std::vector<std::pair<double, int>>> face_point_;  ///< face -> (t, point)
  std::vector<Vec2> points_;
  std::vector<DirectedSegment> segments_;
};

}  // namespace

DetectedBoundary detect_volume_of_fluid(const ParticleCloud& cloud, const Grid& grid,
                                        const VofConfig& config, DetectionTimings& timings) {
  const auto field_start = Clock::now();
  VofGrid g;
  g.origin = grid.origin;
  g.h = grid.cell_size / config.refinement;
  g.nx = grid.n_cells_x * config.refinement;
  g.ny = grid.n_cells_y * config.refinement;
  timings.refinement = config.refinement;
  const std::size_t n_cells = static_cast<std::size_t>(g.nx) * g.ny;

  // 1. Volume of material per cell as a fraction of the cell (eq. 4.8), clamped to [0, 1]
  //    (compressed material can put more than a cell's volume into it).
  std::vector<double> fraction(n_cells, 0.0);
  const double cell_area = g.h * g.h;
  const double count_volume = cloud.initial_spacing * cloud.initial_spacing;
  for (std::size_t p = 0; p < cloud.position.size(); ++p) {
    const Vec2& x = cloud.position[p];
    const int i = static_cast<int>(std::floor((x.x() - g.origin.x()) / g.h));
    const int j = static_cast<int>(std::floor((x.y() - g.origin.y()) / g.h));
    if (i < 0 || j < 0 || i >= g.nx || j >= g.ny) continue;
    fraction[static_cast<std::size_t>(j) * g.nx + i] +=
        (config.fraction == VofFraction::kCount ? count_volume : cloud.volume[p]) / cell_area;
  }
  for (double& f : fraction) f = std::min(f, 1.0);
  const auto f_at = [&](int i, int j) {
    return (i < 0 || j < 0 || i >= g.nx || j >= g.ny)
               ? 0.0
               : fraction[static_cast<std::size_t>(j) * g.nx + i];
  };
  const double tol = config.mixed_tolerance;
  const auto full = [tol](double f) { return f >= 1.0 - tol; };
  const auto empty = [tol](double f) { return f <= tol; };
  timings.field = seconds_since(field_start);

  // 2. Per cell: the material part of each face (for the face pieces) and, in mixed cells, the
  //    PLIC chord with the Sobel normal (eq. 3.36).
  const auto edge_start = Clock::now();
  const int n_faces = g.n_horizontal() + (g.nx + 1) * g.ny;
  std::vector<Interval> below_or_left(n_faces), above_or_right(n_faces);
  BoundaryBuilder builder(g);
  long mixed_cells = 0;
  for (int j = 0; j < g.ny; ++j) {
    for (int i = 0; i < g.nx; ++i) {
      const double f = f_at(i, j);
      if (empty(f)) continue;
      // Faces of the cell counter-clockwise: bottom, right, top, left.
      const int face[4] = {g.horizontal(i, j), g.vertical(i + 1, j), g.horizontal(i, j + 1),
                           g.vertical(i, j)};
      Interval* slot[4] = {&above_or_right[face[0]], &below_or_left[face[1]],
                           &below_or_left[face[2]], &above_or_right[face[3]]};
      if (full(f)) {
        for (int k = 0; k < 4; ++k) *slot[k] = Interval{0.0, 1.0};
        continue;
      }
      ++mixed_cells;
      // Sobel operator (eq. 3.36) as a central difference: G points up the fraction.
      const double gx = (f_at(i + 1, j - 1) + 2.0 * f_at(i + 1, j) + f_at(i + 1, j + 1)) -
                        (f_at(i - 1, j - 1) + 2.0 * f_at(i - 1, j) + f_at(i - 1, j + 1));
      const double gy = (f_at(i - 1, j + 1) + 2.0 * f_at(i, j + 1) + f_at(i + 1, j + 1)) -
                        (f_at(i - 1, j - 1) + 2.0 * f_at(i, j - 1) + f_at(i + 1, j - 1));
      const double norm = std::hypot(gx, gy);
      // Outward normal; without a gradient (symmetric surroundings) the material is put at the
      // bottom of the cell.
      const Vec2 n = norm > 0.0 ? Vec2(-gx / norm, -gy / norm) : Vec2(0.0, 1.0);
      const double s = plic_offset(n, f, g.h);
      // g = s - n.(x - centre) at the corners (counter-clockwise from the lower left).
      const double a = 0.5 * g.h;
      const double gc[4] = {s - n.dot(Vec2(-a, -a)), s - n.dot(Vec2(a, -a)), s - n.dot(Vec2(a, a)),
                            s - n.dot(Vec2(-a, a))};
      // End values (t = 0, t = 1) of each face in its own parameter direction.
      const double g_low[4] = {gc[0], gc[1], gc[3], gc[0]};
      const double g_high[4] = {gc[1], gc[2], gc[2], gc[3]};
      for (int k = 0; k < 4; ++k) *slot[k] = covered(g_low[k], g_high[k]);
      // Counter-clockwise, the material arc of the cell boundary ends where it leaves the
      // material (corner k inside, corner k + 1 outside) and starts where it enters it; the
      // chord closes the material polygon from the end of the arc to its start.
      int exit_point = -1, entry_point = -1;
      for (int k = 0; k < 4; ++k) {
        const bool in_k = gc[k] >= 0.0, in_next = gc[(k + 1) % 4] >= 0.0;
        if (in_k == in_next) continue;
        const int point = builder.point_on_face(face[k], crossing(g_low[k], g_high[k]));
        (in_k ? exit_point : entry_point) = point;
      }
      if (exit_point >= 0 && entry_point >= 0) builder.add_segment(exit_point, entry_point);
    }
  }
  // 3. Face pieces covered by the material of exactly one of the two cells. Material below a
  //    horizontal face runs in -x, above it in +x; left of a vertical face in +y, right in -y.
  for (int face = 0; face < n_faces; ++face) {
    const Interval& first = below_or_left[face];
    const Interval& second = above_or_right[face];
    if ((first.empty() && second.empty()) || g.on_grid_edge(face)) continue;
    double cuts[6];
    int n_cuts = 0;
    cuts[n_cuts++] = 0.0;
    cuts[n_cuts++] = 1.0;
    for (const Interval* iv : {&first, &second}) {
      if (iv->empty()) continue;
      cuts[n_cuts++] = iv->lo;
      cuts[n_cuts++] = iv->hi;
    }
    std::sort(cuts, cuts + n_cuts);
    const bool horizontal = g.is_horizontal(face);
    for (int k = 0; k + 1 < n_cuts; ++k) {
      const double u = cuts[k], v = cuts[k + 1];
      if (!(u < v)) continue;
      // [u, v] lies between consecutive cuts: inside or outside each interval as a whole (a
      // midpoint test would fail on pieces one rounding error long).
      const bool in_first = !first.empty() && first.lo <= u && v <= first.hi;
      const bool in_second = !second.empty() && second.lo <= u && v <= second.hi;
      if (in_first == in_second) continue;
      const int pu = builder.point_on_face(face, u), pv = builder.point_on_face(face, v);
      const bool forward = horizontal ? in_second : in_first;
      forward ? builder.add_segment(pu, pv) : builder.add_segment(pv, pu);
    }
  }
  timings.edge_points = seconds_since(edge_start);
  timings.processed_cells = mixed_cells;

  const auto connection_start = Clock::now();
  DetectedBoundary boundary = builder.assemble();
  timings.connection = seconds_since(connection_start);
  for (const auto& c : boundary.contours) {
    timings.edge_point_count += static_cast<long>(c.points.size());
  }
  return boundary;
}

}  // namespace pfm::detail

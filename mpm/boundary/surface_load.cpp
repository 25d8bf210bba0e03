#include "mpm/boundary/surface_load.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "mpm/core/shape_functions.hpp"

namespace pfm::boundary {

namespace {

double cross(const Vec2& a, const Vec2& b) {
  return a.x() * b.y() - a.y() * b.x();
}

// n |B'| = B' turned clockwise (material on the left).
Vec2 turned_clockwise(const Vec2& v) {
  return Vec2(v.y(), -v.x());
}

// The hodograph B' as a Bezier segment of degree n - 1 (thesis eq. 6.7); degree >= 2 only.
BezierSegment hodograph(const BezierSegment& segment) {
  BezierSegment d;
  d.degree = segment.degree - 1;
  for (int i = 0; i < segment.degree; ++i) {
    d.control[i] = segment.degree * (segment.control[i + 1] - segment.control[i]);
  }
  return d;
}

void sort_unique(std::vector<double>& values) {
  std::sort(values.begin(), values.end());
  std::size_t kept = 0;
  for (std::size_t i = 0; i < values.size(); ++i) {
    if (kept == 0 || values[i] - values[kept - 1] > 1e-14) values[kept++] = values[i];
  }
  values.resize(kept);
}

}  // namespace

TractionLaw BoundaryLoadSpec::traction_law(double load_factor) const {
  TractionLaw law;
  switch (type) {
    case BoundaryLoadType::kVerticalPressure:
      law.normal_scale = Vec2(0.0, -load_factor * pressure);  // t = (0, -q n_y)
      break;
    case BoundaryLoadType::kFollowerPressure:
      law.normal_scale = Vec2(-load_factor * pressure, -load_factor * pressure);  // t = -p n
      break;
    case BoundaryLoadType::kTraction:
      law.fixed_traction = load_factor * traction;
      break;
  }
  return law;
}

Vec2 exact_total_force(const BezierSegment& segment, const TractionLaw& law) {
  // Integral of n |B'| dt = (Delta y, -Delta x); eq. 6.13 for the vertical pressure.
  Vec2 total = law.normal_scale.cwiseProduct(turned_clockwise(segment.end() - segment.start()));
  if (law.fixed_traction != Vec2::Zero()) total += law.fixed_traction * segment.length();
  return total;
}

namespace {

/// exact_total_force of the part [t0, t1] of a segment.
Vec2 exact_part_force(const BezierSegment& segment, double t0, double t1, const TractionLaw& law) {
  Vec2 total =
      law.normal_scale.cwiseProduct(turned_clockwise(segment.point(t1) - segment.point(t0)));
  if (law.fixed_traction != Vec2::Zero()) total += law.fixed_traction * segment.length(t0, t1);
  return total;
}

}  // namespace

const GaussRule& BoundaryLoadIntegrator::gauss_rule(int k) const {
  if (k < 1 || k > kMaxGaussPoints) throw std::invalid_argument("gauss_points not in 1..20");
  return rules_[k];
}

BoundaryLoadIntegrator::BoundaryLoadIntegrator(const Grid& grid, int shape_degree)
    : grid_(grid),
      degree_(shape_degree),
      knot_grid_(grid),
      accumulated_(static_cast<std::size_t>(grid.n_nodes()), Vec2::Zero()),
      touched_flag_(static_cast<std::size_t>(grid.n_nodes()), 0) {
  if (shape_degree < 1 || shape_degree > 3) {
    throw std::invalid_argument("BoundaryLoadIntegrator: shape_degree not in 1..3");
  }
  if (shape_degree == 2) {
    knot_grid_.cell_size = 0.5 * grid.cell_size;
    knot_grid_.n_cells_x = 2 * grid.n_cells_x;
    knot_grid_.n_cells_y = 2 * grid.n_cells_y;
  }
  for (int k = 1; k <= kMaxGaussPoints; ++k) rules_[k] = gauss_legendre(k);
  touched_.reserve(256);
  unit_.reserve(256);
  breaks_.reserve(64);
}

void BoundaryLoadIntegrator::add_node_force(int i, int j, const Vec2& force) {
  const bool on_grid = i >= 0 && j >= 0 && i < grid_.n_nodes_x() && j < grid_.n_nodes_y();
  if (!on_grid) {
    off_grid_ += force;
    return;
  }
  const int node = grid_.node_index(i, j);
  // Merge with a recent entry of the same node (consecutive points of one piece).
  for (std::size_t k = unit_.size() >= 4 ? unit_.size() - 4 : 0; k < unit_.size(); ++k) {
    if (unit_[k].node == node) {
      unit_[k].force += force;
      return;
    }
  }
  unit_.push_back({node, force});
}

void BoundaryLoadIntegrator::add_point_force(int cell_i, int cell_j, const Vec2& x,
                                             const Vec2& force) {
  if (degree_ > 1) {
    const ShapeStencil s = bspline_stencil(grid_, degree_, x);
    for (int b = 0; b < s.width; ++b) {
      for (int a = 0; a < s.width; ++a) {
        const double value = s.value[b * s.width + a];
        if (value != 0.0) add_node_force(s.base_i + a, s.base_j + b, value * force);
      }
    }
    return;
  }
  // Bilinear functions of cell (cell_i, cell_j) (thesis 3.2), used as polynomials: a point
  // that roundoff puts a hair outside the cell still gets this cell's functions.
  const Vec2 local = (x - grid_.node_position(cell_i, cell_j)) / grid_.cell_size;
  const double xi = local.x(), eta = local.y();
  add_node_force(cell_i, cell_j, (1.0 - xi) * (1.0 - eta) * force);
  add_node_force(cell_i + 1, cell_j, xi * (1.0 - eta) * force);
  add_node_force(cell_i, cell_j + 1, (1.0 - xi) * eta * force);
  add_node_force(cell_i + 1, cell_j + 1, xi * eta * force);
}

void BoundaryLoadIntegrator::flush_unit(const Vec2& exact_total, bool scale) {
  Vec2 factor(1.0, 1.0);
  if (scale) {
    // Thesis eq. 6.15, component by component.
    Vec2 sum = Vec2::Zero();
    for (const auto& entry : unit_) sum += entry.force;
    for (int c = 0; c < 2; ++c) {
      if (sum[c] != 0.0) factor[c] = exact_total[c] / sum[c];
    }
  }
  for (const auto& entry : unit_) {
    accumulated_[entry.node] += entry.force.cwiseProduct(factor);
    if (!touched_flag_[entry.node]) {
      touched_flag_[entry.node] = 1;
      touched_.push_back(entry.node);
    }
  }
  unit_.clear();
}

void BoundaryLoadIntegrator::integrate_piece_exact(const BezierSegment& segment, double t0,
                                                   double t1, int cell_i, int cell_j,
                                                   const TractionLaw& law, const GaussRule& rule) {
  const double half = 0.5 * (t1 - t0), mid = 0.5 * (t0 + t1);
  const bool has_fixed = law.fixed_traction != Vec2::Zero();
  const bool fixed_is_polynomial = segment.is_straight();
  for (int q = 0; q < rule.n_points; ++q) {
    const double t = mid + half * rule.node[q];
    const Vec2 velocity = segment.derivative(t) * half;  // dB/du on the reference interval
    Vec2 integrand = law.normal_scale.cwiseProduct(turned_clockwise(velocity));
    if (has_fixed && fixed_is_polynomial) integrand += law.fixed_traction * velocity.norm();
    add_point_force(cell_i, cell_j, segment.point(t), rule.weight[q] * integrand);
  }
  if (has_fixed && !fixed_is_polynomial) {
    // N_a(B(t)) |B'(t)| is not a polynomial on a curved piece: adaptive quadrature per node.
    const double tolerance = 1e-14 * segment.length(t0, t1) + 1e-300;
    if (degree_ > 1) {
      // The nodes of the piece's knot span (one span: the piece is cut at the knot lines).
      const ShapeStencil at_mid = bspline_stencil(grid_, degree_, segment.point(mid));
      for (int k = 0; k < at_mid.width * at_mid.width; ++k) {
        const int a = k % at_mid.width, b = k / at_mid.width;
        auto weighted_speed = [&](double t) {
          const ShapeStencil s = bspline_stencil(grid_, degree_, segment.point(t));
          const int sa = at_mid.base_i + a - s.base_i, sb = at_mid.base_j + b - s.base_j;
          const bool in = sa >= 0 && sb >= 0 && sa < s.width && sb < s.width;
          return in ? s.value[sb * s.width + sa] * segment.derivative(t).norm() : 0.0;
        };
        const double value = adaptive_gauss(weighted_speed, t0, t1, tolerance);
        add_node_force(at_mid.base_i + a, at_mid.base_j + b, value * law.fixed_traction);
      }
      return;
    }
    const Vec2 corner = grid_.node_position(cell_i, cell_j);
    const double h = grid_.cell_size;
    for (int a = 0; a < 4; ++a) {
      const int ai = a % 2, aj = a / 2;
      auto weighted_speed = [&](double t) {
        const Vec2 local = (segment.point(t) - corner) / h;
        const double nx = ai == 1 ? local.x() : 1.0 - local.x();
        const double ny = aj == 1 ? local.y() : 1.0 - local.y();
        return nx * ny * segment.derivative(t).norm();
      };
      const double value = adaptive_gauss(weighted_speed, t0, t1, tolerance);
      add_node_force(cell_i + ai, cell_j + aj, value * law.fixed_traction);
    }
  }
}

void BoundaryLoadIntegrator::add_unit(const BezierSegment& segment, double t0, double t1,
                                      const TractionLaw& law, const QuadratureOptions& options,
                                      const GaussRule& rule) {
  if (!(t1 > t0)) return;
  const bool thesis = options.mode == IntegrationMode::kThesis;
  auto cell_of = [&](const Vec2& x, int& ci, int& cj) {
    ci = grid_.cell_i(x.x());
    cj = grid_.cell_j(x.y());
  };
  // Thesis eq. 6.12 on [a, b]: (Gauss arc length) x (Gauss mean of N^T t). With fixed_cell,
  // N is the piece's cell; otherwise each Gauss point uses the cell that contains it.
  auto thesis_piece = [&](double a, double b, bool fixed_cell, int ci, int cj) {
    const double half = 0.5 * (b - a), mid = 0.5 * (a + b);
    double arc_length = 0.0;  // eq. 6.11
    for (int q = 0; q < rule.n_points; ++q) {
      arc_length += rule.weight[q] * segment.derivative(mid + half * rule.node[q]).norm();
    }
    arc_length *= half;
    for (int q = 0; q < rule.n_points; ++q) {
      const double t = mid + half * rule.node[q];
      const Vec2 normal = segment.outward_normal(t);
      const Vec2 traction = law.normal_scale.cwiseProduct(normal) + law.fixed_traction;
      const Vec2 x = segment.point(t);
      int pi = ci, pj = cj;
      if (!fixed_cell) cell_of(x, pi, pj);
      add_point_force(pi, pj, x, 0.5 * arc_length * rule.weight[q] * traction);
    }
  };
  if (options.split_at_cell_edges) {
    grid_crossing_parameters(segment, knot_grid_, t0, t1, breaks_);
    for (std::size_t p = 0; p + 1 < breaks_.size(); ++p) {
      const double a = breaks_[p], b = breaks_[p + 1];
      int ci = 0, cj = 0;
      cell_of(segment.point(0.5 * (a + b)), ci, cj);
      if (thesis) {
        thesis_piece(a, b, true, ci, cj);
      } else {
        integrate_piece_exact(segment, a, b, ci, cj, law, rule);
      }
      // With splitting, eq. 6.15 acts per piece (the thesis's element level).
      const bool scale = options.scale_eq_6_15;
      flush_unit(scale ? exact_total_force(segment.sub_segment(a, b), law) : Vec2::Zero(), scale);
    }
  } else if (thesis) {
    thesis_piece(t0, t1, false, 0, 0);
  } else {
    const double half = 0.5 * (t1 - t0), mid = 0.5 * (t0 + t1);
    for (int q = 0; q < rule.n_points; ++q) {
      const double t = mid + half * rule.node[q];
      const Vec2 velocity = segment.derivative(t) * half;
      const Vec2 integrand = law.normal_scale.cwiseProduct(turned_clockwise(velocity)) +
                             law.fixed_traction * velocity.norm();
      const Vec2 x = segment.point(t);
      int ci = 0, cj = 0;
      cell_of(x, ci, cj);
      add_point_force(ci, cj, x, rule.weight[q] * integrand);
    }
  }
  if (!unit_.empty()) {
    const bool scale = options.scale_eq_6_15;
    flush_unit(scale ? exact_total_force(segment.sub_segment(t0, t1), law) : Vec2::Zero(), scale);
  }
}

void BoundaryLoadIntegrator::add_segment(const BezierSegment& segment, double t0, double t1,
                                         const TractionLaw& law, const QuadratureOptions& options) {
  add_unit(segment, t0, t1, law, options,
           gauss_rule(gauss_points_for_degree(options.gauss_points, degree_)));
}

void BoundaryLoadIntegrator::take_forces(std::span<Vec2> out) {
  if (out.size() != accumulated_.size()) {
    throw std::invalid_argument("take_forces: output size != number of grid nodes");
  }
  std::fill(out.begin(), out.end(), Vec2::Zero());
  for (const int node : touched_) {
    out[node] = accumulated_[node];
    accumulated_[node] = Vec2::Zero();
    touched_flag_[node] = 0;
  }
  touched_.clear();
  off_grid_ = Vec2::Zero();
}

namespace {

// Moves forces[lost] to the nearest nodes with mass (scheme in surface_load.hpp).
// on_receive(node) is called for every node that receives a share.
template <class OnReceive>
bool move_lost_force(const Grid& grid, std::span<const double> node_mass, double min_node_mass,
                     std::span<Vec2> forces, int lost_node, OnReceive&& on_receive) {
  const int nx = grid.n_nodes_x(), ny = grid.n_nodes_y();
  const int li = lost_node % nx, lj = lost_node / nx;
  const Vec2 lost_force = forces[lost_node];
  const Vec2 lost_position = grid.node_position(li, lj);
  auto for_each_massive = [&](int radius, auto&& visit) {
    for (int j = std::max(0, lj - radius); j <= std::min(ny - 1, lj + radius); ++j) {
      for (int i = std::max(0, li - radius); i <= std::min(nx - 1, li + radius); ++i) {
        const int node = grid.node_index(i, j);
        if (node_mass[node] > min_node_mass) visit(node, grid.node_position(i, j));
      }
    }
  };
  const int max_radius = std::max(nx, ny);
  for (int radius = 1; radius <= max_radius; ++radius) {
    int count = 0;
    Vec2 centroid = Vec2::Zero();
    for_each_massive(radius, [&](int, const Vec2& x) {
      ++count;
      centroid += x;
    });
    if (count < 2 && radius < max_radius) continue;
    if (count == 0) return false;
    centroid /= count;
    double spread = 0.0;  // sum |r_J|^2
    for_each_massive(radius, [&](int, const Vec2& x) { spread += (x - centroid).squaredNorm(); });
    const double moment_about_centroid = cross(lost_position - centroid, lost_force);
    const double mu = spread > 0.0 ? moment_about_centroid / spread : 0.0;
    forces[lost_node] = Vec2::Zero();
    for_each_massive(radius, [&](int node, const Vec2& x) {
      const Vec2 r = x - centroid;
      forces[node] += lost_force / count + mu * Vec2(-r.y(), r.x());
      on_receive(node);
    });
    return count >= 2;
  }
  return false;
}

}  // namespace

void BoundaryLoadIntegrator::index_shadows(const std::vector<CompositeBezier>& curves) {
  turning_x_.clear();
  double x_min = std::numeric_limits<double>::infinity(), x_max = -x_min;
  for (const auto& curve : curves) {
    for (const auto& segment : curve.segments) {
      turning_x_.push_back(segment.start().x());
      turning_x_.push_back(segment.end().x());
      if (segment.degree >= 2) {
        ray_roots_.clear();
        coordinate_crossings(hodograph(segment), 0, 0.0, ray_roots_);
        for (const double t : ray_roots_) turning_x_.push_back(segment.point(t).x());
      }
      for (int k = 0; k <= segment.degree; ++k) {
        x_min = std::min(x_min, segment.control[k].x());
        x_max = std::max(x_max, segment.control[k].x());
      }
    }
  }
  sort_unique(turning_x_);
  // Bins of one grid cell in x; a segment goes into every bin its control polygon overlaps.
  shadow_bin_width_ = grid_.cell_size;
  shadow_x0_ = x_min;
  const std::size_t n_bins =
      turning_x_.empty() ? 0 : static_cast<std::size_t>((x_max - x_min) / shadow_bin_width_) + 1;
  for (auto& bin : shadow_bins_) bin.clear();
  if (shadow_bins_.size() < n_bins) shadow_bins_.resize(n_bins);
  for (std::size_t c = 0; c < curves.size(); ++c) {
    for (std::size_t j = 0; j < curves[c].segments.size(); ++j) {
      const BezierSegment& segment = curves[c].segments[j];
      double lo = segment.control[0].x(), hi = lo;
      for (int k = 1; k <= segment.degree; ++k) {
        lo = std::min(lo, segment.control[k].x());
        hi = std::max(hi, segment.control[k].x());
      }
      const auto first = static_cast<std::size_t>((lo - shadow_x0_) / shadow_bin_width_);
      const auto last =
          std::min(n_bins - 1, static_cast<std::size_t>((hi - shadow_x0_) / shadow_bin_width_));
      for (std::size_t b = first; b <= last; ++b)
        shadow_bins_[b].emplace_back(static_cast<int>(c), static_cast<int>(j));
    }
  }
}

bool BoundaryLoadIntegrator::shadowed(const std::vector<CompositeBezier>& curves,
                                      const BezierSegment& segment, double t) const {
  // A vertical ray up from B(t): shadowed when it meets the boundary above B(t).
  const Vec2 p = segment.point(t);
  const double tolerance = 1e-9 * grid_.cell_size;
  const double offset = (p.x() - shadow_x0_) / shadow_bin_width_;
  if (offset < 0.0) return false;
  const auto bin = static_cast<std::size_t>(offset);
  if (bin >= shadow_bins_.size()) return false;
  for (const auto& [c, j] : shadow_bins_[bin]) {
    const BezierSegment& other =
        curves[static_cast<std::size_t>(c)].segments[static_cast<std::size_t>(j)];
    double y_max = other.control[0].y();
    for (int k = 1; k <= other.degree; ++k) y_max = std::max(y_max, other.control[k].y());
    if (y_max <= p.y() + tolerance) continue;
    ray_roots_.clear();
    coordinate_crossings(other, 0, p.x(), ray_roots_);
    for (const double s : ray_roots_) {
      if (other.point(s).y() > p.y() + tolerance) return true;
    }
  }
  return false;
}

void BoundaryLoadIntegrator::select_parts(const std::vector<CompositeBezier>& curves,
                                          const BoundaryLoadSpec& spec,
                                          std::vector<CurvePart>& parts) {
  parts.clear();
  const bool upward_only = spec.faces != LoadedFaces::kAll;
  const bool top_only = spec.faces == LoadedFaces::kTop;
  if (top_only) index_shadows(curves);
  std::size_t c = 0, j = 0;  // the curve and segment being cut
  auto push = [&](double t0, double t1) { parts.push_back({c, j, t0, t1}); };
  // Adds a loaded part; for kTop only its sub-parts that nothing lies above (the part is cut
  // at the x of every vertex and turning point of the curves, where shadows begin and end).
  auto add_part = [&](const BezierSegment& segment, double t0, double t1) {
    if (!top_only) {
      push(t0, t1);
      return;
    }
    shadow_cuts_.clear();
    const double xa = segment.point(t0).x(), xb = segment.point(t1).x();
    const auto lo = std::upper_bound(turning_x_.begin(), turning_x_.end(), std::min(xa, xb));
    const auto hi = std::lower_bound(turning_x_.begin(), turning_x_.end(), std::max(xa, xb));
    for (auto it = lo; it < hi; ++it) {
      ray_roots_.clear();
      coordinate_crossings(segment, 0, *it, ray_roots_);
      for (const double t : ray_roots_)
        if (t > t0 && t < t1) shadow_cuts_.push_back(t);
    }
    shadow_cuts_.push_back(t0);
    shadow_cuts_.push_back(t1);
    sort_unique(shadow_cuts_);
    double run_start = -1.0, run_end = -1.0;
    for (std::size_t k = 0; k + 1 < shadow_cuts_.size(); ++k) {
      const double a = shadow_cuts_[k], b = shadow_cuts_[k + 1];
      if (shadowed(curves, segment, 0.5 * (a + b))) continue;
      if (run_end == a) {
        run_end = b;
        continue;
      }
      if (run_end > run_start) push(run_start, run_end);
      run_start = a;
      run_end = b;
    }
    if (run_end > run_start) push(run_start, run_end);
  };
  std::vector<double>& cuts = filter_breaks_;
  for (c = 0; c < curves.size(); ++c) {
    for (j = 0; j < curves[c].segments.size(); ++j) {
      const BezierSegment& segment = curves[c].segments[j];
      // A segment whose outward normal at its middle is outside the normal window has no
      // loaded part.
      if (spec.normal_window) {
        const NormalWindow& window = *spec.normal_window;
        if (segment.outward_normal(0.5).dot(window.direction) < window.min_cosine) continue;
      }
      // Loaded parts: cut at x = x_min, x = x_max and where the tangent turns (B'_x = 0).
      cuts.clear();
      if (spec.x_range) {
        coordinate_crossings(segment, 0, spec.x_range->x(), cuts);
        coordinate_crossings(segment, 0, spec.x_range->y(), cuts);
      }
      if (upward_only && segment.degree >= 2)
        coordinate_crossings(hodograph(segment), 0, 0.0, cuts);
      cuts.push_back(0.0);
      cuts.push_back(1.0);
      sort_unique(cuts);
      cuts.back() = 1.0;
      double part_start = -1.0, part_end = -1.0;
      for (std::size_t p = 0; p + 1 < cuts.size(); ++p) {
        const double mid = 0.5 * (cuts[p] + cuts[p + 1]);
        bool loaded = true;
        if (spec.x_range) {
          const double x = segment.point(mid).x();
          loaded = x >= spec.x_range->x() && x <= spec.x_range->y();
        }
        if (loaded && upward_only) loaded = segment.derivative(mid).x() < 0.0;  // n_y > 0
        if (!loaded) continue;
        if (part_end == cuts[p]) {
          part_end = cuts[p + 1];
        } else {
          if (part_end > part_start) add_part(segment, part_start, part_end);
          part_start = cuts[p];
          part_end = cuts[p + 1];
        }
      }
      if (part_end > part_start) add_part(segment, part_start, part_end);
    }
  }
}

void BoundaryLoadIntegrator::quadrature_points(const std::vector<CompositeBezier>& curves,
                                               const BoundaryLoadSpec& spec,
                                               std::vector<CurvePoint>& points) {
  points.clear();
  const GaussRule& rule =
      gauss_rule(gauss_points_for_degree(spec.quadrature.gauss_points, degree_));
  select_parts(curves, spec, parts_);
  for (const CurvePart& part : parts_) {
    const BezierSegment& segment = curves[part.curve].segments[part.segment];
    grid_crossing_parameters(segment, knot_grid_, part.t0, part.t1, breaks_);
    for (std::size_t p = 0; p + 1 < breaks_.size(); ++p) {
      const double half = 0.5 * (breaks_[p + 1] - breaks_[p]);
      const double mid = 0.5 * (breaks_[p] + breaks_[p + 1]);
      for (int q = 0; q < rule.n_points; ++q) {
        const double t = mid + half * rule.node[q];
        const Vec2 velocity = segment.derivative(t);
        const double speed = velocity.norm();
        if (!(speed > 0.0)) continue;
        points.push_back(
            {segment.point(t), turned_clockwise(velocity) / speed, rule.weight[q] * half * speed});
      }
    }
  }
}

int redistribute_lost_forces(const Grid& grid, std::span<const double> node_mass,
                             std::span<Vec2> forces, std::span<const int> nodes,
                             double min_node_mass) {
  const auto n = static_cast<std::size_t>(grid.n_nodes());
  if (node_mass.size() != n || forces.size() != n) {
    throw std::invalid_argument("redistribute_lost_forces: sizes != number of grid nodes");
  }
  int moved = 0;
  for (const int node : nodes) {
    if (node_mass[node] > min_node_mass || forces[node] == Vec2::Zero()) continue;
    if (move_lost_force(grid, node_mass, min_node_mass, forces, node, [](int) {})) ++moved;
  }
  return moved;
}

BoundaryLoadResult BoundaryLoadIntegrator::integrate(
    const std::vector<CompositeBezier>& curves, const BoundaryLoadSpec& spec, double load_factor,
    std::span<const double> node_mass, std::span<Vec2> node_force_out, bool keep_nodal_forces) {
  const auto n = static_cast<std::size_t>(grid_.n_nodes());
  if (node_force_out.size() != n || (!node_mass.empty() && node_mass.size() != n)) {
    throw std::invalid_argument("integrate: array sizes != number of grid nodes");
  }
  BoundaryLoadResult result;
  const TractionLaw law = spec.traction_law(load_factor);
  const GaussRule& rule =
      gauss_rule(gauss_points_for_degree(spec.quadrature.gauss_points, degree_));
  select_parts(curves, spec, parts_);
  for (const CurvePart& part : parts_) {
    const BezierSegment& segment = curves[part.curve].segments[part.segment];
    add_unit(segment, part.t0, part.t1, law, spec.quadrature, rule);
    result.exact_force += exact_part_force(segment, part.t0, part.t1, law);
  }
  result.off_grid_force = off_grid_;
  off_grid_ = Vec2::Zero();

  // Totals and lost load.
  for (const int node : touched_) {
    const Vec2& f = accumulated_[node];
    const Vec2 x = grid_.node_position(node % grid_.n_nodes_x(), node / grid_.n_nodes_x());
    result.total_force += f;
    result.total_moment += cross(x, f);
    if (!node_mass.empty() && node_mass[node] <= spec.min_node_mass && f != Vec2::Zero()) {
      result.lost_force += f;
      result.lost_moment += cross(x, f);
      ++result.n_lost_nodes;
      result.lost_nodes.push_back(node);
    }
  }
  std::sort(result.lost_nodes.begin(), result.lost_nodes.end());
  if (spec.redistribute_lost_load && result.n_lost_nodes > 0) {
    const std::size_t n_touched = touched_.size();
    for (std::size_t k = 0; k < n_touched; ++k) {
      const int node = touched_[k];
      if (node_mass[node] > spec.min_node_mass || accumulated_[node] == Vec2::Zero()) continue;
      move_lost_force(grid_, node_mass, spec.min_node_mass, accumulated_, node,
                      [this](int receiver) {
                        if (!touched_flag_[receiver]) {
                          touched_flag_[receiver] = 1;
                          touched_.push_back(receiver);
                        }
                      });
    }
    result.redistributed = true;
  }
  // Hand the forces over and reset the accumulator.
  std::sort(touched_.begin(), touched_.end());
  for (const int node : touched_) {
    const Vec2 f = accumulated_[node];
    if (f != Vec2::Zero()) {
      ++result.n_loaded_nodes;
      node_force_out[node] += f;
      if (keep_nodal_forces) result.nodal_forces.push_back({node, f});
    }
    accumulated_[node] = Vec2::Zero();
    touched_flag_[node] = 0;
  }
  touched_.clear();
  return result;
}

BoundaryLoadResult integrate_load(const Grid& grid, const std::vector<CompositeBezier>& curves,
                                  const BoundaryLoadSpec& spec, double load_factor,
                                  std::span<const double> node_mass, std::span<Vec2> node_force_out,
                                  bool keep_nodal_forces) {
  BoundaryLoadIntegrator integrator(grid);
  return integrator.integrate(curves, spec, load_factor, node_mass, node_force_out,
                              keep_nodal_forces);
}

std::vector<Vec2> segment_nodal_forces(const Grid& grid, const BezierSegment& segment,
                                       const TractionLaw& law, const QuadratureOptions& options) {
  BoundaryLoadIntegrator integrator(grid);
  integrator.add_segment(segment, 0.0, 1.0, law, options);
  std::vector<Vec2> forces(static_cast<std::size_t>(grid.n_nodes()), Vec2::Zero());
  integrator.take_forces(forces);
  return forces;
}

namespace {

struct ReferenceIntegrand {
  const Grid& grid;
  const BezierSegment& segment;
  const TractionLaw& law;
  // Adds weight x (nodal integrand at t) to out (2 entries per node).
  void add(double t, double weight, std::vector<double>& out) const {
    const Vec2 x = segment.point(t);
    const Vec2 velocity = segment.derivative(t);
    const Vec2 traction = law.normal_scale.cwiseProduct(turned_clockwise(velocity)) +
                          law.fixed_traction * velocity.norm();
    const double h = grid.cell_size;
    const int ci = static_cast<int>(std::floor((x.x() - grid.origin.x()) / h));
    const int cj = static_cast<int>(std::floor((x.y() - grid.origin.y()) / h));
    for (int j = std::max(0, cj - 1); j <= std::min(grid.n_nodes_y() - 1, cj + 2); ++j) {
      for (int i = std::max(0, ci - 1); i <= std::min(grid.n_nodes_x() - 1, ci + 2); ++i) {
        const Vec2 node = grid.node_position(i, j);
        const double hat = std::max(0.0, 1.0 - std::abs(x.x() - node.x()) / h) *
                           std::max(0.0, 1.0 - std::abs(x.y() - node.y()) / h);
        if (hat == 0.0) continue;
        const int k = grid.node_index(i, j);
        out[2 * k] += weight * hat * traction.x();
        out[2 * k + 1] += weight * hat * traction.y();
      }
    }
  }
};

void reference_rule(const ReferenceIntegrand& f, const GaussRule& rule, double a, double b,
                    std::vector<double>& out) {
  std::fill(out.begin(), out.end(), 0.0);
  const double half = 0.5 * (b - a), mid = 0.5 * (a + b);
  for (int q = 0; q < rule.n_points; ++q)
    f.add(mid + half * rule.node[q], half * rule.weight[q], out);
}

// True when the curve visibly changes cell inside [a, b]: two consecutive samples (ends and
// Gauss nodes) in different cells. A sample within 1e-11 h of a grid line counts as being in
// both cells beside it, so a curve running along a line, or ending on one, shows no change
// (its integrand has no kink there). Adaptive rules can converge falsely on a kink that sits
// close to a subdivision point (both estimates carry the same error), so the reference does
// not accept an interval with a kink until it is tiny.
bool changes_cell(const Grid& grid, const BezierSegment& segment, const GaussRule& rule, double a,
                  double b) {
  const double half = 0.5 * (b - a), mid = 0.5 * (a + b);
  std::array<double, 2> low_prev{}, high_prev{};
  for (int q = -1; q <= rule.n_points; ++q) {
    const double t = q < 0 ? a : (q == rule.n_points ? b : mid + half * rule.node[q]);
    const Vec2 scaled = (segment.point(t) - grid.origin) / grid.cell_size;
    std::array<double, 2> low{}, high{};  // the cells (per axis) the sample may belong to
    for (int axis = 0; axis < 2; ++axis) {
      const double u = scaled[axis], line = std::round(u);
      if (std::abs(u - line) < 1e-11) {
        low[axis] = line - 1.0;
        high[axis] = line;
      } else {
        low[axis] = high[axis] = std::floor(u);
      }
      if (q >= 0 && (low[axis] > high_prev[axis] || high[axis] < low_prev[axis])) return true;
    }
    low_prev = low;
    high_prev = high;
  }
  return false;
}

void reference_step(const ReferenceIntegrand& f, const GaussRule& rule, double a, double b,
                    const std::vector<double>& whole, double tolerance_per_length, int depth,
                    std::vector<double>& total) {
  const double mid = 0.5 * (a + b);
  std::vector<double> left(whole.size()), right(whole.size());
  reference_rule(f, rule, a, mid, left);
  reference_rule(f, rule, mid, b, right);
  double difference = 0.0;
  for (std::size_t k = 0; k < whole.size(); ++k) {
    difference = std::max(difference, std::abs(left[k] + right[k] - whole[k]));
  }
  const bool converged = depth >= 3 && difference <= tolerance_per_length * (b - a) &&
                         (b - a < 1e-9 || !changes_cell(f.grid, f.segment, rule, a, b));
  if (depth >= 60 || converged) {
    for (std::size_t k = 0; k < whole.size(); ++k) total[k] += left[k] + right[k];
    return;
  }
  reference_step(f, rule, a, mid, left, tolerance_per_length, depth + 1, total);
  reference_step(f, rule, mid, b, right, tolerance_per_length, depth + 1, total);
}

}  // namespace

std::vector<Vec2> reference_nodal_forces(const Grid& grid, const BezierSegment& segment,
                                         const TractionLaw& law, double relative_tolerance) {
  const std::size_t n = static_cast<std::size_t>(grid.n_nodes());
  const ReferenceIntegrand integrand{grid, segment, law};
  const GaussRule rule = gauss_legendre(12);
  // Integrand scale: |t| bound times the largest speed |B'| <= n max |P_i+1 - P_i|.
  double speed = 0.0;
  for (int i = 0; i < segment.degree; ++i) {
    speed = std::max(speed, segment.degree * (segment.control[i + 1] - segment.control[i]).norm());
  }
  const double scale = (law.normal_scale.cwiseAbs().maxCoeff() + law.fixed_traction.norm()) * speed;
  std::vector<double> whole(2 * n), total(2 * n, 0.0);
  reference_rule(integrand, rule, 0.0, 1.0, whole);
  reference_step(integrand, rule, 0.0, 1.0, whole, relative_tolerance * scale, 0, total);
  std::vector<Vec2> forces(n);
  for (std::size_t k = 0; k < n; ++k) forces[k] = Vec2(total[2 * k], total[2 * k + 1]);
  return forces;
}

}  // namespace pfm::boundary

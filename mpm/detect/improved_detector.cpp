// The improved detector (see detector.hpp): volume-normalised kernel field contoured at 0.5 with
// exact edge crossings, a particle guard and a narrow band.
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <utility>

#include "mpm/detect/detect_internal.hpp"

namespace pfm {

ImprovedField::ImprovedField(const ParticleCloud& cloud, const ImprovedConfig& config)
    : exponent_(static_cast<int>(config.profile)), guard_(config.guard_factor > 0.0) {
  detail::check_cloud(cloud);
  const std::size_t n = cloud.position.size();
  const double a0 = config.radius_factor * cloud.initial_spacing;
  const double rho0 = config.guard_factor * 0.5 * cloud.initial_spacing;
  position_.assign(cloud.position.begin(), cloud.position.end());
  kernel_inverse_.resize(n);
  kernel_weight_.resize(n);
  guard_inverse_.resize(n);
  particle_reach_.resize(n);
  reach_box_.resize(n);
  smallest_guard_axis_ = std::numeric_limits<double>::infinity();
  curvature_moment_ = a0 * a0 / (2.0 * exponent_ + 3.0);
  const double mass_constant = (exponent_ + 1.0) / std::numbers::pi;  // C det S, unit mass
  for (std::size_t p = 0; p < n; ++p) {
    const Mat2 f =
        cloud.deformation_gradient.empty() ? Mat2::Identity() : cloud.deformation_gradient[p];
    const double det_f = f.determinant();
    const Mat2 f_inverse = f.inverse();
    // S = F S0 with S0 = a0 I: the kernel follows the material (no clamping).
    kernel_inverse_[p] = f_inverse / a0;
    kernel_weight_[p] = cloud.volume[p] * mass_constant / (a0 * a0 * det_f);
    double largest = 0.0, smallest = 0.0;
    detail::singular_values(f, largest, smallest);
    double reach = a0 * largest;
    if (guard_) {
      guard_inverse_[p] = f_inverse / rho0;
      reach = std::max(reach, std::sqrt(2.0) * rho0 * largest);  // guard defined for q < 2
    }
    particle_reach_[p] = reach;
    reach_ = std::max(reach_, reach);
    // Axis-aligned half widths of the kernel ellipse {F a0 u : |u| < 1}.
    const Mat2 m = f * f.transpose();
    reach_box_[p] = a0 * Vec2(std::sqrt(m(0, 0)), std::sqrt(m(1, 1)));
  }
  bins_ = ParticleBins(position_, reach_ > 0.0 ? reach_ : 1.0);
  // Guards only where the particle's own phi is not comfortably above the level.
  guarded_.assign(n, 0);
  if (guard_) {
    for (std::size_t p = 0; p < n; ++p) {
      const Mat2 f =
          cloud.deformation_gradient.empty() ? Mat2::Identity() : cloud.deformation_gradient[p];
      double largest = 0.0, smallest = 0.0;
      detail::singular_values(f, largest, smallest);
      if (volume_fraction(position_[p]) <= config.level + config.guard_margin) {
        guarded_[p] = 1;
        ++n_guarded_;
        smallest_guard_axis_ = std::min(smallest_guard_axis_, rho0 * smallest);
        const Mat2 m = f * f.transpose();
        const Vec2 widths(std::sqrt(m(0, 0)), std::sqrt(m(1, 1)));
        reach_box_[p] = reach_box_[p].cwiseMax(std::sqrt(2.0) * rho0 * widths);
      } else {
        particle_reach_[p] = a0 * largest;  // no guard: the kernel alone
      }
    }
  }
}

double ImprovedField::volume_fraction(const Vec2& x) const {
  double phi = 0.0;
  bins_.for_each_near(x, [&](int p) {
    const Vec2 u = kernel_inverse_[p] * (x - position_[p]);
    const double q = u.squaredNorm();
    if (q < 1.0) {
      const double w = 1.0 - q;
      double wk = w;
      for (int k = 1; k < exponent_; ++k) wk *= w;
      phi += kernel_weight_[p] * wk;
    }
  });
  return phi;
}

double ImprovedField::operator()(const Vec2& x) const {
  double phi = 0.0, guard = 0.0;
  bins_.for_each_near(x, [&](int p) {
    const Vec2 d = x - position_[p];
    const Vec2 u = kernel_inverse_[p] * d;
    const double q = u.squaredNorm();
    if (q < 1.0) {
      const double w = 1.0 - q;
      double wk = w;
      for (int k = 1; k < exponent_; ++k) wk *= w;
      phi += kernel_weight_[p] * wk;
    }
    if (guarded_[p]) {
      // 0.5 + 0.5 (1 - |G^-1 d|^2): > 0.5 inside the guard ellipse, continuous, 0 at q = 2.
      const double qg = (guard_inverse_[p] * d).squaredNorm();
      if (qg < 2.0) guard = std::max(guard, 1.0 - 0.5 * qg);
    }
  });
  return std::max(phi, guard);
}

double brent_root(const std::function<double(double)>& g, double value_a, double value_b,
                  double tolerance_t, long* evaluations) {
  if (value_a == 0.0) return 0.0;
  if (value_b == 0.0) return 1.0;
  double a = 0.0, b = 1.0, fa = value_a, fb = value_b;
  if (std::abs(fa) < std::abs(fb)) {
    std::swap(a, b);
    std::swap(fa, fb);
  }
  // b: best estimate; a: the other end of the bracket; c: previous b; d: the one before.
  double c = a, fc = fa, d = a;
  bool bisected = true;
  for (int iteration = 0; iteration < 200; ++iteration) {
    if (fb == 0.0 || std::abs(b - a) <= tolerance_t) break;
    double s;
    if (fa != fc && fb != fc) {  // inverse quadratic interpolation through a, b, c
      s = a * fb * fc / ((fa - fb) * (fa - fc)) + b * fa * fc / ((fb - fa) * (fb - fc)) +
          c * fa * fb / ((fc - fa) * (fc - fb));
    } else {  // secant
      s = b - fb * (b - a) / (fb - fa);
    }
    // Safeguards: fall back to bisection unless s is well inside the bracket and the steps
    // shrink fast enough.
    const double quarter = 0.25 * (3.0 * a + b);
    const bool outside = !((s > std::min(quarter, b)) && (s < std::max(quarter, b)));
    const bool slow = bisected ? std::abs(s - b) >= 0.5 * std::abs(b - c)
                               : std::abs(s - b) >= 0.5 * std::abs(c - d);
    const bool tiny = bisected ? std::abs(b - c) < tolerance_t : std::abs(c - d) < tolerance_t;
    if (outside || slow || tiny) {
      s = 0.5 * (a + b);
      bisected = true;
    } else {
      bisected = false;
    }
    const double fs = g(s);
    if (evaluations != nullptr) ++*evaluations;
    d = c;
    c = b;
    fc = fb;
    if ((fa > 0.0) != (fs > 0.0)) {
      b = s;
      fb = fs;
    } else {
      a = s;
      fa = fs;
    }
    if (std::abs(fa) < std::abs(fb)) {
      std::swap(a, b);
      std::swap(fa, fb);
    }
  }
  // Return the end of the bracket on the material side's boundary estimate (b).
  return std::clamp(b, 0.0, 1.0);
}

namespace detail {

namespace {

// Curvature-bias correction: each point moves towards the void by kappa m / 2 (m: curvature
// moment), kappa from the circle through the neighbours one kernel radius away along the contour.
void correct_curvature(DetectedBoundary& boundary, double moment, double arc) {
  for (auto& contour : boundary.contours) {
    const int n = static_cast<int>(contour.points.size());
    if (n < 3) continue;
    const auto& pts = contour.points;
    std::vector<Vec2> moved = pts;
    for (int k = 0; k < n; ++k) {
      if (!contour.closed && (k == 0 || k == n - 1)) continue;
      // Walk back and forth until the chord length reaches `arc` (or the walk runs out).
      int back = k, ahead = k;
      double length = 0.0;
      for (int step = 0; step < n - 1 && length < arc; ++step) {
        const int next = contour.closed ? (back - 1 + n) % n : back - 1;
        if (next < 0) break;
        length += (pts[back] - pts[next]).norm();
        back = next;
      }
      length = 0.0;
      for (int step = 0; step < n - 1 && length < arc; ++step) {
        const int next = contour.closed ? (ahead + 1) % n : ahead + 1;
        if (next >= n) break;
        length += (pts[next] - pts[ahead]).norm();
        ahead = next;
      }
      if (back == k || ahead == k || back == ahead) continue;
      const Vec2 u = pts[k] - pts[back], v = pts[ahead] - pts[k], w = pts[ahead] - pts[back];
      const double denominator = u.norm() * v.norm() * w.norm();
      if (denominator <= 0.0) continue;
      const double kappa = 2.0 * (u.x() * v.y() - u.y() * v.x()) / denominator;  // left turn > 0
      const Vec2 tangent = w.normalized();
      const Vec2 left_normal(-tangent.y(), tangent.x());  // points into the material
      moved[k] = pts[k] - 0.5 * kappa * moment * left_normal;
    }
    contour.points = std::move(moved);
  }
}

}  // namespace

DetectedBoundary detect_improved(const ParticleCloud& cloud, const Grid& grid,
                                 const ImprovedConfig& config, DetectionTimings& timings) {
  using Clock = std::chrono::steady_clock;
  const auto field_start = Clock::now();
  const ImprovedField field(cloud, config);
  const double h = grid.cell_size;
  int refinement = config.refinement;
  if (refinement <= 0) {
    // A field cell whose diagonal fits in the smallest guard semi-axis has all four corners in
    // the guard ellipse of any particle inside it: that particle is then inside the contour.
    const double axis = field.smallest_guard_axis();
    refinement = std::isfinite(axis) ? static_cast<int>(std::ceil(h * std::sqrt(2.0) / axis)) : 4;
    refinement = std::clamp(std::max(refinement, 4), 1, std::max(1, config.max_refinement));
  }
  timings.refinement = refinement;
  NodalField geometry;
  geometry.origin = grid.origin;
  geometry.spacing = h / refinement;
  geometry.n_x = grid.n_cells_x * refinement + 1;
  geometry.n_y = grid.n_cells_y * refinement + 1;
  const std::size_t n_nodes = static_cast<std::size_t>(geometry.n_x) * geometry.n_y;
  std::vector<double> node_cache(n_nodes, std::numeric_limits<double>::quiet_NaN());
  long field_evaluations = 0;
  bool time_lazy_nodes = false;  // nodes evaluated during the contouring count as field time
  double lazy_node_seconds = 0.0;
  const auto node_value = [&](int i, int j) {
    double& slot = node_cache[static_cast<std::size_t>(j) * geometry.n_x + i];
    if (std::isnan(slot)) {
      const auto start = time_lazy_nodes ? Clock::now() : Clock::time_point{};
      slot = field(geometry.origin + Vec2(i * geometry.spacing, j * geometry.spacing));
      ++field_evaluations;
      if (time_lazy_nodes) lazy_node_seconds += seconds_since(start);
    }
    return slot;
  };
  const int n_fine_x = geometry.n_x - 1, n_fine_y = geometry.n_y - 1;
  std::vector<int> cells;
  if (!config.narrow_band) {
    for (int j = 0; j < geometry.n_y; ++j) {
      for (int i = 0; i < geometry.n_x; ++i) node_value(i, j);
    }
    cells.resize(static_cast<std::size_t>(n_fine_x) * n_fine_y);
    for (std::size_t c = 0; c < cells.size(); ++c) cells[c] = static_cast<int>(c);
  } else {
    // Coarse cells (grid cells) reached by some kernel or guard; the rest is exactly void.
    const int ncx = grid.n_cells_x, ncy = grid.n_cells_y;
    std::vector<char> reached(static_cast<std::size_t>(ncx) * ncy, 0);
    const auto positions = field.positions();
    for (std::size_t p = 0; p < positions.size(); ++p) {
      const Vec2 half = field.reach_box(p);
      const int i0 = std::max(grid.cell_i(positions[p].x() - half.x()), 0);
      const int i1 = std::min(grid.cell_i(positions[p].x() + half.x()), ncx - 1);
      const int j0 = std::max(grid.cell_j(positions[p].y() - half.y()), 0);
      const int j1 = std::min(grid.cell_j(positions[p].y() + half.y()), ncy - 1);
      for (int j = j0; j <= j1; ++j) {
        for (int i = i0; i <= i1; ++i) reached[static_cast<std::size_t>(j) * ncx + i] = 1;
      }
    }
    // Screening of the reached cells: corners and centre all well above the level (interior) or
    // all well below it with no guarded particle in the cell (exterior) are skipped.
    std::vector<char> guard_here(reached.size(), 0);
    for (std::size_t p = 0; p < positions.size(); ++p) {
      if (!field.guarded(p)) continue;
      const int i = grid.cell_i(positions[p].x()), j = grid.cell_j(positions[p].y());
      if (i >= 0 && j >= 0 && i < ncx && j < ncy)
        guard_here[static_cast<std::size_t>(j) * ncx + i] = 1;
    }
    std::vector<char> active(reached.size(), 0);
    const double interior = config.level + config.band_margin;
    const double exterior = config.level - config.band_margin;
    for (int j = 0; j < ncy; ++j) {
      for (int i = 0; i < ncx; ++i) {
        const std::size_t c = static_cast<std::size_t>(j) * ncx + i;
        if (!reached[c]) continue;
        const int fi = i * refinement, fj = j * refinement;
        const double v[4] = {node_value(fi, fj), node_value(fi + refinement, fj),
                             node_value(fi, fj + refinement),
                             node_value(fi + refinement, fj + refinement)};
        bool deep = v[0] > interior && v[1] > interior && v[2] > interior && v[3] > interior;
        bool far = !guard_here[c] && v[0] < exterior && v[1] < exterior && v[2] < exterior &&
                   v[3] < exterior;
        if (deep || far) {
          const Vec2 centre = grid.node_position(i, j) + Vec2(0.5 * h, 0.5 * h);
          const double vc = field(centre);
          ++field_evaluations;
          deep = deep && vc > interior;
          far = far && vc < exterior;
        }
        active[c] = (deep || far) ? 0 : 1;
      }
    }
    // Dilate by one coarse cell (within the reached cells) and list the fine cells.
    std::vector<char> band(active.size(), 0);
    for (int j = 0; j < ncy; ++j) {
      for (int i = 0; i < ncx; ++i) {
        const std::size_t c = static_cast<std::size_t>(j) * ncx + i;
        if (!reached[c]) continue;
        bool near = false;
        for (int dj = -1; dj <= 1 && !near; ++dj) {
          for (int di = -1; di <= 1 && !near; ++di) {
            const int ii = i + di, jj = j + dj;
            near = ii >= 0 && jj >= 0 && ii < ncx && jj < ncy &&
                   active[static_cast<std::size_t>(jj) * ncx + ii];
          }
        }
        band[c] = near ? 1 : 0;
      }
    }
    for (int fj = 0; fj < n_fine_y; ++fj) {
      for (int fi = 0; fi < n_fine_x; ++fi) {
        if (band[static_cast<std::size_t>(fj / refinement) * ncx + fi / refinement]) {
          cells.push_back(fj * n_fine_x + fi);
        }
      }
    }
  }
  timings.field = seconds_since(field_start);

  const auto contour_start = Clock::now();
  double edge_seconds = 0.0;
  long root_evaluations = 0, edge_points = 0;
  const double tolerance_t = config.root_tolerance * refinement;  // fraction of the fine edge
  const double level = config.level;
  const EdgeRefiner refine = [&](const Vec2& a, double value_a, const Vec2& b, double value_b) {
    const auto start = Clock::now();
    const Vec2 d = b - a;
    const double t = brent_root([&](double s) { return field(a + s * d) - level; }, value_a,
                                value_b, tolerance_t, &root_evaluations);
    ++edge_points;
    edge_seconds += seconds_since(start);
    return Vec2(a + t * d);
  };
  const std::function<double(const Vec2&)> exact_sample = [&](const Vec2& x) {
    ++field_evaluations;
    return field(x);
  };
  time_lazy_nodes = true;
  DetectedBoundary boundary = marching_squares_cells(geometry, node_value, cells, level,
                                                     config.saddle_rule, refine, exact_sample);
  timings.field += lazy_node_seconds;
  timings.edge_points = edge_seconds;
  timings.connection = seconds_since(contour_start) - edge_seconds - lazy_node_seconds;
  timings.processed_cells = static_cast<long>(cells.size());
  timings.edge_point_count = edge_points;
  timings.root_evaluations = root_evaluations;
  timings.field_evaluations = field_evaluations + root_evaluations;
  if (config.curvature_correction) {
    const auto start = Clock::now();
    correct_curvature(boundary, field.curvature_moment(),
                      config.radius_factor * cloud.initial_spacing);
    timings.filters = seconds_since(start);
  }
  return boundary;
}

}  // namespace detail
}  // namespace pfm

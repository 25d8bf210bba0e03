// The improved detector (see detector.hpp): volume-normalised kernel field contoured at 0.5 with
// exact edge crossings, a particle guard and a narrow band.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numbers>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include "mpm/detect/detect_internal.hpp"
#include "mpm/detect/vector_loops.hpp"

namespace pfm {

namespace {

// Grid edge w (0 left, 1 right, 2 bottom, 3 top of the box g0 .. g1): the distance of x from
// it (> 0 inside the box) and the position of x along it from the box's lower corner, m.
double wall_distance(int w, const Vec2& x, const Vec2& g0, const Vec2& g1) {
  return w == 0   ? x.x() - g0.x()
         : w == 1 ? g1.x() - x.x()
         : w == 2 ? x.y() - g0.y()
                  : g1.y() - x.y();
}

double wall_along(int w, const Vec2& x, const Vec2& g0) {
  return w < 2 ? x.y() - g0.y() : x.x() - g0.x();
}

}  // namespace

ImprovedField::ImprovedField(const ParticleCloud& cloud, const ImprovedConfig& config,
                             const Grid* walls)
    : ImprovedField((detail::check_cloud(cloud), cloud), config, DeferGuards{}, walls) {
  decide_guards({});
}

ImprovedField::ImprovedField(const ParticleCloud& cloud, const ImprovedConfig& config, DeferGuards,
                             const Grid* walls, const CloudBounds* bounds,
                             const WallContacts* contacts)
    : exponent_(static_cast<int>(config.profile)),
      guard_(config.guard_factor > 0.0),
      level_(config.level),
      guard_margin_(config.guard_margin) {
  const std::size_t n = cloud.position.size();
  const double a0 = config.radius_factor * cloud.initial_spacing;
  guard_radius_ = config.guard_factor * 0.5 * cloud.initial_spacing;
  guard_scale_ = guard_ ? a0 / guard_radius_ : 0.0;
  position_.assign(cloud.position.begin(), cloud.position.end());
  guarded_.assign(n, 0);
  particle_reach_.resize(n);
  kernel_reach_.resize(n);
  reach_box_.resize(n);
  smallest_stretch_.resize(n);
  smallest_guard_axis_ = std::numeric_limits<double>::infinity();
  curvature_moment_ = a0 * a0 / (2.0 * exponent_ + 3.0);
  const double mass_constant = (exponent_ + 1.0) / std::numbers::pi;  // C det S, unit mass
  const bool deformed = !cloud.deformation_gradient.empty();
  const double guard_reach = std::sqrt(2.0) * guard_radius_;  // guard defined for q_g < 2
  const double unit_reach = reference_reach(config, cloud.initial_spacing);
  // Pass 1, by particle: reaches (for the bins, the mirror images and the narrow band).
  for (std::size_t p = 0; p < n; ++p) {
    if (!deformed) {
      smallest_stretch_[p] = 1.0;
      kernel_reach_[p] = a0;
      particle_reach_[p] = unit_reach;
      reach_box_[p] = Vec2::Constant(particle_reach_[p]);
      reach_ = std::max(reach_, particle_reach_[p]);
      continue;
    }
    const Mat2& f = cloud.deformation_gradient[p];
    double largest = 0.0, smallest = 0.0;
    detail::singular_values(f, largest, smallest);
    smallest_stretch_[p] = smallest;
    // Axis-aligned half widths of the kernel ellipse {F a0 u : |u| < 1} and of the guard's
    // support {F rho0 u : |u|^2 < 2} (counted whether the guard becomes active or not).
    const Vec2 widths(std::sqrt(f(0, 0) * f(0, 0) + f(0, 1) * f(0, 1)),
                      std::sqrt(f(1, 0) * f(1, 0) + f(1, 1) * f(1, 1)));
    kernel_reach_[p] = a0 * largest;
    double reach = kernel_reach_[p];
    reach_box_[p] = a0 * widths;
    if (guard_) {
      reach = std::max(reach, guard_reach * largest);
      reach_box_[p] = reach_box_[p].cwiseMax(guard_reach * widths);
    }
    particle_reach_[p] = reach;
    reach_ = std::max(reach_, reach);
  }
  // Mirror images across the grid edges that no particle lies beyond (walls): the reflection
  // R (x - e) + e of the position and R F R of the deformation, R = diag(-1, 1) or diag(1, -1);
  // near a corner across both edges too. Images are never guarded.
  struct Image {
    std::size_t particle;
    bool in_x, in_y;
    double ex, ey;  ///< the mirror lines x = ex, y = ey, m
  };
  std::vector<Image> images;
  std::vector<Vec2> all_positions = position_;
  if (walls != nullptr && n > 0) {
    const Vec2 g0 = walls->origin, g1 = walls->upper_corner();
    const double spacing = cloud.initial_spacing;
    WallContacts own;
    if (contacts == nullptr) {
      Vec2 lo = position_[0], hi = position_[0];
      for (const Vec2& x : position_) {
        lo = lo.cwiseMin(x);
        hi = hi.cwiseMax(x);
      }
      own = find_wall_contacts(position_, lo, hi, *walls, spacing);
      contacts = &own;
    }
    const bool* wall = contacts->wall;
    const std::vector<char>* touched = contacts->touched;
    const auto distance_to = [&](int w, const Vec2& x) { return wall_distance(w, x, g0, g1); };
    const auto along = [&](int w, const Vec2& x) { return wall_along(w, x, g0); };
    const auto mirrored = [&](int w, const Vec2& x, double half_across, double half_along) {
      if (!wall[w] || distance_to(w, x) >= half_across) return false;
      const auto& bins = touched[w];
      const double a = along(w, x);
      const long b0 = std::max(0L, static_cast<long>(std::floor((a - half_along) / spacing)));
      const long b1 = std::min(static_cast<long>(bins.size()) - 1,
                               static_cast<long>(std::floor((a + half_along) / spacing)));
      for (long b = b0; b <= b1; ++b) {
        if (bins[static_cast<std::size_t>(b)]) return true;
      }
      return false;
    };
    for (std::size_t p = 0; p < n; ++p) {
      const Vec2& x = position_[p];
      const double half_x = std::max(reach_box_[p].x(), particle_reach_[p]);
      const double half_y = std::max(reach_box_[p].y(), particle_reach_[p]);
      int side_x = -1, side_y = -1;  // which wall (0 low, 1 high) the particle is mirrored across
      if (mirrored(0, x, half_x, half_y)) {
        side_x = 0;
      } else if (mirrored(1, x, half_x, half_y)) {
        side_x = 1;
      }
      if (mirrored(2, x, half_y, half_x)) {
        side_y = 0;
      } else if (mirrored(3, x, half_y, half_x)) {
        side_y = 1;
      }
      if (side_x < 0 && side_y < 0) continue;
      const double ex = side_x == 1 ? g1.x() : g0.x(), ey = side_y == 1 ? g1.y() : g0.y();
      const std::pair<bool, bool> kinds[3] = {{true, false}, {false, true}, {true, true}};
      for (const auto& [in_x, in_y] : kinds) {
        if ((in_x && side_x < 0) || (in_y && side_y < 0)) continue;
        images.push_back({p, in_x, in_y, ex, ey});
        all_positions.emplace_back(in_x ? 2.0 * ex - x.x() : x.x(),
                                   in_y ? 2.0 * ey - x.y() : x.y());
      }
    }
  }
  // Bins of the largest reach / kBinRings, searched kBinRings rings out.
  rings_ = kBinRings;
  bins_ = ParticleBins(all_positions, reach_ > 0.0 ? reach_ / rings_ : 1.0);
  // Pass 2, in bin order (the cloud's arrays are read in a few streams): the slots.
  struct Slot {
    double x, y, k00, k01, k10, k11, weight, half_x, half_y;
  };
  const auto kernel_of = [&](std::size_t p) {
    Slot slot{position_[p].x(),
              position_[p].y(),
              1.0 / a0,
              0.0,
              0.0,
              1.0 / a0,
              cloud.volume[p] * mass_constant / (a0 * a0),
              a0,
              a0};
    if (deformed) {
      const Mat2& f = cloud.deformation_gradient[p];
      const double det_f = f.determinant();
      // S = F S0 with S0 = a0 I: the kernel follows the material (no clamping); S^-1 = F^-1 / a0.
      const double inverse_scale = 1.0 / (det_f * a0);
      slot.k00 = f(1, 1) * inverse_scale;
      slot.k01 = -f(0, 1) * inverse_scale;
      slot.k10 = -f(1, 0) * inverse_scale;
      slot.k11 = f(0, 0) * inverse_scale;
      slot.weight /= det_f;
      // Half widths of the box around the ellipse {a0 F u : |u| < 1}: a0 |row of F|.
      slot.half_x = a0 * std::sqrt(f(0, 0) * f(0, 0) + f(0, 1) * f(0, 1));
      slot.half_y = a0 * std::sqrt(f(1, 0) * f(1, 0) + f(1, 1) * f(1, 1));
    }
    return slot;
  };
  slot_.assign_zeros(all_positions.size());
  double largest_weight = 0.0;
  for (std::size_t k = 0; k < slot_.size(); ++k) {
    const std::size_t q = static_cast<std::size_t>(bins_.particle_at(static_cast<int>(k)));
    Slot m = kernel_of(q < n ? q : images[q - n].particle);
    if (q >= n) {
      const Image& image = images[q - n];
      if (image.in_x) {
        m.x = 2.0 * image.ex - m.x;
        m.k01 = -m.k01;
        m.k10 = -m.k10;
      }
      if (image.in_y) {
        m.y = 2.0 * image.ey - m.y;
        m.k01 = -m.k01;
        m.k10 = -m.k10;
      }
    }
    slot_.x[k] = m.x;
    slot_.y[k] = m.y;
    slot_.k00[k] = m.k00;
    slot_.k01[k] = m.k01;
    slot_.k10[k] = m.k10;
    slot_.k11[k] = m.k11;
    slot_.weight[k] = m.weight;
    slot_.half_x[k] = m.half_x;
    slot_.half_y[k] = m.half_y;
    largest_weight = std::max(largest_weight, m.weight);
  }
  // The fixed-point unit (vector_loops.hpp): a term of the largest weight stays below 2^45 units,
  // and the weights of every slot together below 2^63, so that no sum overflows. The narrow band
  // takes the bounds of the whole cloud, so that its unit is the full field's.
  double bound = largest_weight;
  double slots = static_cast<double>(slot_.size());
  if (bounds != nullptr) {
    if (!(largest_weight <= 2.0 * bounds->weight_bound) || !(slot_.size() <= bounds->slot_bound)) {
      char message[200];
      std::snprintf(message, sizeof message,
                    "ImprovedField: a kernel weight (%.17g) exceeds twice the cloud's bound "
                    "(%.17g), or its %zu slots the cloud's %zu",
                    largest_weight, bounds->weight_bound, slot_.size(), bounds->slot_bound);
      throw std::logic_error(message);
    }
    bound = bounds->weight_bound;
    slots = static_cast<double>(bounds->slot_bound);
  }
  bound = bound > 0.0 ? bound : 1.0;
  int exponent_of_bound = 0, exponent_of_total = 0;
  std::frexp(bound, &exponent_of_bound);  // bound < 2^exponent_of_bound
  std::frexp(bound * std::max(slots, 1.0), &exponent_of_total);
  fixed_point_bits_ = std::min(44 - exponent_of_bound, 62 - exponent_of_total);
  fixed_point_unit_ = std::ldexp(1.0, -fixed_point_bits_);
  // A power of two: each product is std::ldexp(weight, bits), correctly rounded alike.
  const double scale = std::ldexp(1.0, fixed_point_bits_);
  for (std::size_t k = 0; k < slot_.size(); ++k) slot_.weight[k] *= scale;
}

double ImprovedField::weight_bound(const ImprovedConfig& config, double initial_spacing,
                                   double largest_volume, double smallest_det) {
  const double a0 = config.radius_factor * initial_spacing;
  const double mass_constant = (static_cast<int>(config.profile) + 1.0) / std::numbers::pi;
  return largest_volume * mass_constant / (a0 * a0) / smallest_det;
}

void ImprovedField::KernelArrays::assign_zeros(std::size_t n) {
  n_ = n;
  for (std::vector<double>* v : columns()) v->assign(n + detail::kKernelPadding, 0.0);
}

void ImprovedField::KernelArrays::gather(const KernelArrays& from, std::span<const int> slots) {
  n_ = slots.size();
  const auto to = columns();
  const auto source = from.columns();
  half_x.clear();
  half_y.clear();
  for (std::size_t c = 0; c < kSummedColumns; ++c) {
    std::vector<double>& column = *to[c];
    const double* values = source[c]->data();
    column.resize(n_ + detail::kKernelPadding);
    for (std::size_t k = 0; k < n_; ++k) column[k] = values[slots[k]];
    std::fill(column.begin() + static_cast<long>(n_), column.end(), 0.0);
  }
}

double ImprovedField::reference_reach(const ImprovedConfig& config, double initial_spacing) {
  const double a0 = config.radius_factor * initial_spacing;
  if (!(config.guard_factor > 0.0)) return a0;
  // The guard is defined where q_g < 2: out to sqrt 2 times its radius.
  return std::max(a0, std::sqrt(2.0) * (config.guard_factor * 0.5 * initial_spacing));
}

ImprovedField::WallContacts ImprovedField::find_wall_contacts(std::span<const Vec2> positions,
                                                              const Vec2& lo, const Vec2& hi,
                                                              const Grid& walls, double spacing) {
  // Wall w: 0 left, 1 right, 2 bottom, 3 top. Where the body rests on a wall: a particle closer
  // to it than one initial spacing "touches" it; the touched stretches of the wall are kept in
  // bins of one spacing along it, and a particle is mirrored across the wall only if the wall is
  // touched within its reach along the wall (a body near a wall but clear of it keeps its own
  // boundary there).
  WallContacts c;
  const Vec2 g0 = walls.origin, g1 = walls.upper_corner();
  c.wall[0] = lo.x() >= g0.x();
  c.wall[1] = hi.x() <= g1.x();
  c.wall[2] = lo.y() >= g0.y();
  c.wall[3] = hi.y() <= g1.y();
  const double wall_length[2] = {g1.y() - g0.y(), g1.x() - g0.x()};
  for (int w = 0; w < 4; ++w) {
    if (!c.wall[w]) continue;
    auto& bins = c.touched[w];
    bins.assign(static_cast<std::size_t>(wall_length[w / 2] / spacing) + 2, 0);
    for (const Vec2& x : positions) {
      if (wall_distance(w, x, g0, g1) >= spacing) continue;
      const double t = std::clamp(wall_along(w, x, g0) / spacing, 0.0, bins.size() - 1.0);
      bins[static_cast<std::size_t>(t)] = 1;
    }
  }
  return c;
}

void ImprovedField::decide_guards(std::span<const char> candidate) {
  if (!guard_) return;
  const std::size_t n = position_.size();
  // Guards only where the particle's own phi is not comfortably above the level; phi is
  // evaluated before any guard is switched on.
  std::vector<std::size_t> newly;
  for (std::size_t p = 0; p < n; ++p) {
    if (!candidate.empty() && !candidate[p]) continue;
    if (volume_fraction(position_[p]) <= level_ + guard_margin_) newly.push_back(p);
  }
  for (const std::size_t p : newly) switch_guard_on(p);
  // Particles without a guard reach as far as their kernel.
  for (std::size_t p = 0; p < n; ++p) {
    if (!guarded_[p]) particle_reach_[p] = kernel_reach_[p];
  }
}

void ImprovedField::add_guards(std::span<const std::size_t> particles) {
  if (!guard_) return;
  for (const std::size_t p : particles) {
    if (guarded_[p]) continue;
    switch_guard_on(p);
    particle_reach_[p] = kernel_reach_[p] * std::max(1.0, std::sqrt(2.0) / guard_scale_);
  }
}

void ImprovedField::switch_guard_on(std::size_t p) {
  guarded_[p] = 1;
  ++n_guarded_;
  smallest_guard_axis_ = std::min(smallest_guard_axis_, guard_radius_ * smallest_stretch_[p]);
  const auto k = static_cast<std::size_t>(bins_.slot_of(static_cast<int>(p)));
  slot_.guarded[k] = 1.0;
  // The guard's support |K d|^2 < 2 / scale^2 is the kernel ellipse scaled by sqrt(2) / scale.
  const double guard_box = std::sqrt(2.0) / guard_scale_;
  if (guard_box > 1.0) {
    slot_.half_x[k] *= guard_box;
    slot_.half_y[k] *= guard_box;
  }
}

double ImprovedField::sum_ranges(const KernelArrays& kernels, const int* begin, const int* end,
                                 int n_ranges, const Vec2& x, bool guard) const {
  const detail::KernelColumns columns{kernels.x.data(),     kernels.y.data(),   kernels.k00.data(),
                                      kernels.k01.data(),   kernels.k10.data(), kernels.k11.data(),
                                      kernels.weight.data()};
  const double px = x.x(), py = x.y();
  const std::uint64_t units = detail::kernel_sum(exponent_, columns, begin, end, n_ranges, px, py);
  const double phi = static_cast<double>(units) * fixed_point_unit_;
  if (!guard || n_guarded_ == 0) return phi;
  // The guards (few): 0.5 + 0.5 (1 - |G^-1 d|^2), > 0.5 inside the guard ellipse, continuous,
  // 0 at q = 2; G = F rho0 = S rho0 / a0, so |G^-1 d|^2 = (a0 / rho0)^2 q. A maximum, so in any
  // order.
  const double scale_squared = guard_scale_ * guard_scale_;
  double best = 0.0;
  for (int r = 0; r < n_ranges; ++r) {
    for (int k = begin[r]; k < end[r]; ++k) {
      const auto s = static_cast<std::size_t>(k);
      if (kernels.guarded[s] == 0.0) continue;
      const double dx = px - kernels.x[s], dy = py - kernels.y[s];
      const double ux = kernels.k00[s] * dx + kernels.k01[s] * dy;
      const double uy = kernels.k10[s] * dx + kernels.k11[s] * dy;
      const double qg = scale_squared * (ux * ux + uy * uy);
      if (qg < 2.0) best = std::max(best, 1.0 - 0.5 * qg);
    }
  }
  return std::max(phi, best);
}

double ImprovedField::sum_at(const Vec2& x, bool guard) const {
  int begin[2 * kBinRings + 1], end[2 * kBinRings + 1];
  const int rows = bins_.slot_rows_near(x, rings_, begin, end);
  return sum_ranges(slot_, begin, end, rows, x, guard);
}

double ImprovedField::volume_fraction(const Vec2& x) const {
  return sum_at(x, false);
}

double ImprovedField::operator()(const Vec2& x) const {
  return sum_at(x, true);
}

double ImprovedField::operator()(const Vec2& x, const KernelArrays& slots) const {
  const int begin = 0, end = static_cast<int>(slots.size());
  return sum_ranges(slots, &begin, &end, 1, x, true);
}

void ImprovedField::slots_reaching(const Vec2& lo, const Vec2& hi, KernelArrays& out) const {
  // The bins within reach of the box (a superset), then each slot's own support box, widened by
  // a hair so that rounding at a kernel's rim never drops a nonzero term.
  const double hair = 1e-9 * reach_;
  thread_local std::vector<int> found;
  found.clear();
  bins_.for_each_slot_in_box(lo - Vec2::Constant(reach_), hi + Vec2::Constant(reach_), [&](int k) {
    const auto s = static_cast<std::size_t>(k);
    const double half_x = slot_.half_x[s] + hair, half_y = slot_.half_y[s] + hair;
    if (slot_.x[s] + half_x >= lo.x() && slot_.x[s] - half_x <= hi.x() &&
        slot_.y[s] + half_y >= lo.y() && slot_.y[s] - half_y <= hi.y()) {
      found.push_back(k);
    }
  });
  out.gather(slot_, found);
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
      // An interpolation step shorter than half the tolerance would land on b's side again
      // when the root lies closer to b than that (a field flat at its resolution there keeps
      // it so), and the bracket would then close by bisection alone: step half the tolerance
      // towards a instead (Brent's minimum step), which crosses such a root.
      if (std::abs(s - b) < 0.5 * tolerance_t) s = b + (a > b ? 0.5 : -0.5) * tolerance_t;
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
        offset_(static_cast<std::size_t>(n_coarse_x + 1) * (n_coarse_y + 1), -1) {}
  T& at(int i, int j) {
    const std::size_t block = static_cast<std::size_t>(j / r_) * n_x_ + i / r_;
    long& offset = offset_[block];
    if (offset < 0) {
      offset = static_cast<long>(pool_.size());
      pool_.resize(pool_.size() + static_cast<std::size_t>(r_) * r_, fill_);
    }
    return pool_[offset + static_cast<long>(j % r_) * r_ + i % r_];
  }
  /// The value at (i, j), or nullptr where its block is not allocated yet.
  const T* find(int i, int j) const {
    const long offset = offset_[static_cast<std::size_t>(j / r_) * n_x_ + i / r_];
    return offset < 0 ? nullptr : &pool_[offset + static_cast<long>(j % r_) * r_ + i % r_];
  }

 private:
  int n_x_, r_;
  T fill_;
  std::vector<long> offset_;
  std::vector<T> pool_;
};

namespace {

// What one sweep over every particle of the cloud tells (survey_cloud()).
struct CloudSurvey {
  Vec2 lo = Vec2::Zero(), hi = Vec2::Zero();  ///< bounding box of the positions, m
  double largest_stretch = 1.0;               ///< largest singular value of any F (1 without F)
  double largest_volume = 0.0;                ///< m^2
  double smallest_det = 1.0;                  ///< smallest det F (1 without F)
  std::vector<double> cell_volume;            ///< particle volume per grid cell, m^2 (narrow band)
  std::vector<int> cell;                      ///< grid cell of each particle, -1 outside
  /// Runs of consecutive particles in one cell (the usual order: particles are made cell by
  /// cell and move slowly): run r holds particles run_start[r] .. run_start[r + 1] - 1, in cell
  /// run_cell[r]; run_start ends with the number of particles (narrow band).
  std::vector<std::uint32_t> run_start;
  std::vector<int> run_cell;
};

// The one pass over every particle the improved detector makes: checks each particle (with the
// messages of check_particle()), and gathers the box, the largest stretch and, for the narrow
// band, the cell of each particle and the volume in each cell (sweep_cloud(), vectorised).
CloudSurvey survey_cloud(const ParticleCloud& cloud, const Grid& grid, bool cells) {
  CloudSurvey survey;
  const std::size_t n = cloud.position.size();
  if (n == 0) return survey;
  const double* volume = cloud.volume.data();
  const int n_x = grid.n_cells_x, n_y = grid.n_cells_y;
  if (cells) survey.cell.resize(n);
  int* cell = cells ? survey.cell.data() : nullptr;
  const CloudTotals totals = sweep_cloud(
      cloud.position.data()->data(), volume,
      cloud.deformation_gradient.empty() ? nullptr : cloud.deformation_gradient.data()->data(), n,
      {grid.origin.x(), grid.origin.y(), 1.0 / grid.cell_size, n_x, n_y}, cell);
  if (!totals.valid) {
    for (std::size_t p = 0; p < n; ++p) check_particle(cloud, p);
  }
  survey.lo = Vec2(totals.lo_x, totals.lo_y);
  survey.hi = Vec2(totals.hi_x, totals.hi_y);
  survey.largest_stretch = std::sqrt(totals.largest_squared);
  survey.largest_volume = totals.largest_volume;
  survey.smallest_det = totals.smallest_det;
  if (cells) {
    survey.cell_volume.assign(static_cast<std::size_t>(n_x) * n_y, 0.0);
    // Runs of particles in one cell (the usual order) add up in a register.
    double* cell_volume = survey.cell_volume.data();
    int run_cell = cell[0];
    double run_volume = 0.0;
    survey.run_start.push_back(0);
    survey.run_cell.push_back(run_cell);
    for (std::size_t p = 0; p < n; ++p) {
      if (cell[p] != run_cell) {
        if (run_cell >= 0) cell_volume[run_cell] += run_volume;
        run_cell = cell[p];
        run_volume = 0.0;
        survey.run_start.push_back(static_cast<std::uint32_t>(p));
        survey.run_cell.push_back(run_cell);
      }
      run_volume += volume[p];
    }
    if (run_cell >= 0) cell_volume[run_cell] += run_volume;
    survey.run_start.push_back(static_cast<std::uint32_t>(n));
  }
  return survey;
}

// `line(in, out, n, stride)` along every row of the n_x x n_y cells, then along every column.
template <class Line>
std::vector<char> rows_then_columns(const std::vector<char>& in, int n_x, int n_y, Line line) {
  std::vector<char> rows(in.size(), 0), out(in.size(), 0);
  for (int j = 0; j < n_y; ++j) {
    const std::size_t first = static_cast<std::size_t>(j) * n_x;
    line(in.data() + first, rows.data() + first, n_x, 1);
  }
  for (int i = 0; i < n_x; ++i) line(rows.data() + i, out.data() + i, n_y, n_x);
  return out;
}

// Cells whose every neighbour within `rings` (Chebyshev) is set in `in`; outside the grid counts
// as unset.
std::vector<char> erode(const std::vector<char>& in, int n_x, int n_y, int rings) {
  return rows_then_columns(in, n_x, n_y, [rings](const char* a, char* b, int n, int stride) {
    int run = 0;  // set cells ending at k: when >= 2 rings + 1, the cell k - rings is kept
    for (int k = 0; k < n; ++k) {
      run = a[static_cast<std::size_t>(k) * stride] ? run + 1 : 0;
      if (k >= 2 * rings) b[static_cast<std::size_t>(k - rings) * stride] = run > 2 * rings;
    }
  });
}

// Cells with a set cell within `rings` (Chebyshev) in `in`.
std::vector<char> dilate(const std::vector<char>& in, int n_x, int n_y, int rings) {
  return rows_then_columns(in, n_x, n_y, [rings](const char* a, char* b, int n, int stride) {
    int last = -1000000000;  // last set cell at or before k
    for (int k = 0; k < n + rings; ++k) {
      if (k < n && a[static_cast<std::size_t>(k) * stride]) last = k;
      const int target = k - rings;  // covered when a set cell lies within rings of it
      if (target >= 0 && last >= target - rings) b[static_cast<std::size_t>(target) * stride] = 1;
    }
  });
}

}  // namespace

DetectedBoundary detect_improved(const ParticleCloud& cloud, const Grid& grid,
                                 const ImprovedConfig& config, DetectionTimings& timings) {
  using Clock = std::chrono::steady_clock;
  const double h = grid.cell_size;
  const int ncx = grid.n_cells_x, ncy = grid.n_cells_y;

  // 0. One sweep over the cloud. The fixed-point unit of the kernel sums follows from the whole
  //    cloud's largest weight, so that a field built on part of the particles gives bitwise the
  //    sums of one built on all of them (the sums are of integers: any order gives the same).
  auto& parts = timings.field_parts;
  auto part_start = Clock::now();
  // Adds the time since the last call (or the start) to `part`.
  const auto lap = [&](double& part) {
    part += seconds_since(part_start);
    part_start = Clock::now();
  };
  const CloudSurvey survey = survey_cloud(cloud, grid, config.narrow_band);
  lap(parts.survey);
  const double a0 = config.radius_factor * cloud.initial_spacing;
  const double kernel_reach = a0 * survey.largest_stretch;
  const double particle_reach =
      ImprovedField::reference_reach(config, cloud.initial_spacing) * survey.largest_stretch;
  const ImprovedField::CloudBounds bounds{
      ImprovedField::weight_bound(config, cloud.initial_spacing, survey.largest_volume,
                                  survey.smallest_det),
      4 * cloud.position.size()};

  //    Narrow band: a cell whose volume fraction is at least solid_fraction, with every cell
  //    within a kernel reach of it too, is interior without any field evaluation. The field
  //    opens a gap where the material leaves one of about half a kernel radius (tested: 0.3 h at
  //    5 points per cell, a0 = 0.6 h); such a gap empties one of the two cells it may straddle
  //    by a quarter of a0 / h or more, so the cells must be fuller than 1 - 0.15 a0 / h. Where
  //    the volume alone cannot tell, the field screening below decides. Only the particles
  //    within reach of the cells that are not interior enter the field.
  std::vector<char> interior_by_volume;
  ImprovedField::WallContacts contacts;
  std::vector<Vec2> sub_position;
  std::vector<double> sub_volume;
  std::vector<Mat2> sub_deformation;
  ParticleCloud band_cloud = cloud;
  // A kernel reaching across the whole grid (a huge stretch or radius) leaves nothing to screen.
  const double widest = std::max(ncx, ncy);
  const bool screened =
      config.narrow_band && !cloud.position.empty() && particle_reach / h < widest;
  if (screened) {
    const double solid_fraction = 1.0 - 0.15 * a0 / h;
    const int kernel_rings = std::max(1, static_cast<int>(std::ceil(kernel_reach / h)));
    const int particle_rings = std::max(1, static_cast<int>(std::ceil(particle_reach / h)));
    // Where the body rests on a grid edge the field mirrors the particles across it: beyond such
    // a wall the cells are the mirror images of those inside (for the erosion, and for the
    // dilation, since a particle whose image reaches an open cell reaches that cell's image).
    // Elsewhere the outside is void. The padding holds both operations' reach; the erosion's
    // artefacts at its outer rim stay more than particle_rings away from the grid.
    // (Which edges are walls follows from the box; where they are touched is found below.)
    if (config.mirror_grid_edges) {
      contacts =
          ImprovedField::find_wall_contacts({}, survey.lo, survey.hi, grid, cloud.initial_spacing);
    }
    const bool mirror_x[2] = {contacts.wall[0], contacts.wall[1]};
    const bool mirror_y[2] = {contacts.wall[2], contacts.wall[3]};
    const int pad = kernel_rings + particle_rings;
    const int px = ncx + 2 * pad, py = ncy + 2 * pad;
    // Index of the grid cell that padded cell (a, b) images, or -1 for the void.
    const auto source = [&](int a, int b) {
      int i = a - pad, j = b - pad;
      if (i < 0 || i >= ncx) {
        if (!mirror_x[i < 0 ? 0 : 1]) return -1;
        i = i < 0 ? -1 - i : 2 * ncx - 1 - i;
        if (i < 0 || i >= ncx) return -1;
      }
      if (j < 0 || j >= ncy) {
        if (!mirror_y[j < 0 ? 0 : 1]) return -1;
        j = j < 0 ? -1 - j : 2 * ncy - 1 - j;
        if (j < 0 || j >= ncy) return -1;
      }
      return j * ncx + i;
    };
    std::vector<char> padded_solid(static_cast<std::size_t>(px) * py, 0);
    for (int b = 0; b < py; ++b) {
      for (int a = 0; a < px; ++a) {
        const int c = source(a, b);
        padded_solid[static_cast<std::size_t>(b) * px + a] =
            c >= 0 && survey.cell_volume[static_cast<std::size_t>(c)] >= solid_fraction * h * h;
      }
    }
    const std::vector<char> padded_interior = erode(padded_solid, px, py, kernel_rings);
    std::vector<char> padded_open(padded_interior.size());
    for (std::size_t c = 0; c < padded_open.size(); ++c) padded_open[c] = !padded_interior[c];
    const std::vector<char> padded_needed = dilate(padded_open, px, py, particle_rings);
    interior_by_volume.assign(static_cast<std::size_t>(ncx) * ncy, 0);
    std::vector<char> needed(interior_by_volume.size());
    for (int j = 0; j < ncy; ++j) {
      for (int i = 0; i < ncx; ++i) {
        const std::size_t inside = static_cast<std::size_t>(j) * ncx + i;
        const std::size_t padded = static_cast<std::size_t>(j + pad) * px + (i + pad);
        interior_by_volume[inside] = padded_interior[padded];
        needed[inside] = padded_needed[padded];
      }
    }
    const bool deformed = !cloud.deformation_gradient.empty();
    // Selected indices first, then the copies. One sweep: code[c + 1] of the particle's cell c
    // (c = -1 outside the grid) has bit 0 set where the particle enters the field, bit 1 where
    // it may touch a grid edge (in a cell along the edges or outside the grid: closer to the
    // edge than one initial spacing <= h; a larger spacing takes every particle).
    const std::size_t n = cloud.position.size();
    const bool every_particle_may_touch = cloud.initial_spacing > h;
    std::vector<char> code(needed.size() + 1, 3);
    for (int j = 0; j < ncy; ++j) {
      for (int i = 0; i < ncx; ++i) {
        const std::size_t c = static_cast<std::size_t>(j) * ncx + i;
        const bool edge =
            every_particle_may_touch || i == 0 || j == 0 || i == ncx - 1 || j == ncy - 1;
        code[c + 1] = static_cast<char>((needed[c] ? 1 : 0) | (edge ? 2 : 0));
      }
    }
    std::vector<std::uint32_t> selected(n);
    std::vector<Vec2> touching;
    std::size_t m = 0;
    for (std::size_t r = 0; r + 1 < survey.run_start.size(); ++r) {
      const char k = code[static_cast<std::size_t>(survey.run_cell[r] + 1)];
      const std::uint32_t first = survey.run_start[r], end = survey.run_start[r + 1];
      if (k & 1) {
        for (std::uint32_t p = first; p < end; ++p) selected[m++] = p;
      }
      if (k & 2) {
        for (std::uint32_t p = first; p < end; ++p) touching.push_back(cloud.position[p]);
      }
    }
    if (config.mirror_grid_edges) {
      contacts = ImprovedField::find_wall_contacts(touching, survey.lo, survey.hi, grid,
                                                   cloud.initial_spacing);
    }
    sub_position.resize(m);
    sub_volume.resize(m);
    if (deformed) sub_deformation.resize(m);
    for (std::size_t k = 0; k < m; ++k) {
      const std::size_t p = selected[k];
      sub_position[k] = cloud.position[p];
      sub_volume[k] = cloud.volume[p];
      if (deformed) sub_deformation[k] = cloud.deformation_gradient[p];
    }
    band_cloud.position = sub_position;
    band_cloud.volume = sub_volume;
    band_cloud.deformation_gradient = sub_deformation;
  }
  lap(parts.band);
  // The wall contacts found above are those of the whole cloud, which the band holds a part of.
  ImprovedField field(band_cloud, config, ImprovedField::DeferGuards{},
                      config.mirror_grid_edges ? &grid : nullptr, &bounds,
                      screened && config.mirror_grid_edges ? &contacts : nullptr);
  timings.field_particles = static_cast<long>(band_cloud.position.size());
  lap(parts.setup);
  const double level = config.level;
  long field_evaluations = 0;
  const auto positions = field.positions();
  const std::size_t n_particles = positions.size();

  // 1. Coarse screening on the grid cells (narrow band only), with phi alone (the guards are not
  //    decided yet; max(phi, guard) >= phi): cells no kernel reaches are exactly void; reached
  //    cells whose corners and centre all exceed level + band_margin are interior ("deep"),
  //    those all below level - band_margin are exterior ("far") unless they hold a guarded
  //    particle. The rest is "active". The screening is a heuristic (detector.hpp).
  std::vector<char> reached, deep, far;
  if (config.narrow_band) {
    reached.assign(static_cast<std::size_t>(ncx) * ncy, 0);
    for (std::size_t p = 0; p < n_particles; ++p) {
      const Vec2 half = field.reach_box(p);
      const int i0 = std::max(grid.cell_i(positions[p].x() - half.x()), 0);
      const int i1 = std::min(grid.cell_i(positions[p].x() + half.x()), ncx - 1);
      const int j0 = std::max(grid.cell_j(positions[p].y() - half.y()), 0);
      const int j1 = std::min(grid.cell_j(positions[p].y() + half.y()), ncy - 1);
      for (int j = j0; j <= j1; ++j) {
        for (int i = i0; i <= i1; ++i) reached[static_cast<std::size_t>(j) * ncx + i] = 1;
      }
    }
    // phi at the grid nodes and cell centres, gathered point by point (the coarse nodes are
    // sparse: a particle would visit few of them, a block evaluation would cost more).
    std::vector<double> coarse(static_cast<std::size_t>(ncx + 1) * (ncy + 1),
                               std::numeric_limits<double>::quiet_NaN());
    const auto coarse_phi = [&](int i, int j) {
      double& slot = coarse[static_cast<std::size_t>(j) * (ncx + 1) + i];
      if (std::isnan(slot)) {
        slot = field.volume_fraction(grid.node_position(i, j));
        ++field_evaluations;
      }
      return slot;
    };
    deep.assign(reached.size(), 0);
    far.assign(reached.size(), 0);
    const double interior = level + config.band_margin;
    const double exterior = level - config.band_margin;
    for (int j = 0; j < ncy; ++j) {
      for (int i = 0; i < ncx; ++i) {
        const std::size_t c = static_cast<std::size_t>(j) * ncx + i;
        if (!interior_by_volume.empty() && interior_by_volume[c]) {
          deep[c] = 1;
          continue;
        }
        if (!reached[c]) continue;
        const double v[4] = {coarse_phi(i, j), coarse_phi(i + 1, j), coarse_phi(i, j + 1),
                             coarse_phi(i + 1, j + 1)};
        bool is_deep = v[0] > interior && v[1] > interior && v[2] > interior && v[3] > interior;
        bool is_far = v[0] < exterior && v[1] < exterior && v[2] < exterior && v[3] < exterior;
        if (is_deep || is_far) {
          const double vc =
              field.volume_fraction(grid.node_position(i, j) + Vec2(0.5 * h, 0.5 * h));
          ++field_evaluations;
          is_deep = is_deep && vc > interior;
          is_far = is_far && vc < exterior;
        }
        deep[c] = is_deep ? 1 : 0;
        far[c] = is_far ? 1 : 0;
      }
    }
  }
  lap(parts.screening);
  // 2. Guards: every particle outside the deep cells is a candidate (all without narrow band).
  std::vector<char> candidate;
  if (config.narrow_band) {
    candidate.assign(n_particles, 1);
    for (std::size_t p = 0; p < n_particles; ++p) {
      const int i = grid.cell_i(positions[p].x()), j = grid.cell_j(positions[p].y());
      if (i >= 0 && j >= 0 && i < ncx && j < ncy && deep[static_cast<std::size_t>(j) * ncx + i]) {
        candidate[p] = 0;
      }
    }
  }
  field.decide_guards(candidate);
  field_evaluations += static_cast<long>(
      candidate.empty() ? n_particles : std::count(candidate.begin(), candidate.end(), 1));

  lap(parts.guards);

  // Steps 3-5 run twice when the contours of the first pass leave a particle outside (step 5):
  // those particles are then guarded.
  const double tolerance_fraction = config.root_tolerance;
  double edge_seconds = 0.0, connection_seconds = 0.0;
  long root_evaluations = 0, edge_points = 0;
  ImprovedField::KernelArrays edge_slots;
  int edge_slots_cell = -1;  // the square whose slots edge_slots holds (-1: none)
  DetectedBoundary boundary;
  for (int pass = 0;; ++pass) {
    part_start = Clock::now();
    int refinement = config.refinement;
    if (refinement <= 0) {
      // A field cell whose diagonal fits in the smallest guard semi-axis has all four corners in
      // the guard ellipse of any particle inside it: that particle is then inside the contour.
      // The first pass tries the base refinement (4) whatever the guards; the containment check
      // below tests the guarded particles too, and the second pass takes the guards'
      // refinement if any particle is outside. A few guarded corner particles of a long face
      // would otherwise refine the whole band (300k-point block: 13 ms at refinement 10, 8 ms
      // at 4).
      const double axis =
          pass == 0 ? std::numeric_limits<double>::infinity() : field.smallest_guard_axis();
      // (Capped before the conversion: a guard squeezed to nothing asks for any refinement.)
      refinement = std::isfinite(axis)
                       ? static_cast<int>(std::min(std::ceil(h * std::sqrt(2.0) / axis), 1e6))
                       : 4;
      refinement = std::clamp(std::max(refinement, 4), 1, std::max(1, config.max_refinement));
    }
    const int r = refinement;
    timings.refinement = r;
    NodalField geometry;
    geometry.origin = grid.origin;
    geometry.spacing = h / r;
    geometry.n_x = ncx * r + 1;
    geometry.n_y = ncy * r + 1;
    const int n_fine_x = geometry.n_x - 1, n_fine_y = geometry.n_y - 1;
    // The fine cell (i, j) holding x, clamped to the grid; false when x lies outside the grid.
    const auto fine_cell = [&](const Vec2& x, int& i, int& j) {
      const double u = std::floor((x.x() - geometry.origin.x()) / geometry.spacing);
      const double v = std::floor((x.y() - geometry.origin.y()) / geometry.spacing);
      i = static_cast<int>(std::clamp(u, 0.0, n_fine_x - 1.0));
      j = static_cast<int>(std::clamp(v, 0.0, n_fine_y - 1.0));
      return u >= 0.0 && v >= 0.0 && u < n_fine_x && v < n_fine_y;
    };
    BlockStore<double> node_cache(ncx, ncy, r, std::numeric_limits<double>::quiet_NaN());
    const auto node_value = [&](int i, int j) {
      double& slot = node_cache.at(i, j);
      if (std::isnan(slot)) {
        slot = field(Vec2(geometry.origin.x() + static_cast<double>(i) * geometry.spacing,
                          geometry.origin.y() + static_cast<double>(j) * geometry.spacing));
        ++field_evaluations;
      }
      return slot;
    };
    const auto inside = [&](int i, int j) { return node_value(i, j) > level; };

    // 3. The fine cells to contour. Full field: all of them. Narrow band: the contours are traced
    //    from seeds, fine cell by fine cell: a cell with a sign change passes its contour on
    //    through every edge whose nodes differ, so a contour is followed wherever it goes. Seeds:
    //    (a) in the active coarse cells, the field on a lattice of every stride-th fine node
    //    (stride: the largest divisor of the refinement up to half of it, so the lattice is at
    //    most half a grid cell; every fine node near a guarded particle), and along every lattice
    //    segment whose two ends differ and along the grid edge, the fine cells beside each fine
    //    edge with a sign change; (b) for each guarded particle, and each other particle of an
    //    island that may hold no lattice node, the first cell with a sign change from it.
    std::vector<int> cells;
    if (!config.narrow_band) {
      cells.resize(static_cast<std::size_t>(n_fine_x) * n_fine_y);
      for (std::size_t c = 0; c < cells.size(); ++c) cells[c] = static_cast<int>(c);
    } else {
      BlockStore<char> visited(ncx, ncy, r, 0);
      std::vector<int> queue;
      const auto push = [&](int i, int j) {
        if (i < 0 || j < 0 || i >= n_fine_x || j >= n_fine_y) return;
        char& v = visited.at(i, j);
        if (v) return;
        v = 1;
        queue.push_back(j * n_fine_x + i);
      };
      std::vector<char> guard_here(reached.size(), 0);
      for (std::size_t p = 0; p < n_particles; ++p) {
        if (!field.guarded(p)) continue;
        const int i = grid.cell_i(positions[p].x()), j = grid.cell_j(positions[p].y());
        if (i >= 0 && j >= 0 && i < ncx && j < ncy)
          guard_here[static_cast<std::size_t>(j) * ncx + i] = 1;
      }
      const auto active = [&](int i, int j) {
        const std::size_t c = static_cast<std::size_t>(j) * ncx + i;
        return reached[c] && !deep[c] && (!far[c] || guard_here[c]);
      };
      int coarse_stride = 1;
      for (int d = 1; 2 * d <= r; ++d) {
        if (r % d == 0) coarse_stride = d;
      }
      // Near a guarded particle (its cell and the cells its guard reaches, at least the ring
      // around it) the guards' small ellipses and the gaps between them make sub-lattice islands
      // and holes: every fine node there.
      const double guard_reach = std::sqrt(2.0) * config.guard_factor * 0.5 *
                                 cloud.initial_spacing * survey.largest_stretch;
      const int guard_rings = static_cast<int>(std::clamp(std::ceil(guard_reach / h), 1.0, widest));
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
          const int stride = fine ? 1 : coarse_stride;
          // The lattice segments of the run (every fine node near guards): along its rows and up
          // its columns.
          const int last_i = end * r, last_j = (j + 1) * r;
          for (int fj = j * r; fj <= last_j; fj += stride) {
            for (int fi = i * r; fi <= last_i; fi += stride) {
              const bool here = inside(fi, fj);
              if (fi < last_i && inside(fi + stride, fj) != here)
                seed_segment(fi, fj, 1, 0, stride);
              if (fj < last_j && inside(fi, fj + stride) != here)
                seed_segment(fi, fj, 0, 1, stride);
            }
          }
          // Along the grid edge every fine edge: a region cut by the edge has a contour for each
          // stretch of the edge it leaves, which may start and end between two lattice nodes.
          if (j == 0) seed_segment(i * r, 0, 1, 0, last_i - i * r);
          if (j == ncy - 1) seed_segment(i * r, n_fine_y, 1, 0, last_i - i * r);
          if (i == 0) seed_segment(0, j * r, 0, 1, r);
          if (end == ncx) seed_segment(n_fine_x, j * r, 0, 1, r);
          i = end;
        }
      }
      const auto sign_change = [&](int i, int j) {
        const bool a = inside(i, j);
        return a != inside(i + 1, j) || a != inside(i, j + 1) || a != inside(i + 1, j + 1);
      };
      // Seeds the first cell with a sign change in p's row, from p's cell to the right; if the
      // row has none up to the grid edge (a contour cut by the edge), to the left, then in p's
      // column upwards and downwards.
      const auto seed_from = [&](std::size_t p) {
        int i0 = 0, j0 = 0;
        fine_cell(positions[p], i0, j0);  // from the nearest cell for a particle off the grid
        const int steps[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
        for (const auto& [di, dj] : steps) {
          for (int i = i0, j = j0; i >= 0 && j >= 0 && i < n_fine_x && j < n_fine_y;
               i += di, j += dj) {
            // Cells found interior by their volume are passed as inside without evaluation: the
            // particles deep inside them are not in the field, whose values there would be too
            // low.
            if (!interior_by_volume.empty() &&
                interior_by_volume[static_cast<std::size_t>(j / r) * ncx + i / r]) {
              continue;
            }
            if (sign_change(i, j)) {
              push(i, j);
              return;
            }
          }
        }
      };
      for (std::size_t p = 0; p < n_particles; ++p) {
        if (field.guarded(p)) seed_from(p);
      }
      // Islands that hold no lattice node: an unguarded candidate particle (phi > level there)
      // seeds like a guarded one when its coarse cell is not active (no lattice there) or when
      // all four corners of its lattice square are outside.
      for (std::size_t p = 0; p < n_particles; ++p) {
        int i = 0, j = 0;
        if (!candidate[p] || field.guarded(p) || !fine_cell(positions[p], i, j)) continue;
        const std::size_t c = static_cast<std::size_t>(j / r) * ncx + i / r;
        const int stride = near_guard[c] ? 1 : coarse_stride;
        const int ci = i / stride * stride, cj = j / stride * stride;
        if (!active(i / r, j / r) ||
            (!inside(ci, cj) && !inside(ci + stride, cj) && !inside(ci, cj + stride) &&
             !inside(ci + stride, cj + stride))) {
          seed_from(p);
        }
      }
      // Trace: a cell with a sign change passes the contour on through each edge whose two nodes
      // differ; cells reached without a sign change (none in exact arithmetic) are dropped.
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
    }
    lap(parts.nodes);

    // 4. Edge points and contours.
    const auto contour_start = Clock::now();
    const double edge_seconds_before = edge_seconds;
    const double tolerance_t = tolerance_fraction * r;  // fraction of the fine edge
    const int square = std::max(1, r / 2);
    edge_slots_cell = -1;  // a new fine grid
    const EdgeRefiner refine = [&](const Vec2& a, double value_a, const Vec2& b, double value_b) {
      const auto start = Clock::now();
      const Vec2 d = b - a;
      // Every evaluation of the root lies on the edge, in the square of `square` x `square` fine
      // cells (about h/2) that holds its middle (a closed box): the slots reaching that square
      // are gathered once for all its edges (the contours are followed cell by cell). A whole
      // grid cell would gather twice the slots at 5 points per cell.
      int fi = 0, fj = 0;
      fine_cell(0.5 * (a + b), fi, fj);
      const int si = fi / square, sj = fj / square;
      const int key = sj * (n_fine_x / square + 1) + si;
      if (key != edge_slots_cell) {
        edge_slots_cell = key;
        const Vec2 corner = geometry.origin + Vec2(si, sj) * (square * geometry.spacing);
        const Vec2 upper = corner + Vec2::Constant(square * geometry.spacing);
        field.slots_reaching(corner.cwiseMin(a.cwiseMin(b)), upper.cwiseMax(a.cwiseMax(b)),
                             edge_slots);
      }
      const double t = brent_root([&](double s) { return field(a + s * d, edge_slots) - level; },
                                  value_a, value_b, tolerance_t, &root_evaluations);
      ++edge_points;
      edge_seconds += seconds_since(start);
      return Vec2(a + t * d);
    };
    const std::function<double(const Vec2&)> exact_sample = [&](const Vec2& x) {
      ++field_evaluations;
      return field(x);
    };
    boundary = marching_squares_cells(geometry, node_value, cells, level, config.saddle_rule,
                                      refine, exact_sample);
    timings.processed_cells = static_cast<long>(cells.size());

    // 5. Containment: an unguarded particle (of those tested for guards) in a fine cell that a
    //    contour crosses must lie on the material side of the cell's segment nearest to it (left
    //    of it: one segment, or two in a saddle cell, which the nearest one decides). The first
    //    pass's contours can cut off a particle whose phi is above the guard margin where the
    //    level set curves within a fine cell (a small island); such particles get their guard and
    //    the contours are found again.
    struct CellSegment {
      int cell;
      Vec2 a, b;
    };
    std::vector<CellSegment> segments;
    std::vector<char> crossed(static_cast<std::size_t>(ncx) * ncy, 0);
    for (const Contour& c : boundary.contours) {
      const std::size_t n = c.points.size();
      for (std::size_t k = 0; k + 1 < n || (c.closed && k < n); ++k) {
        const Vec2& a = c.points[k];
        const Vec2& b = c.points[(k + 1) % n];
        int i = 0, j = 0;
        fine_cell(0.5 * (a + b), i, j);
        segments.push_back({j * n_fine_x + i, a, b});
        crossed[static_cast<std::size_t>(j / r) * ncx + i / r] = 1;
      }
    }
    std::stable_sort(segments.begin(), segments.end(),
                     [](const CellSegment& x, const CellSegment& y) { return x.cell < y.cell; });
    std::vector<std::size_t> left_out;
    for (std::size_t p = 0; p < n_particles; ++p) {
      if (!candidate.empty() && !candidate[p]) continue;
      const Vec2& x = positions[p];
      int fi = 0, fj = 0;
      if (!fine_cell(x, fi, fj)) continue;
      const int ci = fi / r, cj = fj / r;
      const int cell = fj * n_fine_x + fi;
      auto it = segments.end();
      if (crossed[static_cast<std::size_t>(cj) * ncx + ci]) {
        it = std::lower_bound(segments.begin(), segments.end(), cell,
                              [](const CellSegment& s, int value) { return s.cell < value; });
      }
      if (it == segments.end() || it->cell != cell) {
        // No contour in p's fine cell: its corners share one sign, which must be inside (a
        // few stacked points make an island smaller than a fine cell, which no node sees).
        // Any corner tells; one already evaluated (the lattice holds one of every fine cell at
        // stride 2) saves an evaluation.
        double corner = std::numeric_limits<double>::quiet_NaN();
        for (int k = 0; k < 4 && std::isnan(corner); ++k) {
          const double* known = node_cache.find(fi + (k & 1), fj + (k >> 1));
          if (known != nullptr) corner = *known;
        }
        if (std::isnan(corner)) corner = node_value(fi, fj);
        if (!(corner > level)) left_out.push_back(p);
        continue;
      }
      const CellSegment* nearest = nullptr;
      double best = std::numeric_limits<double>::infinity();
      for (; it != segments.end() && it->cell == cell; ++it) {
        const Vec2 d = it->b - it->a;
        const double t =
            std::clamp((x - it->a).dot(d) / std::max(d.squaredNorm(), 1e-300), 0.0, 1.0);
        const double distance = (it->a + t * d - x).squaredNorm();
        if (distance < best) {
          best = distance;
          nearest = &*it;
        }
      }
      if (nearest == nullptr) continue;
      const Vec2 d = nearest->b - nearest->a, e = x - nearest->a;
      if (d.x() * e.y() - d.y() * e.x() < 0.0) left_out.push_back(p);
    }
    connection_seconds += seconds_since(contour_start) - (edge_seconds - edge_seconds_before);
    if (left_out.empty() || pass > 0 || config.guard_factor <= 0.0) break;
    timings.particles_outside_first_contours = static_cast<long>(left_out.size());
    const std::size_t guarded_before = field.n_guarded();
    field.add_guards(left_out);
    timings.particles_guarded_after_contouring =
        static_cast<long>(field.n_guarded() - guarded_before);
  }
  timings.edge_points = edge_seconds;
  timings.connection = connection_seconds;
  timings.edge_point_count = edge_points;
  timings.root_evaluations = root_evaluations;
  timings.field_evaluations = field_evaluations + root_evaluations;
  timings.field =
      parts.survey + parts.band + parts.setup + parts.screening + parts.guards + parts.nodes;
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

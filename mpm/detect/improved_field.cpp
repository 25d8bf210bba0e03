// The improved detector's exact field (see detector.hpp): max(phi, guard), the volume-normalised
// kernel sums with the particle guards, their slots and bins, and the root finder of the edges.
#include "mpm/detect/improved_field.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <stdexcept>
#include <type_traits>
#include <utility>

#include "mpm/detect/detect_internal.hpp"
#include "mpm/detect/kernel.hpp"
#include "mpm/detect/vector_loops.hpp"

namespace pfm {

namespace {

// Particles (slots) per chunk of the field's set-up loops on the OpenMP threads (some 10 ns each;
// see improved_detector.cpp), and per chunk of the guard decisions (an evaluation each, about
// 60 ns, for the candidates).
constexpr std::size_t kParticleChunk = 4096;
constexpr std::size_t kGuardChunk = 512;

// Grid edge w (0 left, 1 right, 2 bottom, 3 top of the box g0 .. g1): the distance of x from
// it (> 0 inside the box) and the position of x along it from the box's lower corner, m.
double wall_distance(int w, const Vec2& x, const Vec2& g0, const Vec2& g1) {
  return w == 0   ? x.x() - g0.x()
         : w == 1 ? g1.x() - x.x()
         : w == 2 ? x.y() - g0.y()
                  : g1.y() - x.y();
}

// The columns of `kernels` that the kernel sums read.
detail::KernelColumns summed_columns(const ImprovedField::KernelArrays& k) {
  return {k.x.data(),   k.y.data(),   k.k00.data(),   k.k01.data(),
          k.k10.data(), k.k11.data(), k.weight.data()};
}

double wall_along(int w, const Vec2& x, const Vec2& g0) {
  return w < 2 ? x.y() - g0.y() : x.x() - g0.x();
}

/// A particle's mirror image across a grid edge (in_x: x = ex) or two (in_y: y = ey), m.
struct MirrorImage {
  std::size_t particle;
  bool in_x, in_y;
  double ex, ey;  ///< the mirror lines x = ex, y = ey, m
};

/// The mirror images across the edges of `walls` that no particle lies beyond: the reflection
/// R (x - e) + e of the position and R F R of the deformation, R = diag(-1, 1) or diag(1, -1);
/// near a corner across both edges too. `contacts`: the wall contacts if known (else found
/// here). Appends each image's position to `all_positions`.
std::vector<MirrorImage> mirror_images(const std::vector<Vec2>& position,
                                       const std::vector<Vec2>& reach_box,
                                       const std::vector<double>& particle_reach, const Grid& walls,
                                       double spacing, const ImprovedField::WallContacts* contacts,
                                       std::vector<Vec2>& all_positions) {
  std::vector<MirrorImage> images;
  const Vec2 g0 = walls.origin, g1 = walls.upper_corner();
  ImprovedField::WallContacts own;
  if (contacts == nullptr) {
    Vec2 lo = position[0], hi = position[0];
    for (const Vec2& x : position) {
      lo = lo.cwiseMin(x);
      hi = hi.cwiseMax(x);
    }
    own = ImprovedField::find_wall_contacts(position, lo, hi, walls, spacing);
    contacts = &own;
  }
  for (std::size_t p = 0; p < position.size(); ++p) {
    const Vec2& x = position[p];
    const double half_x = std::max(reach_box[p].x(), particle_reach[p]);
    const double half_y = std::max(reach_box[p].y(), particle_reach[p]);
    const auto [side_x, side_y] =
        ImprovedField::mirror_sides(*contacts, walls, x, half_x, half_y, spacing);
    if (side_x < 0 && side_y < 0) continue;
    const double ex = side_x == 1 ? g1.x() : g0.x(), ey = side_y == 1 ? g1.y() : g0.y();
    const std::pair<bool, bool> kinds[3] = {{true, false}, {false, true}, {true, true}};
    for (const auto& [in_x, in_y] : kinds) {
      if ((in_x && side_x < 0) || (in_y && side_y < 0)) continue;
      images.push_back({p, in_x, in_y, ex, ey});
      all_positions.emplace_back(in_x ? 2.0 * ex - x.x() : x.x(), in_y ? 2.0 * ey - x.y() : x.y());
    }
  }
  return images;
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
    : exponent_(detail::kernel_exponent(config.profile)),
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
  curvature_moment_ = detail::kernel_curvature_moment(config.profile, a0);
  const bool deformed = !cloud.deformation_gradient.empty();
  const double guard_reach = reference_guard_reach(config, cloud.initial_spacing);
  const double unit_reach = reference_reach(config, cloud.initial_spacing);
  // Pass 1, by particle (on the threads): reaches (for the bins, the mirror images and the
  // narrow band).
  detail::for_each_on_threads(n, kParticleChunk, [&](std::size_t p) {
    if (!deformed) {
      smallest_stretch_[p] = 1.0;
      kernel_reach_[p] = a0;
      particle_reach_[p] = unit_reach;
      reach_box_[p] = Vec2::Constant(particle_reach_[p]);
      return;
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
  });
  for (std::size_t p = 0; p < n; ++p) reach_ = std::max(reach_, particle_reach_[p]);
  // Mirror images across the grid edges that no particle lies beyond (walls); never guarded.
  std::vector<Vec2> all_positions = position_;
  const std::vector<MirrorImage> images =
      walls != nullptr && n > 0 ? mirror_images(position_, reach_box_, particle_reach_, *walls,
                                                cloud.initial_spacing, contacts, all_positions)
                                : std::vector<MirrorImage>();
  // Bins of the largest reach / kBinRings, searched kBinRings rings out.
  rings_ = kBinRings;
  bins_ = ParticleBins(all_positions, reach_ > 0.0 ? reach_ / rings_ : 1.0);
  // Pass 2, in bin order (the cloud's arrays are read in a few streams): the slots.
  const auto kernel_of = [&](std::size_t p) {
    return detail::kernel_slot(position_[p], cloud.volume[p],
                               deformed ? &cloud.deformation_gradient[p] : nullptr, a0,
                               config.profile);
  };
  slot_.assign_zeros(all_positions.size());
  detail::for_each_on_threads(slot_.size(), kParticleChunk, [&](std::size_t k) {
    const std::size_t q = static_cast<std::size_t>(bins_.particle_at(static_cast<int>(k)));
    detail::KernelSlot m = kernel_of(q < n ? q : images[q - n].particle);
    if (q >= n) {
      const MirrorImage& image = images[q - n];
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
  });
  double largest_weight = 0.0;
  for (std::size_t k = 0; k < slot_.size(); ++k) {
    largest_weight = std::max(largest_weight, slot_.weight[k]);
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
  fixed_point_bits_ = detail::fixed_point_bits(bound, slots);
  fixed_point_unit_ = std::ldexp(1.0, -fixed_point_bits_);
  // A power of two: each product is std::ldexp(weight, bits), correctly rounded alike.
  const double scale = std::ldexp(1.0, fixed_point_bits_);
  for (std::size_t k = 0; k < slot_.size(); ++k) slot_.weight[k] *= scale;
}

double ImprovedField::weight_bound(const ImprovedConfig& config, double initial_spacing,
                                   double largest_volume, double smallest_det) {
  return detail::kernel_weight_bound(config.profile, config.radius_factor * initial_spacing,
                                     largest_volume, smallest_det);
}

void ImprovedField::KernelArrays::assign_zeros(std::size_t n) {
  n_ = n;
  for (std::vector<double>* v : columns()) v->assign(n + detail::kKernelPadding, 0.0);
  guarded_slots.clear();
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
  guarded_slots.clear();
  if (from.guarded_slots.empty()) return;
  for (std::size_t k = 0; k < n_; ++k) {
    if (std::binary_search(from.guarded_slots.begin(), from.guarded_slots.end(), slots[k])) {
      guarded_slots.push_back(static_cast<int>(k));
    }
  }
}

double ImprovedField::reference_guard_reach(const ImprovedConfig& config, double initial_spacing) {
  if (!(config.guard_factor > 0.0)) return 0.0;
  // The guard is defined where q_g < 2: out to sqrt 2 times its radius.
  return std::sqrt(2.0) * (config.guard_factor * 0.5 * initial_spacing);
}

double ImprovedField::reference_reach(const ImprovedConfig& config, double initial_spacing) {
  return std::max(config.radius_factor * initial_spacing,
                  reference_guard_reach(config, initial_spacing));
}

std::array<int, 2> ImprovedField::mirror_sides(const WallContacts& contacts, const Grid& walls,
                                               const Vec2& x, double half_x, double half_y,
                                               double spacing) {
  const Vec2 g0 = walls.origin, g1 = walls.upper_corner();
  // Across wall w if the particle reaches it (half_across) where the body touches it, within
  // half_along along it.
  const auto mirrored = [&](int w, double half_across, double half_along) {
    if (!contacts.wall[w] || wall_distance(w, x, g0, g1) >= half_across) return false;
    const auto& bins = contacts.touched[w];
    const double a = wall_along(w, x, g0);
    const long b0 = std::max(0L, static_cast<long>(std::floor((a - half_along) / spacing)));
    const long b1 = std::min(static_cast<long>(bins.size()) - 1,
                             static_cast<long>(std::floor((a + half_along) / spacing)));
    for (long b = b0; b <= b1; ++b) {
      if (bins[static_cast<std::size_t>(b)]) return true;
    }
    return false;
  };
  const int side_x = mirrored(0, half_x, half_y) ? 0 : mirrored(1, half_x, half_y) ? 1 : -1;
  const int side_y = mirrored(2, half_y, half_x) ? 0 : mirrored(3, half_y, half_x) ? 1 : -1;
  return {side_x, side_y};
}

ImprovedField::WallContacts ImprovedField::find_wall_contacts(std::span<const Vec2> positions,
                                                              const Vec2& lo, const Vec2& hi,
                                                              const Grid& walls, double spacing,
                                                              double distance) {
  if (!(distance > 0.0)) distance = spacing;
  // Wall w: 0 left, 1 right, 2 bottom, 3 top. Where the body rests on a wall: a particle closer
  // to it than `distance` (one initial spacing for the field) "touches" it; the touched stretches
  // of the wall are kept in bins of one spacing along it, and a particle is mirrored across the
  // wall only if the wall is touched within its reach along the wall (a body near a wall but clear
  // of it keeps its own boundary there).
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
      if (wall_distance(w, x, g0, g1) >= distance) continue;
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
  // evaluated before any guard is switched on (on the threads, by chunks of particles).
  std::vector<char> low(n, 0);
  detail::for_each_on_threads(n, kGuardChunk, [&](std::size_t p) {
    if (candidate.empty() || candidate[p]) {
      low[p] = volume_fraction_above(position_[p], level_ + guard_margin_) ? 0 : 1;
    }
  });
  for (std::size_t p = 0; p < n; ++p) {
    if (low[p]) switch_guard_on(p);
  }
  list_guarded_slots();
  // Particles without a guard reach as far as their kernel.
  for (std::size_t p = 0; p < n; ++p) {
    if (!guarded_[p]) particle_reach_[p] = kernel_reach_[p];
  }
}

std::size_t ImprovedField::add_guards(std::span<const std::size_t> particles) {
  if (!guard_) return 0;
  const std::size_t before = n_guarded_;
  for (const std::size_t p : particles) {
    if (guarded_[p]) continue;
    switch_guard_on(p);
    particle_reach_[p] = kernel_reach_[p] * std::max(1.0, std::sqrt(2.0) / guard_scale_);
  }
  list_guarded_slots();
  return n_guarded_ - before;
}

void ImprovedField::list_guarded_slots() {
  slot_.guarded_slots.clear();
  for (std::size_t p = 0; p < guarded_.size(); ++p) {
    if (guarded_[p]) slot_.guarded_slots.push_back(bins_.slot_of(static_cast<int>(p)));
  }
  std::sort(slot_.guarded_slots.begin(), slot_.guarded_slots.end());
}

void ImprovedField::switch_guard_on(std::size_t p) {
  guarded_[p] = 1;
  ++n_guarded_;
  smallest_guard_axis_ = std::min(smallest_guard_axis_, guard_radius_ * smallest_stretch_[p]);
  const auto k = static_cast<std::size_t>(bins_.slot_of(static_cast<int>(p)));
  // The guard's support |K d|^2 < 2 / scale^2 is the kernel ellipse scaled by sqrt(2) / scale.
  const double guard_box = std::sqrt(2.0) / guard_scale_;
  if (guard_box > 1.0) {
    slot_.half_x[k] *= guard_box;
    slot_.half_y[k] *= guard_box;
  }
}

double ImprovedField::sum_ranges(const KernelArrays& kernels, const int* begin, const int* end,
                                 int n_ranges, const Vec2& x, bool guard) const {
  const detail::KernelColumns columns = summed_columns(kernels);
  const double px = x.x(), py = x.y();
  const std::uint64_t units = detail::kernel_sum(exponent_, columns, begin, end, n_ranges, px, py);
  const double phi = static_cast<double>(units) * fixed_point_unit_;
  return guard ? std::max(phi, raised_by(kernels, begin, end, n_ranges, x)) : phi;
}

double ImprovedField::raised_by(const KernelArrays& kernels, const int* begin, const int* end,
                                int n_ranges, const Vec2& x) const {
  const double px = x.x(), py = x.y();
  const double bridged = bridges_.a.empty() ? 0.0 : bridges_.value(x, level_);
  if (n_guarded_ == 0) return bridged;
  // The guards (few): 0.5 + 0.5 (1 - |G^-1 d|^2), > 0.5 inside the guard ellipse, continuous,
  // 0 at q = 2; G = F rho0 = S rho0 / a0, so |G^-1 d|^2 = (a0 / rho0)^2 q. A maximum, so in any
  // order.
  const double scale_squared = guard_scale_ * guard_scale_;
  const std::vector<int>& guarded = kernels.guarded_slots;
  double best = 0.0;
  for (int r = 0; r < n_ranges; ++r) {
    for (auto it = std::lower_bound(guarded.begin(), guarded.end(), begin[r]);
         it != guarded.end() && *it < end[r]; ++it) {
      const auto s = static_cast<std::size_t>(*it);
      const double dx = px - kernels.x[s], dy = py - kernels.y[s];
      const double ux = kernels.k00[s] * dx + kernels.k01[s] * dy;
      const double uy = kernels.k10[s] * dx + kernels.k11[s] * dy;
      const double qg = scale_squared * (ux * ux + uy * uy);
      if (qg < 2.0) best = std::max(best, 1.0 - 0.5 * qg);
    }
  }
  return std::max(bridged, best);
}

double ImprovedField::sum_at(const Vec2& x, bool guard) const {
  int begin[2 * kBinRings + 1], end[2 * kBinRings + 1];
  const int rows = bins_.slot_rows_near(x, rings_, begin, end);
  return sum_ranges(slot_, begin, end, rows, x, guard);
}

double ImprovedField::guards_and_bridges(const Vec2& x) const {
  int begin[2 * kBinRings + 1], end[2 * kBinRings + 1];
  const int rows = bins_.slot_rows_near(x, rings_, begin, end);
  return raised_by(slot_, begin, end, rows, x);
}

double ImprovedField::volume_fraction(const Vec2& x) const {
  return sum_at(x, false);
}

double ImprovedField::Bridges::value(const Vec2& x, double level) const {
  const double u = std::floor((x.x() - origin.x()) / bin),
               v = std::floor((x.y() - origin.y()) / bin);
  if (!(u >= 0.0 && v >= 0.0 && u < n_x && v < n_y)) return 0.0;
  const std::size_t k = static_cast<std::size_t>(v) * n_x + static_cast<std::size_t>(u);
  // The Chebyshev distance to a segment's box bounds the distance to the segment from below: a
  // box farther than the support is skipped (a fixed bound, not the nearest so far, whose
  // rounding would make the result depend on the order of the segments).
  const double support = 2.0 * half;
  double nearest = support;
  for (int i = start[k]; i < start[k + 1]; ++i) {
    const auto s = static_cast<std::size_t>(item[static_cast<std::size_t>(i)]);
    const Vec2 lo = a[s].cwiseMin(b[s]), hi = a[s].cwiseMax(b[s]);
    const double box = std::max(std::max(lo.x() - x.x(), x.x() - hi.x()),
                                std::max(lo.y() - x.y(), x.y() - hi.y()));
    if (box < support) nearest = std::min(nearest, detail::chebyshev_distance(x, a[s], b[s]));
  }
  return nearest < support ? level * (2.0 - nearest / half) : 0.0;
}

void ImprovedField::add_bridges(std::span<const std::size_t> points,
                                std::span<const std::array<std::size_t, 2>> pairs, double cell) {
  Bridges& g = bridges_;
  for (const std::size_t p : points) {
    g.a.push_back(position_[p]);
    g.b.push_back(position_[p]);
  }
  // Each segment from its lower-left end (lexicographically), so that its distances do not
  // depend on the order of the two particles.
  for (const auto& [p, q] : pairs) {
    const Vec2 &x = position_[p], &y = position_[q];
    const bool ordered = x.x() < y.x() || (x.x() == y.x() && x.y() <= y.y());
    g.a.push_back(ordered ? x : y);
    g.b.push_back(ordered ? y : x);
  }
  if (g.a.empty()) return;
  g.half = 1.25 * cell;
  const double support = 2.0 * g.half;  // beyond it a bridge adds 0
  Vec2 lo = g.a[0].cwiseMin(g.b[0]), hi = g.a[0].cwiseMax(g.b[0]);
  for (std::size_t s = 0; s < g.a.size(); ++s) {
    lo = lo.cwiseMin(g.a[s].cwiseMin(g.b[s]));
    hi = hi.cwiseMax(g.a[s].cwiseMax(g.b[s]));
  }
  // Bins of the support's size (a segment is listed in each bin its box widened by the support
  // meets): an evaluation visits the few bridges near it. Where that would make more bins than
  // four per bridge (and 16,384), they are widened evenly to that many. The value does not
  // depend on the bins (the nearest segment within the support, whichever bin lists it).
  g.origin = lo - Vec2::Constant(support);
  const Vec2 extent = hi - lo + Vec2::Constant(2.0 * support);
  const double most = std::max(16384.0, 4.0 * static_cast<double>(g.a.size()));
  const double count = std::ceil(extent.x() / support) * std::ceil(extent.y() / support);
  g.bin = count > most ? support * std::sqrt(count / most) : support;
  g.n_x = static_cast<int>(std::floor((hi.x() + support - g.origin.x()) / g.bin)) + 1;
  g.n_y = static_cast<int>(std::floor((hi.y() + support - g.origin.y()) / g.bin)) + 1;
  std::vector<std::vector<int>> lists(static_cast<std::size_t>(g.n_x) * g.n_y);
  for (std::size_t s = 0; s < g.a.size(); ++s) {
    const Vec2 a = g.a[s].cwiseMin(g.b[s]) - Vec2::Constant(support);
    const Vec2 b = g.a[s].cwiseMax(g.b[s]) + Vec2::Constant(support);
    const int i0 = static_cast<int>(std::floor((a.x() - g.origin.x()) / g.bin));
    const int j0 = static_cast<int>(std::floor((a.y() - g.origin.y()) / g.bin));
    const int i1 =
        std::min(g.n_x - 1, static_cast<int>(std::floor((b.x() - g.origin.x()) / g.bin)));
    const int j1 =
        std::min(g.n_y - 1, static_cast<int>(std::floor((b.y() - g.origin.y()) / g.bin)));
    for (int j = std::max(j0, 0); j <= j1; ++j) {
      for (int i = std::max(i0, 0); i <= i1; ++i) {
        lists[static_cast<std::size_t>(j) * g.n_x + i].push_back(static_cast<int>(s));
      }
    }
  }
  g.start.assign(1, 0);
  g.item.clear();
  for (const std::vector<int>& l : lists) {
    g.item.insert(g.item.end(), l.begin(), l.end());
    g.start.push_back(static_cast<int>(g.item.size()));
  }
}

double ImprovedField::operator()(const Vec2& x) const {
  return sum_at(x, true);
}

bool ImprovedField::volume_fraction_above(const Vec2& x, double threshold) const {
  int begin[2 * kBinRings + 1], end[2 * kBinRings + 1];
  const int rows = bins_.slot_rows_near(x, rings_, begin, end);
  const detail::KernelColumns columns = summed_columns(slot_);
  // The middle row, then the others outwards. phi = units x 2^-s never falls as units grow (the
  // conversion to double is monotone), so a partial sum above the threshold decides.
  int order[2 * kBinRings + 1];
  int n = 0;
  order[n++] = rows / 2;
  for (int d = 1; n < rows; ++d) {
    if (rows / 2 + d < rows) order[n++] = rows / 2 + d;
    if (rows / 2 - d >= 0) order[n++] = rows / 2 - d;
  }
  std::uint64_t units = 0;
  for (int k = 0; k < rows; ++k) {
    const int r = order[k];
    units += detail::kernel_sum(exponent_, columns, begin + r, end + r, 1, x.x(), x.y());
    if (static_cast<double>(units) * fixed_point_unit_ > threshold) return true;
  }
  return false;
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
  // An end exactly at the level (outside: inside is above it) is the root; it is put a
  // tolerance towards the other end, so that two contours that meet at a fine node (a saddle of
  // the field exactly at the level there) do not share the node as a point.
  if (value_a == 0.0) return std::min(tolerance_t, 0.5);
  if (value_b == 0.0) return 1.0 - std::min(tolerance_t, 0.5);
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

}  // namespace pfm

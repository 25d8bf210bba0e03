// The improved detector's definition (detector.hpp, ImprovedConfig), written plainly: the field
// of every particle summed term by term at every node of the refined grid, its contours by
// marching squares with Brent's roots on the crossed edges, the check that every particle lies
// inside them, the bridges and guards of the later passes, and the removal of spurious loops.
//
// It is the specification of detect_improved() (improved_detector.cpp) and its test oracle: the
// narrow band, the coarse screening, the bins, the sums in vector registers, the nodes kept
// between passes and the threads there give bitwise the same contours as this file
// (tests/cpp/detect, Determinism.* and Invariants.*). detect() runs this file for
// `narrow_band: false`. The pieces of the definition that the fast path shares with it (the
// refinement of a pass, what the contours of a pass call for next, the containment check's
// geometry) are in definition.cpp; the kernel is in kernel.hpp, the wall rule in ImprovedField,
// the loops' classes and the bridges' pairs in loop_classes.cpp.

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <vector>

#include "mpm/detect/detect_internal.hpp"
#include "mpm/detect/improved_field.hpp"
#include "mpm/detect/kernel.hpp"
#include "mpm/detect/loop_classes.hpp"
#include "mpm/detect/marching_squares.hpp"

namespace pfm::detail {

namespace {

// The field max(phi, guards, bridges) of the whole cloud (detector.hpp, ImprovedField, defines
// each term).
class Field {
 public:
  // `weight_bound`: the largest kernel weight of the cloud, which sets the fixed-point unit.
  Field(const ParticleCloud& cloud, const ImprovedConfig& config, const Grid& grid,
        double weight_bound)
      : exponent_(kernel_exponent(config.profile)), level_(config.level) {
    const std::size_t n = cloud.position.size();
    const double spacing = cloud.initial_spacing;
    const double a0 = config.radius_factor * spacing;
    const bool deformed = !cloud.deformation_gradient.empty();
    guard_radius_ = config.guard_factor * 0.5 * spacing;
    guard_scale_ = config.guard_factor > 0.0 ? a0 / guard_radius_ : 0.0;
    position_.assign(cloud.position.begin(), cloud.position.end());
    guarded_.assign(n, 0);
    // One kernel per particle; the particle's largest and smallest stretch, and the rows' norms
    // of F (the half widths of the box around the ellipse F disk(1)).
    std::vector<Vec2> stretch(n, Vec2(1.0, 1.0)), widths(n, Vec2(1.0, 1.0));
    smallest_stretch_.assign(n, 1.0);
    for (std::size_t p = 0; p < n; ++p) {
      const Mat2* f = deformed ? &cloud.deformation_gradient[p] : nullptr;
      kernels_.push_back(kernel_slot(position_[p], cloud.volume[p], f, a0, config.profile));
      if (f == nullptr) continue;
      const Mat2& m = *f;
      singular_values(m, stretch[p].x(), stretch[p].y());
      smallest_stretch_[p] = stretch[p].y();
      widths[p] = Vec2(std::sqrt(m(0, 0) * m(0, 0) + m(0, 1) * m(0, 1)),
                       std::sqrt(m(1, 0) * m(1, 0) + m(1, 1) * m(1, 1)));
    }
    // Mirror images across the grid edges the body rests on (ImprovedConfig::mirror_grid_edges),
    // for a particle whose kernel or guard reaches the edge where the body touches it: the
    // position reflected, S^-1's off-diagonal terms negated once per reflection.
    if (config.mirror_grid_edges && n > 0) {
      Vec2 lo = position_[0], hi = position_[0];
      for (const Vec2& x : position_) {
        lo = lo.cwiseMin(x);
        hi = hi.cwiseMax(x);
      }
      const auto contacts = ImprovedField::find_wall_contacts(position_, lo, hi, grid, spacing);
      const double unit_reach = ImprovedField::reference_reach(config, spacing);
      const double guard_reach = ImprovedField::reference_guard_reach(config, spacing);
      const Vec2 g0 = grid.origin, g1 = grid.upper_corner();
      for (std::size_t p = 0; p < n; ++p) {
        // The reach of the kernel and of the guard (whether it becomes active or not).
        double reach = unit_reach;
        Vec2 box = Vec2::Constant(unit_reach);
        if (deformed) {
          reach = a0 * stretch[p].x();
          box = a0 * widths[p];
          if (config.guard_factor > 0.0) {
            reach = std::max(reach, guard_reach * stretch[p].x());
            box = box.cwiseMax(guard_reach * widths[p]);
          }
        }
        const auto side =
            ImprovedField::mirror_sides(contacts, grid, position_[p], std::max(box.x(), reach),
                                        std::max(box.y(), reach), spacing);
        for (const auto& [in_x, in_y] : {std::pair{true, false}, {false, true}, {true, true}}) {
          if ((in_x && side[0] < 0) || (in_y && side[1] < 0)) continue;
          KernelSlot image = kernels_[p];
          if (in_x) {
            image.x = 2.0 * (side[0] == 1 ? g1.x() : g0.x()) - image.x;
            image.k01 = -image.k01;
            image.k10 = -image.k10;
          }
          if (in_y) {
            image.y = 2.0 * (side[1] == 1 ? g1.y() : g0.y()) - image.y;
            image.k01 = -image.k01;
            image.k10 = -image.k10;
          }
          kernels_.push_back(image);
        }
      }
    }
    // The fixed-point unit: the cloud's largest weight and four slots per particle (itself and
    // up to three images).
    const int bits = fixed_point_bits(weight_bound, 4.0 * static_cast<double>(n));
    unit_ = std::ldexp(1.0, -bits);
    for (KernelSlot& k : kernels_) k.weight *= std::ldexp(1.0, bits);
    // Each grid cell lists the kernels whose box (widened more than phi() widens it) meets it.
    grid_ = grid;
    every_.resize(kernels_.size());
    for (std::size_t s = 0; s < every_.size(); ++s) every_[s] = s;
    by_cell_.resize(static_cast<std::size_t>(grid.n_cells_x) * grid.n_cells_y);
    const auto cell = [&](double v, double origin, int count) {
      return static_cast<int>(std::clamp(std::floor((v - origin) / grid.cell_size), 0.0,
                                         static_cast<double>(count - 1)));
    };
    for (std::size_t s = 0; s < kernels_.size(); ++s) {
      const KernelSlot& k = kernels_[s];
      const double wide_x = k.half_x * (1.0 + 1e-6), wide_y = k.half_y * (1.0 + 1e-6);
      const int i0 = cell(k.x - wide_x, grid.origin.x(), grid.n_cells_x);
      const int i1 = cell(k.x + wide_x, grid.origin.x(), grid.n_cells_x);
      const int j0 = cell(k.y - wide_y, grid.origin.y(), grid.n_cells_y);
      const int j1 = cell(k.y + wide_y, grid.origin.y(), grid.n_cells_y);
      for (int j = j0; j <= j1; ++j) {
        for (int i = i0; i <= i1; ++i) {
          by_cell_[static_cast<std::size_t>(j) * grid.n_cells_x + i].push_back(s);
        }
      }
    }
  }

  // phi(x) = sum_k round(w_k (1 - |S_k^-1 (x - x_k)|^2)_+^k) 2^-s, in units of 2^-s.
  double phi(const Vec2& x) const {
    std::uint64_t units = 0;
    for (const std::size_t s : kernels_near(x)) {
      const KernelSlot& k = kernels_[s];
      const double dx = x.x() - k.x, dy = x.y() - k.y;
      // Outside its box (widened by a hair against rounding) a kernel adds an exact zero.
      if (std::abs(dx) > k.half_x * (1.0 + 1e-9) || std::abs(dy) > k.half_y * (1.0 + 1e-9)) {
        continue;
      }
      const double ux = k.k00 * dx + k.k01 * dy, uy = k.k10 * dx + k.k11 * dy;
      const double t = 1.0 - (ux * ux + uy * uy);
      if (!(t > 0.0)) continue;
      const double term = exponent_ == 1   ? k.weight * t
                          : exponent_ == 2 ? k.weight * (t * t)
                                           : k.weight * ((t * t) * t);
      units += static_cast<std::uint64_t>(std::nearbyint(term));
    }
    return static_cast<double>(units) * unit_;
  }

  // The kernels listed in x's grid cell; every kernel for a point outside the grid.
  const std::vector<std::size_t>& kernels_near(const Vec2& x) const {
    const double u = std::floor((x.x() - grid_.origin.x()) / grid_.cell_size);
    const double v = std::floor((x.y() - grid_.origin.y()) / grid_.cell_size);
    if (!(u >= 0.0 && v >= 0.0 && u < grid_.n_cells_x && v < grid_.n_cells_y)) return every_;
    return by_cell_[static_cast<std::size_t>(v * grid_.n_cells_x + u)];
  }

  // max(phi, bridges, guards); a guard is 1 - |G^-1 (x - x_p)|^2 / 2 with G = F rho0 (> 1/2
  // inside the ellipse F disk(rho0), 0 where the square reaches 2).
  double operator()(const Vec2& x) const {
    double value = phi(x);
    if (!bridge_a_.empty()) value = std::max(value, bridge_value(x));
    const double scale_squared = guard_scale_ * guard_scale_;
    for (const std::size_t p : guard_list_) {
      const KernelSlot& k = kernels_[p];
      const double dx = x.x() - k.x, dy = x.y() - k.y;
      const double ux = k.k00 * dx + k.k01 * dy, uy = k.k10 * dx + k.k11 * dy;
      const double q = scale_squared * (ux * ux + uy * uy);
      if (q < 2.0) value = std::max(value, 1.0 - 0.5 * q);
    }
    return value;
  }

  // Guards `particles` (none without guards); returns how many were not guarded before.
  std::size_t add_guards(std::span<const std::size_t> particles) {
    if (!(guard_scale_ > 0.0)) return 0;
    const std::size_t before = guard_list_.size();
    for (const std::size_t p : particles) {
      if (guarded_[p]) continue;
      guarded_[p] = 1;
      guard_list_.push_back(p);
    }
    return guard_list_.size() - before;
  }
  // Smallest semi-axis of an active guard, m (infinity without one).
  double smallest_guard_axis() const {
    double axis = std::numeric_limits<double>::infinity();
    for (const std::size_t p : guard_list_) {
      axis = std::min(axis, guard_radius_ * smallest_stretch_[p]);
    }
    return axis;
  }

  // The bridges (ImprovedField::add_bridges()): the square of half side `cell` around each of
  // `points`, and the strip of that half width along each of `pairs`, inside the material.
  void add_bridges(std::span<const std::size_t> points,
                   std::span<const std::array<std::size_t, 2>> pairs, double cell) {
    for (const std::size_t p : points) {
      bridge_a_.push_back(position_[p]);
      bridge_b_.push_back(position_[p]);
    }
    for (const auto& [p, q] : pairs) {
      // From the lexicographically lower end.
      const Vec2 &x = position_[p], &y = position_[q];
      const bool ordered = x.x() < y.x() || (x.x() == y.x() && x.y() <= y.y());
      bridge_a_.push_back(ordered ? x : y);
      bridge_b_.push_back(ordered ? y : x);
    }
    bridge_half_ = 1.25 * cell;
  }
  std::size_t n_bridges() const { return bridge_a_.size(); }

 private:
  // level (2 - d / half), d the Chebyshev distance to the nearest bridge, where d < 2 half.
  double bridge_value(const Vec2& x) const {
    const double support = 2.0 * bridge_half_;
    double nearest = support;
    for (std::size_t s = 0; s < bridge_a_.size(); ++s) {
      const Vec2 lo = bridge_a_[s].cwiseMin(bridge_b_[s]), hi = bridge_a_[s].cwiseMax(bridge_b_[s]);
      const double box = std::max(std::max(lo.x() - x.x(), x.x() - hi.x()),
                                  std::max(lo.y() - x.y(), x.y() - hi.y()));
      if (box < support) {
        nearest = std::min(nearest, chebyshev_distance(x, bridge_a_[s], bridge_b_[s]));
      }
    }
    return nearest < support ? level_ * (2.0 - nearest / bridge_half_) : 0.0;
  }

  int exponent_;
  double level_;
  double unit_ = 1.0;
  double guard_radius_ = 0.0, guard_scale_ = 0.0;
  std::vector<KernelSlot> kernels_;  ///< the particles', then the mirror images'
  Grid grid_;
  std::vector<std::vector<std::size_t>> by_cell_;
  std::vector<std::size_t> every_;
  std::vector<Vec2> position_;
  std::vector<char> guarded_;            ///< per particle
  std::vector<std::size_t> guard_list_;  ///< the guarded particles
  std::vector<double> smallest_stretch_;
  std::vector<Vec2> bridge_a_, bridge_b_;
  double bridge_half_ = 0.0;
};

// Containment: the particles the contours leave outside. A particle in a fine cell that a
// contour crosses must lie left of (on the material side of) the cell's segment nearest to it;
// in a fine cell without one, the cell's corners (all of one sign) must be inside.
std::vector<std::size_t> particles_outside(const DetectedBoundary& boundary,
                                           const NodalField& nodes, std::span<const Vec2> positions,
                                           double level) {
  const std::vector<CellSegment> segments = segments_by_cell(boundary, nodes);
  std::vector<std::size_t> outside;
  for (std::size_t p = 0; p < positions.size(); ++p) {
    int i = 0, j = 0;
    if (!fine_cell(nodes, positions[p], i, j)) continue;
    const auto near = segments_in(segments, j * (nodes.n_x - 1) + i);
    const double corner = nodes.values[static_cast<std::size_t>(j) * nodes.n_x + i];
    if (near.empty() ? !(corner > level) : outside_nearest_segment(near, positions[p])) {
      outside.push_back(p);
    }
  }
  return outside;
}

}  // namespace

DetectedBoundary detect_improved_reference(const ParticleCloud& input, const Grid& grid,
                                           const ImprovedConfig& config,
                                           DetectionTimings& timings) {
  check_cloud(input);
  const auto start = std::chrono::steady_clock::now();
  const double h = grid.cell_size, spacing = input.initial_spacing;
  const std::size_t n = input.position.size();
  // The stretch cap (ImprovedConfig::max_stretch) on a copy of F and the volumes, and the bound
  // of the kernel weights (V / det F, from the volumes and F before the cap: the cap keeps
  // V' / det F' = V / det F).
  std::vector<Mat2> deformation(input.deformation_gradient.begin(),
                                input.deformation_gradient.end());
  std::vector<double> volume(input.volume.begin(), input.volume.end());
  double largest_volume = 0.0, smallest_det = 1.0;
  for (const double v : volume) largest_volume = std::max(largest_volume, v);
  if (!deformation.empty()) {
    smallest_det = std::numeric_limits<double>::infinity();
    for (const Mat2& f : deformation) smallest_det = std::min(smallest_det, f.determinant());
    if (config.max_stretch > 0.0) {
      cap_stretch(deformation, config.max_stretch, volume);
    }
  }
  ParticleCloud cloud{input.position, volume, deformation, spacing};
  // Kernel shapes from the neighbours (ImprovedConfig::neighbour_shape) only narrow: their
  // weights are at most 1 / (1 - beta) those of F.
  std::vector<Mat2> shaped;
  if (config.neighbour_shape > 0.0) {
    shaped = neighbour_shaped_deformation(cloud, config);
    cloud.deformation_gradient = shaped;
  }
  const double weight_bound =
      1.0 / (1.0 - config.neighbour_shape) *
      ImprovedField::weight_bound(config, spacing, largest_volume, smallest_det);
  Field field(cloud, config, grid, weight_bound);
  // The guards: every particle whose own phi is not above level + guard_margin.
  std::vector<std::size_t> low;
  for (std::size_t p = 0; p < n; ++p) {
    if (!(field.phi(input.position[p]) > config.level + config.guard_margin)) low.push_back(p);
  }
  field.add_guards(low);
  long evaluations = static_cast<long>(n), root_evaluations = 0, edge_points = 0;
  const auto evaluate = [&](const Vec2& x) {
    ++evaluations;
    return field(x);
  };
  // Contour passes: the first at refinement 4 (finer beyond 2 x 2 points per cell:
  // pass_refinement); then, if a particle lies outside the contours or an island touches other
  // material, one with bridges (join_spurious_loops) or with those particles guarded; then, if a
  // particle is still outside, one at the guards' refinement.
  DetectedBoundary boundary;
  std::optional<LoopClasses> classes;
  for (int pass = 0;; ++pass) {
    classes.reset();
    const int r = pass_refinement(config, pass, field.smallest_guard_axis(), h, spacing);
    timings.refinement = r;
    NodalField nodes;
    nodes.origin = grid.origin;
    nodes.spacing = h / r;
    nodes.n_x = grid.n_cells_x * r + 1;
    nodes.n_y = grid.n_cells_y * r + 1;
    nodes.values.resize(static_cast<std::size_t>(nodes.n_x) * nodes.n_y);
    for (int j = 0; j < nodes.n_y; ++j) {
      for (int i = 0; i < nodes.n_x; ++i) {
        nodes.values[static_cast<std::size_t>(j) * nodes.n_x + i] =
            evaluate(Vec2(nodes.origin.x() + static_cast<double>(i) * nodes.spacing,
                          nodes.origin.y() + static_cast<double>(j) * nodes.spacing));
      }
    }
    // Each crossing at Brent's root of the exact field along its edge, to root_tolerance cells.
    const auto root = [&](const Vec2& a, double value_a, const Vec2& b, double value_b) {
      const Vec2 d = b - a;
      const double t = brent_root([&](double s) { return field(a + s * d) - config.level; },
                                  value_a, value_b, config.root_tolerance * r, &root_evaluations);
      ++edge_points;
      return Vec2(a + t * d);
    };
    boundary = marching_squares(nodes, config.level, config.saddle_rule, root, evaluate);
    timings.processed_cells = static_cast<long>(nodes.n_x - 1) * (nodes.n_y - 1);
    const std::vector<std::size_t> left_out =
        particles_outside(boundary, nodes, input.position, config.level);
    const auto next =
        next_pass(config, pass, boundary, input.position, left_out, spacing, classes, timings);
    if (!next) break;
    timings.particles_guarded_after_contouring += static_cast<long>(field.add_guards(left_out));
    if (next->bridging) {
      field.add_bridges(left_out, next->pairs, h / r);
      timings.bridges = static_cast<long>(field.n_bridges());
    }
  }
  remove_unresolved_loops(config, boundary, input.position, spacing, classes, timings);
  if (config.curvature_correction) {
    correct_curvature(boundary,
                      kernel_curvature_moment(config.profile, config.radius_factor * spacing),
                      config.radius_factor * spacing);
  }
  timings.field_particles = static_cast<long>(n);
  timings.edge_point_count = edge_points;
  timings.root_evaluations = root_evaluations;
  timings.field_evaluations = evaluations + root_evaluations;
  timings.field = seconds_since(start);
  return boundary;
}

}  // namespace pfm::detail

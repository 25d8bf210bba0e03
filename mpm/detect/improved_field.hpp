// The improved detector's building blocks: its exact field (ImprovedField), the lattice its sweep
// takes, the thesis's Gaussian filter weights and the root finder of the edge points. Internals of
// mpm/detect/ (and of the tests and benchmarks that check them); the entry point is detector.hpp.
#pragma once

#include <array>
#include <functional>
#include <optional>
#include <span>
#include <vector>

#include "mpm/core/grid.hpp"
#include "mpm/core/particle_bins.hpp"
#include "mpm/core/types.hpp"
#include "mpm/detect/detector.hpp"
#include "mpm/detect/marching_squares.hpp"
#include "mpm/detect/vector_loops.hpp"

namespace pfm {

namespace detail {
/// The lattice of the grid's cells as the improved detector's sweep takes it.
inline CellLattice cell_lattice(const Grid& grid) {
  return {grid.origin.x(), grid.origin.y(), 1.0 / grid.cell_size, grid.n_cells_x, grid.n_cells_y};
}
}  // namespace detail

/// The improved detector's exact field max(phi, guard) at x (unit: volume fraction).
class ImprovedField {
 public:
  /// Tag of the constructor that leaves the guards undecided (see decide_guards()).
  struct DeferGuards {};
  /// A point's sum visits the bins kBinRings rings around its own; bins are the largest reach /
  /// kBinRings.
  static constexpr int kBinRings = 2;
  /// The fixed-point unit of a field that holds part of a cloud (the narrow band) comes from the
  /// whole cloud, so that its sums are bitwise those of a field holding every particle (the sums
  /// do not depend on the order of their terms, vector_loops.hpp).
  struct CloudBounds {
    /// Bound of the largest kernel weight V_p C_p of the whole cloud (weight_bound()).
    double weight_bound;
    /// Bound of the number of slots of the whole cloud (4 per particle: itself and up to three
    /// mirror images): the unit keeps the sum of all weights below 2^63.
    std::size_t slot_bound;
  };
  /// Kernel data by slot, one array per quantity, each padded with detail::kKernelPadding zeros
  /// (the sums read four slots at a time).
  struct KernelArrays {
    std::vector<double> x, y;                ///< centre, m
    std::vector<double> k00, k01, k10, k11;  ///< S^-1, 1/m
    std::vector<double> weight;              ///< V_p C_p x 2^fixed_point_bits()
    std::vector<double> half_x, half_y;      ///< half widths of the box around kernel and guard, m
    /// The slots whose guard is active, increasing: the guards are few, and a field evaluation
    /// visits only those among its slots instead of testing every slot.
    std::vector<int> guarded_slots;
    std::size_t size() const { return n_; }
    /// n slots (zeros, no guard), padding included.
    void assign_zeros(std::size_t n);
    /// The slots `slots` of `from`, in that order: the columns the sums read (x to weight) and
    /// the guarded ones among them, not the half widths, which are left empty.
    void gather(const KernelArrays& from, std::span<const int> slots);

   private:
    static constexpr std::size_t kSummedColumns = 7;  ///< x .. weight, first in columns()
    std::array<std::vector<double>*, 9> columns() {
      return {&x, &y, &k00, &k01, &k10, &k11, &weight, &half_x, &half_y};
    }
    std::array<const std::vector<double>*, 9> columns() const {
      return {&x, &y, &k00, &k01, &k10, &k11, &weight, &half_x, &half_y};
    }
    std::size_t n_ = 0;
  };

  /// `walls`: the field grid whose edges mirror the particles (ImprovedConfig::mirror_grid_edges);
  /// nullptr: none.
  ImprovedField(const ParticleCloud& cloud, const ImprovedConfig& config,
                const Grid* walls = nullptr);
  /// Which grid edges are walls (no particle beyond) and, in bins of one initial spacing along
  /// each, where a particle touches it (closer than a spacing): see mirror_grid_edges.
  struct WallContacts {
    bool wall[4] = {false, false, false, false};  ///< left, right, bottom, top
    std::vector<char> touched[4];
  };
  /// Reach of an undeformed particle, m: its kernel's (radius_factor x spacing) or its guard's
  /// support (sqrt 2 guard radius), whichever is larger; a particle with largest stretch s
  /// reaches s times as far.
  static double reference_reach(const ImprovedConfig& config, double initial_spacing);
  /// Reach of an undeformed particle's guard, m: sqrt 2 guard radius (0 without guards).
  static double reference_guard_reach(const ImprovedConfig& config, double initial_spacing);
  /// The contacts of the particles at `positions` (bounding box lo, hi) with the edges of `walls`:
  /// the bins of one `spacing` along each edge holding a particle closer to it than `distance`
  /// (m; 0: one spacing, the field's mirrors).
  static WallContacts find_wall_contacts(std::span<const Vec2> positions, const Vec2& lo,
                                         const Vec2& hi, const Grid& walls, double spacing,
                                         double distance = 0.0);
  /// Across which edges of `walls` a particle at x whose kernel and guard reach half_x, half_y
  /// (m) is mirrored: {0 left, 1 right or -1 none; 0 bottom, 1 top or -1 none}. Across a wall
  /// that the particle reaches, where the body touches it within half_along along it.
  static std::array<int, 2> mirror_sides(const WallContacts& contacts, const Grid& walls,
                                         const Vec2& x, double half_x, double half_y,
                                         double spacing);
  /// Trusts the cloud (detect() has checked it). `bounds`: nullptr = those of the cloud itself.
  /// `contacts`: nullptr = those of the cloud's own particles; the narrow band passes those of
  /// the whole cloud, of which it holds a part.
  ImprovedField(const ParticleCloud& cloud, const ImprovedConfig& config, DeferGuards,
                const Grid* walls = nullptr, const CloudBounds* bounds = nullptr,
                const WallContacts* contacts = nullptr);
  /// Guards the particles p with candidate[p] != 0 (all when empty) whose phi(x_p) is
  /// <= level + guard_margin; the narrow band passes the particles outside the interior cells.
  /// Call once, before evaluating the field.
  void decide_guards(std::span<const char> candidate);
  /// Switches the guard on for `particles` whatever their phi (the detector's second pass, for
  /// particles its first contours left outside).
  /// Returns how many were not guarded before.
  std::size_t add_guards(std::span<const std::size_t> particles);

  /// Bridges, for the detector's second pass: keeps the square of half side `cell` (m, the fine
  /// cell) around each particle of `points` in the material, and a strip of that half width along
  /// the segment between the two particles of each of `pairs`. The field is max(phi, guards,
  /// level (2 - d / (1.25 cell))), d the Chebyshev distance to the particle or segment: every
  /// fine node within `cell` of it is inside, so the four corners of the fine cell that holds the
  /// particle, or any point of the segment, are. Adds to the bridges already there.
  void add_bridges(std::span<const std::size_t> points,
                   std::span<const std::array<std::size_t, 2>> pairs, double cell);
  /// Number of bridges (points and segments).
  std::size_t n_bridges() const { return bridges_.a.size(); }

  double operator()(const Vec2& x) const;
  /// The slots (kernels and guards) whose support box meets the box lo..hi, copied into `out`:
  /// the terms of operator() at any point of the box that are not exact zeros.
  void slots_reaching(const Vec2& lo, const Vec2& hi, KernelArrays& out) const;
  /// operator() at x summed over `slots` only (from slots_reaching() for a box holding x):
  /// bitwise equal to operator(), without visiting the bins' other candidates.
  double operator()(const Vec2& x, const KernelArrays& slots) const;
  /// A bound of the largest kernel weight V_p C_p of particles with volume <= largest_volume
  /// and det F >= smallest_det (1 without F), as the constructor computes the weights.
  static double weight_bound(const ImprovedConfig& config, double initial_spacing,
                             double largest_volume, double smallest_det);
  /// s of the fixed-point unit 2^-s of the kernel sums (detail::kernel_sum()).
  int fixed_point_bits() const { return fixed_point_bits_; }
  /// max(guards, bridges) at x (0 without them): operator() is max(phi, this), so a value of
  /// operator() taken before guards or bridges were added becomes its value now by a maximum
  /// with it.
  double guards_and_bridges(const Vec2& x) const;
  /// phi alone (no guard), for studies.
  double volume_fraction(const Vec2& x) const;
  /// Whether volume_fraction(x) > threshold: the same answer, found from the bin rows nearest x
  /// first, stopping as soon as their partial sum exceeds the threshold (the terms are >= 0).
  bool volume_fraction_above(const Vec2& x, double threshold) const;
  /// Largest kernel or guard reach, m.
  double reach() const { return reach_; }
  /// Smallest guard semi-axis over the particles, m (infinity without guard).
  double smallest_guard_axis() const { return smallest_guard_axis_; }
  /// E[t^2 | n = 0] = a^2 / (2k + 3) of the reference kernel, m^2: a boundary of curvature kappa
  /// is found kappa * curvature_moment() / 2 inside the true one (= kappa a^2 / 10 for k = 1).
  double curvature_moment() const { return curvature_moment_; }
  std::span<const Vec2> positions() const { return position_; }
  std::span<const double> reaches() const { return particle_reach_; }
  /// Half widths of the axis-aligned box around particle p outside which it adds nothing (its
  /// guard included, whether active or not), m.
  Vec2 reach_box(std::size_t p) const { return reach_box_[p]; }
  bool guarded(std::size_t p) const { return guarded_[p] != 0; }
  /// Number of particles whose guard is active.
  std::size_t n_guarded() const { return n_guarded_; }
  /// Number of mirror images across the grid edges (see ImprovedConfig::mirror_grid_edges).
  std::size_t n_mirrored() const { return slot_.size() - position_.size(); }

 private:
  void switch_guard_on(std::size_t p);
  // Rebuilds slot_.guarded_slots from guarded_ (after guards were switched on).
  void list_guarded_slots();
  // The sum over the slot ranges [begin[r], end[r]) of `kernels` at x: phi (fixed point
  // converted back) and, with `guard`, max(phi, guard).
  double sum_ranges(const KernelArrays& kernels, const int* begin, const int* end, int n_ranges,
                    const Vec2& x, bool guard) const;
  // max(bridges, guards) at x (0 without them), the guards among the slots of those ranges.
  double raised_by(const KernelArrays& kernels, const int* begin, const int* end, int n_ranges,
                   const Vec2& x) const;
  double sum_at(const Vec2& x, bool guard) const;

  // The bridges of add_bridges(): segments a-b (a point: a == b), binned in squares of side bin
  // (each segment listed in every bin its support box meets).
  struct Bridges {
    std::vector<Vec2> a, b;
    double half = 0.0;  ///< Chebyshev half width of the part inside (1.25 fine cells), m
    Vec2 origin = Vec2::Zero();
    double bin = 0.0;
    int n_x = 0, n_y = 0;
    std::vector<int> start, item;  ///< bin k lists item[start[k] .. start[k + 1] - 1]
    /// The largest bridge value at x (0 outside every support), for contour level `level`.
    double value(const Vec2& x, double level) const;
  };
  Bridges bridges_;

  // Per particle, by particle index.
  std::vector<Vec2> position_;
  std::vector<char> guarded_;
  std::vector<Vec2> reach_box_;
  std::vector<double> particle_reach_;
  std::vector<double> kernel_reach_;      ///< largest kernel semi-axis, m
  std::vector<double> smallest_stretch_;  ///< smallest singular value of F
  // Per particle and mirror image in bin order (slot k holds bins_.particle_at(k); indices past
  // the particles are mirror images): what the evaluations read.
  KernelArrays slot_;
  int fixed_point_bits_ = 0;
  double fixed_point_unit_ = 1.0;  ///< 2^-fixed_point_bits_
  std::size_t n_guarded_ = 0;
  int exponent_ = 3;
  bool guard_ = true;
  double level_ = 0.5;
  double guard_margin_ = 0.02;
  double guard_radius_ = 0.0;  ///< rho0 = guard_factor * initial_spacing / 2, m
  double guard_scale_ = 0.0;   ///< a0 / rho0: the guard ellipse is the kernel's scaled by it
  double reach_ = 0.0;
  double smallest_guard_axis_ = 0.0;
  double curvature_moment_ = 0.0;
  int rings_ = kBinRings;  ///< bins searched around a point (bin size = reach / rings)
  ParticleBins bins_;
};

/// Weights of the thesis' discrete Gaussian filter (eq. 5.6-5.8): the normal density with standard
/// deviation sigma (in node spacings) integrated over each filter cell; size 0 takes n from
/// eq. 5.7.
std::vector<double> thesis_gaussian_weights(double sigma, int size);

/// Brent's method on [a, b] for a sign change of g (g(a) = value_a, g(b) = value_b); returns the
/// root parameter t in [0, 1] of x = a + t (b - a) to |dt| <= tolerance_t (an end where g is 0:
/// tolerance_t from it). Counts evaluations.
double brent_root(const std::function<double(double)>& g, double value_a, double value_b,
                  double tolerance_t, long* evaluations);

}  // namespace pfm

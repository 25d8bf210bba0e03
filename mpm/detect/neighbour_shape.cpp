// The improved detector's kernel shapes regularised by the neighbours' second moments
// (ImprovedConfig::neighbour_shape; README of mpm/detect, "Kernel shapes from the neighbours").
#include <algorithm>
#include <cmath>
#include <memory>
#include <vector>

#include "mpm/core/particle_bins.hpp"
#include "mpm/detect/detect_internal.hpp"
#include "mpm/detect/kernel.hpp"

namespace pfm::detail {

namespace {

// Particles per chunk on the threads (each visits some 30-80 neighbours).
constexpr std::size_t kShapeChunk = 1024;
// The neighbours narrow a kernel across an axis along which the fuller side of its window holds
// less than this fraction of a full window's second moment (a body about two particles thick or
// thinner: one row of particles gives 0, two rows and the middle of three 0.65 on a square
// lattice with the default radius), in proportion; they never widen it.
constexpr double kThinWindow = 0.5;

// Symmetric positive definite square root of a symmetric positive definite 2 x 2 matrix:
// sqrt(M) = (M + sqrt(det M) I) / sqrt(tr M + 2 sqrt(det M)).
Mat2 symmetric_square_root(const Mat2& m) {
  const double s = std::sqrt(m(0, 0) * m(1, 1) - m(0, 1) * m(1, 0));
  const double t = std::sqrt(m(0, 0) + m(1, 1) + 2.0 * s);
  Mat2 root;
  root << (m(0, 0) + s) / t, m(0, 1) / t, m(1, 0) / t, (m(1, 1) + s) / t;
  return root;
}

// A neighbour's reference offset u = F_p^-1 (x_j - x_p) / a0 in the unit window and its weight.
struct Neighbour {
  Vec2 u;
  double w;
};

}  // namespace

double neighbour_moment_of_unit_window(KernelProfile profile) {
  return kernel_window_moment(profile);
}

NeighbourSearch::NeighbourSearch(const ParticleCloud& cloud, double window_reach)
    : cloud_(cloud), bins_(std::make_unique<ParticleBins>(cloud.position, window_reach / 3.0)) {}

NeighbourSearch::~NeighbourSearch() = default;

WindowMoment neighbour_window_moment(const NeighbourSearch& search, const ImprovedConfig& config,
                                     const Vec2& x, const Mat2& f) {
  const ParticleCloud& cloud = search.cloud();
  const int k = kernel_exponent(config.profile);
  const double a0 = config.radius_factor * cloud.initial_spacing;
  const Mat2 to_unit = f.inverse() / a0;
  // The window's box: |x_j - x| <= a0 |row of F| in each axis.
  const double half_x = a0 * std::sqrt(f(0, 0) * f(0, 0) + f(0, 1) * f(0, 1));
  const double half_y = a0 * std::sqrt(f(1, 0) * f(1, 0) + f(1, 1) * f(1, 1));
  // One buffer per thread, kept between particles.
  thread_local std::vector<Neighbour> near;
  near.clear();
  double largest_volume = 0.0;
  const ParticleBins& bins = search.bins();
  bins.for_each_slot_in_box(x - Vec2(half_x, half_y), x + Vec2(half_x, half_y), [&](int slot) {
    const auto j = static_cast<std::size_t>(bins.particle_at(slot));
    const Vec2 u = to_unit * (cloud.position[j] - x);
    const double q = u.squaredNorm();
    if (!(q < 1.0)) return;
    double w = cloud.volume[j];
    largest_volume = std::max(largest_volume, w);
    for (int e = 0; e < k; ++e) w *= 1.0 - q;
    near.push_back({u, w});
  });
  // The sums are sums of integers, each term rounded to a multiple of a unit set by the window's
  // largest volume and number of neighbours (so that no sum can exceed 2^62 units: every term is
  // at most that volume): they do not depend on the order the bins visit the neighbours in, nor
  // on which bins hold them.
  int exponent = 0;
  std::frexp(largest_volume * static_cast<double>(near.size()), &exponent);
  // (Powers of two: the products are exact, as std::ldexp would be.)
  const double scale = std::ldexp(1.0, 62 - exponent), unit = std::ldexp(1.0, exponent - 62);
  const auto units = [scale](double term) { return std::llrint(term * scale); };
  const auto value = [unit](long long sum) { return static_cast<double>(sum) * unit; };
  long long m00 = 0, m01 = 0, m11 = 0;
  for (const Neighbour& n : near) {
    m00 += units(n.w * n.u.x() * n.u.x());
    m01 += units(n.w * n.u.x() * n.u.y());
    m11 += units(n.w * n.u.y() * n.u.y());
  }
  // The principal axes of the whole window's moment (x and y when it is diagonal).
  WindowMoment result;
  if (m01 != 0) {
    const double angle = 0.5 * std::atan2(2.0 * value(m01), value(m00) - value(m11));
    result.axis[0] = Vec2(std::cos(angle), std::sin(angle));
    result.axis[1] = Vec2(-result.axis[0].y(), result.axis[0].x());
  }
  // Along each axis the larger of the two sides' own moments: a free surface empties one side
  // of the window and leaves the other as full as deep inside; a body thinner than the window
  // empties both. Offsets within 1e-9 of the axis (the particle itself) count half on each side,
  // so that both sides have weight.
  for (int a = 0; a < 2; ++a) {
    const Vec2& e = result.axis[a];
    long long i_plus = 0, w_plus = 0, i_minus = 0, w_minus = 0;
    for (const Neighbour& n : near) {
      const double c = e.dot(n.u);
      if (c > 1e-9) {
        i_plus += units(n.w * c * c);
        w_plus += units(n.w);
      } else if (c < -1e-9) {
        i_minus += units(n.w * c * c);
        w_minus += units(n.w);
      } else {
        const long long i = units(0.5 * n.w * c * c), w = units(0.5 * n.w);
        i_plus += i;
        w_plus += w;
        i_minus += i;
        w_minus += w;
      }
    }
    result.moment[a] = std::max(value(i_plus) / value(w_plus), value(i_minus) / value(w_minus));
  }
  return result;
}

std::vector<Mat2> neighbour_shaped_deformation(const NeighbourSearch& search,
                                               const ParticleCloud& particles,
                                               const ImprovedConfig& config) {
  const std::size_t n = particles.position.size();
  std::vector<Mat2> shaped(n);
  const bool deformed = !particles.deformation_gradient.empty();
  const double beta = config.neighbour_shape;
  const double unit_moment = neighbour_moment_of_unit_window(config.profile);
  for_each_on_threads(n, kShapeChunk, [&](std::size_t p) {
    const Mat2 f = deformed ? particles.deformation_gradient[p] : Mat2::Identity();
    const WindowMoment window = neighbour_window_moment(search, config, particles.position[p], f);
    // B / a0^2 = F [(1 - beta) I + beta A] F^T, positive definite for beta < 1, with A = I where
    // the window is at least kThinWindow full across each axis and narrower where it is less.
    Mat2 across = Mat2::Zero();
    for (int a = 0; a < 2; ++a) {
      const double fullness = window.moment[a] / unit_moment;
      across += std::min(1.0, fullness / kThinWindow) * window.axis[a] * window.axis[a].transpose();
    }
    Mat2 b = f * ((1.0 - beta) * Mat2::Identity() + beta * across) * f.transpose();
    b(0, 1) = b(1, 0) = 0.5 * (b(0, 1) + b(1, 0));
    shaped[p] = symmetric_square_root(b);
  });
  return shaped;
}

std::vector<Mat2> neighbour_shaped_deformation(const ParticleCloud& cloud,
                                               const ImprovedConfig& config) {
  double stretch = cloud.deformation_gradient.empty() ? 1.0 : 0.0;
  for (const Mat2& f : cloud.deformation_gradient) {
    double largest = 0.0, smallest = 0.0;
    singular_values(f, largest, smallest);
    stretch = std::max(stretch, largest);
  }
  const NeighbourSearch search(cloud, config.radius_factor * cloud.initial_spacing * stretch);
  return neighbour_shaped_deformation(search, cloud, config);
}

}  // namespace pfm::detail

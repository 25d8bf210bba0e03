#include "mpm/core/particle_bins.hpp"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace pfm {

ParticleBins::ParticleBins(std::span<const Vec2> positions, double bin_size) : bin_size_(bin_size) {
  if (!(bin_size > 0.0) || !std::isfinite(bin_size)) {
    throw std::invalid_argument("ParticleBins: bin size must be finite and > 0");
  }
  if (positions.empty()) return;
  Vec2 lo = positions[0], hi = positions[0];
  for (const auto& p : positions) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  origin_ = lo;
  n_x_ = bin_i(hi.x()) + 1;
  n_y_ = bin_j(hi.y()) + 1;
  start_.assign(static_cast<std::size_t>(n_x_) * n_y_ + 1, 0);
  std::vector<int> bin_of(positions.size());
  for (std::size_t p = 0; p < positions.size(); ++p) {
    const int i = std::clamp(bin_i(positions[p].x()), 0, n_x_ - 1);
    const int j = std::clamp(bin_j(positions[p].y()), 0, n_y_ - 1);
    bin_of[p] = j * n_x_ + i;
    ++start_[bin_of[p] + 1];
  }
  for (std::size_t b = 1; b < start_.size(); ++b) start_[b] += start_[b - 1];
  particle_.resize(positions.size());
  std::vector<int> cursor(start_.begin(), start_.end() - 1);
  slot_.resize(positions.size());
  for (std::size_t p = 0; p < positions.size(); ++p) {
    slot_[p] = cursor[bin_of[p]];
    particle_[cursor[bin_of[p]]++] = static_cast<int>(p);
  }
}

}  // namespace pfm

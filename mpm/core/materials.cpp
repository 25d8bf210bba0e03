#include "mpm/core/materials.hpp"

#include <algorithm>

namespace pfm {

double PiecewiseLinear::value(double at) const {
  if (at <= x.front()) return y.front();
  if (at >= x.back()) return y.back();
  const auto k = static_cast<std::size_t>(std::upper_bound(x.begin(), x.end(), at) - x.begin());
  const double t = (at - x[k - 1]) / (x[k] - x[k - 1]);
  return y[k - 1] + t * (y[k] - y[k - 1]);
}

double PiecewiseLinear::slope(double at) const {
  if (at < x.front() || at >= x.back()) return 0.0;
  const auto k = static_cast<std::size_t>(std::upper_bound(x.begin(), x.end(), at) - x.begin());
  return (y[k] - y[k - 1]) / (x[k] - x[k - 1]);
}

Stress elastic_stress_increment(const ElasticParameters& elastic, const Strain& d) {
  const double lambda = elastic.lame_lambda();
  const double mu = elastic.shear_modulus();
  const double volumetric = d[kXX] + d[kYY] + d[kZZ];
  return Stress(lambda * volumetric + 2.0 * mu * d[kXX], lambda * volumetric + 2.0 * mu * d[kYY],
                mu * d[kXY], lambda * volumetric + 2.0 * mu * d[kZZ]);
}

void LinearElastic::update(const Strain& strain_increment, Stress& stress, PointState&) const {
  stress += elastic_stress_increment(elastic, strain_increment);
}

const ElasticParameters& elastic_parameters(const Material& material) {
  return std::visit([](const auto& m) -> const ElasticParameters& { return m.elastic; }, material);
}

}  // namespace pfm

#include "mpm/boundary/gauss_quadrature.hpp"

#include <numbers>
#include <stdexcept>
#include <string>

namespace pfm::boundary {

GaussRule gauss_legendre(int k) {
  if (k < 1 || k > kMaxGaussPoints) {
    throw std::invalid_argument("gauss_legendre: k = " + std::to_string(k) + " not in [1, " +
                                std::to_string(kMaxGaussPoints) + "]");
  }
  GaussRule rule;
  rule.n_points = k;
  // The nodes are symmetric; find the non-negative ones from Chebyshev-like initial guesses.
  for (int i = 0; i < (k + 1) / 2; ++i) {
    double x = std::cos(std::numbers::pi * (i + 0.75) / (k + 0.5));
    double derivative = 1.0;
    for (int iteration = 0; iteration < 100; ++iteration) {
      // Legendre recurrence: (n + 1) P_n+1 = (2n + 1) x P_n - n P_n-1.
      double p_previous = 1.0, p = x;
      for (int n = 1; n < k; ++n) {
        const double p_next = ((2.0 * n + 1.0) * x * p - n * p_previous) / (n + 1.0);
        p_previous = p;
        p = p_next;
      }
      if (k == 1) p_previous = 1.0, p = x;
      derivative = k * (x * p - p_previous) / (x * x - 1.0);
      const double step = p / derivative;
      x -= step;
      if (std::abs(step) < 1e-16) break;
    }
    // Recompute the derivative at the converged node for the weight.
    {
      double p_previous = 1.0, p = x;
      for (int n = 1; n < k; ++n) {
        const double p_next = ((2.0 * n + 1.0) * x * p - n * p_previous) / (n + 1.0);
        p_previous = p;
        p = p_next;
      }
      if (k == 1) p_previous = 1.0, p = x;
      derivative = k * (x * p - p_previous) / (x * x - 1.0);
    }
    const double weight = 2.0 / ((1.0 - x * x) * derivative * derivative);
    rule.node[i] = -x;
    rule.weight[i] = weight;
    rule.node[k - 1 - i] = x;
    rule.weight[k - 1 - i] = weight;
  }
  if (k % 2 == 1) rule.node[k / 2] = 0.0;  // exact zero at the centre
  return rule;
}

}  // namespace pfm::boundary

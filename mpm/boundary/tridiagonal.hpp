// Tridiagonal solvers for the C2 middle control points of composite cubic Bezier curves
// (thesis eq. 4.3 with 4.4 or 4.5, reduced to one unknown per segment in bezier.cpp).
//
// * solve_tridiagonal: Thomas algorithm (no pivoting; the [1 4 1] systems of bezier.cpp are
//   strictly diagonally dominant, so it is stable).
// * solve_cyclic_tridiagonal: the periodic system of a closed curve, by the Sherman-Morrison
//   formula around two Thomas solves (needs n >= 3).
// The right-hand side may be any vector-space type T (double, Vec2 ...).
#pragma once

#include <cstddef>
#include <stdexcept>
#include <vector>

namespace pfm::boundary {

/// Solves the n x n system  lower[i] x[i-1] + diag[i] x[i] + upper[i] x[i+1] = rhs[i]
/// (lower[0] and upper[n-1] are ignored). All arrays have size n >= 1.
template <class T>
std::vector<T> solve_tridiagonal(const std::vector<double>& lower, const std::vector<double>& diag,
                                 const std::vector<double>& upper, const std::vector<T>& rhs) {
  const std::size_t n = diag.size();
  if (n == 0 || lower.size() != n || upper.size() != n || rhs.size() != n) {
    throw std::invalid_argument("solve_tridiagonal: inconsistent sizes");
  }
  std::vector<double> upper_prime(n);
  std::vector<T> solution(n);
  // Forward sweep: eliminate the sub-diagonal.
  double pivot = diag[0];
  upper_prime[0] = upper[0] / pivot;
  solution[0] = rhs[0] / pivot;
  for (std::size_t i = 1; i < n; ++i) {
    pivot = diag[i] - lower[i] * upper_prime[i - 1];
    upper_prime[i] = upper[i] / pivot;
    solution[i] = (rhs[i] - lower[i] * solution[i - 1]) / pivot;
  }
  // Back substitution.
  for (std::size_t i = n - 1; i-- > 0;)
    solution[i] = solution[i] - upper_prime[i] * solution[i + 1];
  return solution;
}

/// Solves the periodic system  lower[i] x[i-1] + diag[i] x[i] + upper[i] x[i+1] = rhs[i] with
/// indices modulo n (lower[0] couples x[n-1], upper[n-1] couples x[0]), n >= 3.
/// Sherman-Morrison: A = T + u v^T with u = (gamma, 0, ..., 0, lower[0]),
/// v = (1, 0, ..., 0, upper[n-1] / gamma), gamma = -diag[0].
template <class T>
std::vector<T> solve_cyclic_tridiagonal(const std::vector<double>& lower,
                                        const std::vector<double>& diag,
                                        const std::vector<double>& upper,
                                        const std::vector<T>& rhs) {
  const std::size_t n = diag.size();
  if (n < 3) throw std::invalid_argument("solve_cyclic_tridiagonal: needs n >= 3");
  const double corner_bottom_left = upper[n - 1];  // A(n-1, 0)
  const double corner_top_right = lower[0];        // A(0, n-1)
  const double gamma = -diag[0];
  std::vector<double> modified_diag = diag;
  modified_diag[0] = diag[0] - gamma;
  modified_diag[n - 1] = diag[n - 1] - corner_bottom_left * corner_top_right / gamma;
  std::vector<double> u(n, 0.0);
  u[0] = gamma;
  u[n - 1] = corner_bottom_left;
  const std::vector<T> x = solve_tridiagonal(lower, modified_diag, upper, rhs);
  const std::vector<double> z = solve_tridiagonal(lower, modified_diag, upper, u);
  // v = (1, 0, ..., 0, corner_top_right / gamma).
  const double v_last = corner_top_right / gamma;
  const T factor = (x[0] + v_last * x[n - 1]) / (1.0 + z[0] + v_last * z[n - 1]);
  std::vector<T> solution(n);
  for (std::size_t i = 0; i < n; ++i) solution[i] = x[i] - z[i] * factor;
  return solution;
}

}  // namespace pfm::boundary

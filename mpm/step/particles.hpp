// Material points stored as arrays per field (structure of arrays). Index p is the particle's
// id: ids are assigned in creation order and never change.
#pragma once

#include <span>
#include <vector>

#include "mpm/core/materials.hpp"
#include "mpm/core/types.hpp"

namespace pfm {

struct Particles {
  std::vector<Vec2> position;            ///< m
  std::vector<Vec2> reference_position;  ///< m, displacement = position - reference_position
  std::vector<Vec2> velocity;            ///< m/s
  std::vector<double> mass;              ///< t
  std::vector<double> volume;            ///< current volume per unit thickness, m^2
  std::vector<double> initial_volume;    ///< m^2
  std::vector<Vec2> half_length;         ///< initial half size of the particle domain (uGIMP), m
  std::vector<Stress> stress;            ///< kPa, (xx, yy, xy, zz), tension positive
  std::vector<PointState> state;         ///< equivalent plastic strain and friends
  std::vector<Mat2> deformation_gradient;
  std::vector<int> material;  ///< index into Case::materials
  std::vector<int> body;      ///< index into Case::bodies

  std::size_t size() const { return position.size(); }
  void reserve(std::size_t n);
  /// Append one particle at rest with zero stress.
  void add(const Vec2& x, double particle_volume, double density, const Vec2& half_size,
           int material_index, int body_index);
};

/// The largest initial density of the particles, mass / initial volume (t/m^3): x h^2, the mass
/// of a full cell of the densest material, the scale of "too light to carry a load".
double largest_density(const Particles& particles);

/// The names of the recovered stress components (outputs), and a particle's recovered stress
/// (its own when `recovered` is empty; mpm/core/stress_recovery.hpp).
inline constexpr const char* kRecoveredStressNames[4] = {"sxx_rec", "syy_rec", "sxy_rec",
                                                         "szz_rec"};
inline const Stress& recovered_or_own(std::span<const Stress> recovered, const Particles& particles,
                                      std::size_t p) {
  return recovered.empty() ? particles.stress[p] : recovered[p];
}

}  // namespace pfm

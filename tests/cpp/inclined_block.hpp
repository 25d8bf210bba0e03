// The shipped inclined block's closed form (cases/constraint_inclined_block.json: a 1 m square
// turned 30 degrees to the grid, one face pushed in 0.01 m, the three others held at zero normal
// displacement), for the explicit and the implicit constraint tests: uniaxial strain ln(0.99)
// along the face's normal n (the solvers' rate form integrates the stretching, so small strain's
// -0.01 would read the exact answer as 0.5 % off).
#pragma once

#include <algorithm>
#include <cmath>
#include <numbers>
#include <vector>

#include "mpm/core/materials.hpp"
#include "mpm/step/energy_ledger.hpp"
#include "mpm/step/particles.hpp"

namespace pfm::inclined_block {

/// The measures of a run against the closed form, each relative (value / exact - 1).
struct Errors {
  double interior_nn = 0.0;  ///< mean sigma_nn of the interior points
  double interior_tt = 0.0;  ///< the same for sigma_tt
  double worst_point = 0.0;  ///< largest |sigma_nn / exact - 1| over the interior points
  double reaction = 0.0;     ///< force on the pushed face . (-n)
  double opposite = 0.0;     ///< force on the opposite face . n
  int interior_points = 0;   ///< within 0.3 m of the centre along n and t
};

inline Errors measure(const Particles& p, const ElasticParameters& e,
                      const std::vector<ConstraintReport>& reports) {
  const double strain = std::log(1.0 - 0.01);
  const double exact_nn = e.constrained_modulus() * strain, exact_tt = e.lame_lambda() * strain;
  const double angle = std::numbers::pi / 6.0;
  const Vec2 n(std::cos(angle), std::sin(angle)), t(-std::sin(angle), std::cos(angle));
  const Vec2 centre(1.5, 1.5);
  double sum_nn = 0.0, sum_tt = 0.0;
  Errors r;
  for (std::size_t k = 0; k < p.size(); ++k) {
    const Vec2 d = p.position[k] - centre;
    if (std::abs(d.dot(n)) > 0.3 || std::abs(d.dot(t)) > 0.3) continue;  // the interior
    const Stress& s = p.stress[k];
    const Mat2 sigma = (Mat2() << s[kXX], s[kXY], s[kXY], s[kYY]).finished();
    const double nn = n.dot(sigma * n), tt = t.dot(sigma * t);
    sum_nn += nn;
    sum_tt += tt;
    r.worst_point = std::max(r.worst_point, std::abs(nn / exact_nn - 1.0));
    ++r.interior_points;
  }
  r.interior_nn = sum_nn / r.interior_points / exact_nn - 1.0;
  r.interior_tt = sum_tt / r.interior_points / exact_tt - 1.0;
  const double face_force = std::abs(exact_nn) * 1.0;  // kN/m on the 1 m face
  r.reaction = reports[0].force.dot(-n) / face_force - 1.0;
  r.opposite = reports[1].force.dot(n) / face_force - 1.0;
  return r;
}

}  // namespace pfm::inclined_block

// Internal interfaces between detector.cpp and the detector implementations.
#pragma once

#include <omp.h>

#include <algorithm>
#include <chrono>
#include <cstddef>

#include "mpm/detect/detector.hpp"

namespace pfm::detail {

DetectedBoundary detect_improved(const ParticleCloud& cloud, const Grid& grid,
                                 const ImprovedConfig& config, DetectionTimings& timings);

DetectedBoundary detect_thesis_pfm(const ParticleCloud& cloud, const Grid& grid,
                                   const ThesisPfmConfig& config, DetectorState& state,
                                   DetectionTimings& timings);

/// Baselines (mpm/detect/baselines/).
DetectedBoundary detect_surface_markers(const ParticleCloud& cloud, const Grid& grid,
                                        const DetectorConfig& config, DetectorState& state,
                                        DetectionTimings& timings);
DetectedBoundary detect_volume_of_fluid(const ParticleCloud& cloud, const Grid& grid,
                                        const VofConfig& config, DetectionTimings& timings);
DetectedBoundary detect_cell_density(const ParticleCloud& cloud, const Grid& grid,
                                     const DensityConfig& config, DetectionTimings& timings);

/// body(k) for every k < n, by chunks of `chunk` on the OpenMP threads (a single chunk runs on the
/// calling thread). Each body(k) may write only its own places: then the result does not depend
/// on the thread count. It must not throw (an exception cannot leave an OpenMP region): input is
/// checked before.
template <class Body>
void for_each_on_threads(std::size_t n, std::size_t chunk, const Body& body) {
  const std::size_t n_chunks = (n + chunk - 1) / chunk;
  if (n_chunks <= 1 || omp_get_max_threads() == 1) {  // no team (a team of one still costs)
    for (std::size_t k = 0; k < n; ++k) body(k);
    return;
  }
#pragma omp parallel for schedule(dynamic, 1)
  for (std::size_t c = 0; c < n_chunks; ++c) {
    const std::size_t end = std::min(n, (c + 1) * chunk);
    for (std::size_t k = c * chunk; k < end; ++k) body(k);
  }
}

/// Seconds since `start`.
inline double seconds_since(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

/// Largest and smallest singular values of a 2 x 2 matrix (closed form).
inline void singular_values(const Mat2& m, double& largest, double& smallest) {
  const double e = 0.5 * (m(0, 0) + m(1, 1)), f = 0.5 * (m(0, 0) - m(1, 1));
  const double g = 0.5 * (m(1, 0) + m(0, 1)), h = 0.5 * (m(1, 0) - m(0, 1));
  const double q = std::sqrt(e * e + h * h), r = std::sqrt(f * f + g * g);
  largest = q + r;
  smallest = std::abs(q - r);
}

/// Validates the cloud's spans and spacing and every particle (InputError naming the field).
void check_cloud(const ParticleCloud& cloud);
/// The spans and the spacing only.
void check_cloud_shape(const ParticleCloud& cloud);
/// Particle p: finite position, volume > 0, finite F with det F > 0 (InputError naming it).
void check_particle(const ParticleCloud& cloud, std::size_t p);

}  // namespace pfm::detail

// The materials' stress update per call (ns), in the regimes a step meets: an elastic
// increment inside the yield surface and a plastic one on it, for Tresca and Mohr-Coulomb with
// the thesis's softening cohesion (20, 10, 5 kPa at eps_p 0, 0.01, 0.03) and for linear
// elasticity (E = 1e4 kPa, nu = 0.25). Each iteration runs 1,024 updates from the same state
// (the regime stays the same): "Time" / 1024 is the time per call, items_per_second the calls
// per second.
//
// Sample run:  build/bin/pfm-bench --benchmark_filter=MaterialUpdate
#include <benchmark/benchmark.h>

#include <array>
#include <string>

#include "mpm/core/materials.hpp"

namespace {

using pfm::PointState;
using pfm::Strain;
using pfm::Stress;

constexpr int kUpdates = 1024;

template <class Model>
void time_updates(benchmark::State& state, const Model& model, const Strain& increment,
                  const Stress& start, double plastic_strain) {
  for (auto _ : state) {
    Stress stress = start;
    PointState point{plastic_strain};
    for (int k = 0; k < kUpdates; ++k) model.update(increment, stress, point);
    benchmark::DoNotOptimize(stress);
  }
  state.SetItemsProcessed(state.iterations() * kUpdates);
}

// range(0): 0 Tresca elastic, 1 Tresca plastic, 2 Mohr-Coulomb elastic, 3 Mohr-Coulomb
// plastic, 4 linear elastic.
void BM_MaterialUpdate(benchmark::State& state) {
  const pfm::ElasticParameters elastic{1e4, 0.25};
  const pfm::PiecewiseLinear cohesion{{0.0, 0.01, 0.03}, {20.0, 10.0, 5.0}};
  const pfm::Tresca tresca{elastic, cohesion};
  const pfm::MohrCoulomb mohr_coulomb{elastic, cohesion, 30.0, 10.0, 5.0};
  const Strain tiny(1e-9, -1e-9, 1e-9, 0.0), shear(0.0, 0.0, 1e-4, 0.0);
  const Stress pure_shear(0.0, 0.0, 19.0, 0.0), compressed(-50.0, -60.0, 5.0, -55.0);
  static const std::array<const char*, 5> labels = {"Tresca elastic", "Tresca plastic",
                                                    "Mohr-Coulomb elastic", "Mohr-Coulomb plastic",
                                                    "linear elastic"};
  // An elastic increment from a compressed state, or a plastic one in pure shear.
  const auto time = [&](const auto& model, bool plastic) {
    time_updates(state, model, plastic ? shear : tiny, plastic ? pure_shear : compressed,
                 plastic ? 0.02 : 0.0);
  };
  const auto regime = state.range(0);
  if (regime < 2) {
    time(tresca, regime == 1);
  } else if (regime < 4) {
    time(mohr_coulomb, regime == 3);
  } else {
    time(pfm::LinearElastic{elastic}, false);
  }
  state.SetLabel(labels[static_cast<std::size_t>(state.range(0))]);
}
BENCHMARK(BM_MaterialUpdate)->DenseRange(0, 4);

}  // namespace

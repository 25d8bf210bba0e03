// The case reader's material laws: the softening length (materials[].softening_length) scales
// the cohesion law's plastic strains by length / cell size, and leaves the cohesions alone; the
// anti-locking default follows the materials' Poisson ratios.
#include <gtest/gtest.h>

#include <variant>

#include "mpm/core/json_input.hpp"
#include "mpm/step/case.hpp"

namespace pfm {
namespace {

Case block_with(const nlohmann::json& material, double cell_size) {
  nlohmann::json j = nlohmann::json::parse(R"({
    "grid": {"origin": [0, 0], "n_cells": [8, 8]},
    "bodies": [{"name": "block", "material": "soil", "rectangle": [[0, 0], [2, 2]]}],
    "time": {"end_time": 1.0}
  })");
  j["grid"]["cell_size"] = cell_size;
  j["materials"] = nlohmann::json::array({material});
  return parse_case(j, "block");
}

PiecewiseLinear cohesion_of(const Case& c) {
  if (const auto* t = std::get_if<Tresca>(&c.materials[0].model)) return t->cohesion;
  return std::get<MohrCoulomb>(c.materials[0].model).cohesion;
}

// A law given for a band of L = 1 m on cells of h = 0.5 m softens over twice the plastic
// strain (the band is half as wide); on cells of h = L it is the law as given.
TEST(CaseMaterials, SofteningLengthScalesThePlasticStrainsByLengthOverCellSize) {
  for (const char* model : {"tresca", "mohr_coulomb"}) {
    SCOPED_TRACE(model);
    nlohmann::json material = nlohmann::json::parse(R"({
      "name": "soil", "youngs_modulus": 1000.0, "poisson_ratio": 0.3, "unit_weight": 20.0,
      "cohesion": {"initial": 20.0, "peak": 10.0, "residual": 5.0,
                   "peak_plastic_strain": 0.05, "residual_plastic_strain": 0.25},
      "softening_length": 1.0
    })");
    material["model"] = model;
    if (std::string(model) == "mohr_coulomb") material["friction_angle"] = 20.0;
    const PiecewiseLinear scaled = cohesion_of(block_with(material, 0.5));
    EXPECT_EQ(scaled.x, (std::vector<double>{0.0, 0.1, 0.5}));
    EXPECT_EQ(scaled.y, (std::vector<double>{20.0, 10.0, 5.0}));
    const PiecewiseLinear as_given = cohesion_of(block_with(material, 1.0));
    EXPECT_EQ(as_given.x, (std::vector<double>{0.0, 0.05, 0.25}));
    material.erase("softening_length");
    EXPECT_EQ(cohesion_of(block_with(material, 0.5)).x, (std::vector<double>{0.0, 0.05, 0.25}));
  }
}

// solver.anti_locking defaults to the mean dilatation where a material is nearly incompressible
// (nu >= 0.45) and to none otherwise; a case that names it keeps its choice.
TEST(CaseMaterials, AntiLockingDefaultsToTheMeanDilatationForNearlyIncompressibleSoil) {
  nlohmann::json material = nlohmann::json::parse(R"({
    "name": "soil", "model": "linear_elastic", "youngs_modulus": 1000.0, "unit_weight": 20.0
  })");
  for (const double nu : {0.3, 0.449, 0.45, 0.49}) {
    SCOPED_TRACE(nu);
    material["poisson_ratio"] = nu;
    EXPECT_EQ(block_with(material, 0.5).solver.mean_dilatation, nu >= kBbarPoissonRatio);
  }
  nlohmann::json j = nlohmann::json::parse(R"({
    "grid": {"origin": [0, 0], "n_cells": [8, 8], "cell_size": 0.5},
    "bodies": [{"name": "block", "material": "soil", "rectangle": [[0, 0], [2, 2]]}],
    "time": {"end_time": 1.0}, "solver": {"anti_locking": "none"}
  })");
  j["materials"] = nlohmann::json::array({material});
  EXPECT_FALSE(parse_case(j, "block").solver.mean_dilatation);
  material["poisson_ratio"] = 0.3;
  j["materials"] = nlohmann::json::array({material});
  j["solver"]["anti_locking"] = "bbar";
  EXPECT_TRUE(parse_case(j, "block").solver.mean_dilatation);
}

}  // namespace
}  // namespace pfm

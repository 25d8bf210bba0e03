// Configuration of the baselines ("smm", "vof", "density"): keys, defaults and errors with the
// JSON pointer; and the `detect` command running each of them.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "mpm/core/json_input.hpp"
#include "mpm/detect/detect_command.hpp"
#include "mpm/detect/detector.hpp"

namespace pfm {
namespace {

DetectorConfig parse(const std::string& text) {
  const auto json = nlohmann::json::parse(text);
  return parse_detector_config(JsonView(json, "cfg.json"));
}

void expect_error(const std::string& text, const std::string& expected) {
  try {
    parse(text);
    ADD_FAILURE() << text << ": no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << e.what();
  }
}

TEST(BaselineConfig, DefaultsAndKeys) {
  const DetectorConfig d = parse("{}");
  EXPECT_EQ(d.smm.marker_spacing, 0.5);
  EXPECT_EQ(d.smm.initial_contour, DetectorMethod::kImproved);
  EXPECT_EQ(d.smm.massless_nodes, MasslessNodes::kRenormalise);
  EXPECT_EQ(d.vof.refinement, 1);
  EXPECT_EQ(d.vof.fraction, VofFraction::kCount);
  EXPECT_EQ(d.vof.mixed_tolerance, 1e-9);
  EXPECT_EQ(d.density.field, DensityField::kNodal);
  EXPECT_EQ(d.density.threshold, 0.5);
  EXPECT_EQ(d.density.refinement, 1);
  const DetectorConfig c = parse(R"({"method": "smm",
      "smm": {"marker_spacing": 0.25, "initial_contour": "pfm", "massless_nodes": "zero"},
      "vof": {"refinement": 2, "fraction": "volume", "mixed_tolerance": 1e-6},
      "density": {"field": "cell", "threshold": 0.7, "refinement": 3}})");
  EXPECT_EQ(c.method, DetectorMethod::kSmm);
  EXPECT_EQ(c.smm.marker_spacing, 0.25);
  EXPECT_EQ(c.smm.initial_contour, DetectorMethod::kPfm);
  EXPECT_EQ(c.smm.massless_nodes, MasslessNodes::kZero);
  EXPECT_EQ(c.vof.refinement, 2);
  EXPECT_EQ(c.vof.fraction, VofFraction::kVolume);
  EXPECT_EQ(c.vof.mixed_tolerance, 1e-6);
  EXPECT_EQ(c.density.field, DensityField::kCell);
  EXPECT_EQ(c.density.threshold, 0.7);
  EXPECT_EQ(c.density.refinement, 3);
  EXPECT_EQ(parse(R"({"method": "vof"})").method, DetectorMethod::kVof);
  EXPECT_EQ(parse(R"({"method": "density"})").method, DetectorMethod::kDensity);
}

TEST(BaselineConfig, UnknownKeysAndBadValuesNameThePointer) {
  expect_error(R"({"smm": {"spacing": 1}})", "cfg.json: /smm/spacing: unknown key");
  expect_error(R"({"vof": {"normal": "sobel"}})", "cfg.json: /vof/normal: unknown key");
  expect_error(R"({"density": {"level": 0.5}})", "cfg.json: /density/level: unknown key");
  expect_error(R"({"smm": {"marker_spacing": 0}})", "cfg.json: /smm/marker_spacing");
  expect_error(R"({"smm": {"initial_contour": "vof"}})", "cfg.json: /smm/initial_contour");
  expect_error(R"({"smm": {"massless_nodes": "ignore"}})", "cfg.json: /smm/massless_nodes");
  expect_error(R"({"vof": {"refinement": 0}})", "cfg.json: /vof/refinement");
  expect_error(R"({"vof": {"fraction": "mass"}})", "cfg.json: /vof/fraction");
  expect_error(R"({"density": {"threshold": 1.5}})", "cfg.json: /density/threshold");
  expect_error(R"({"density": {"field": "particle"}})", "cfg.json: /density/field");
  expect_error(R"({"vof": 3})", "cfg.json: /vof");
}

namespace fs = std::filesystem;

TEST(BaselineConfig, DetectCommandRunsEveryBaseline) {
  std::ostringstream csv;
  csv << "x,y,volume\n";
  for (int j = 0; j < 8; ++j) {
    for (int i = 0; i < 12; ++i) csv << 2.125 + 0.25 * i << "," << 2.125 + 0.25 * j << ",0.0625\n";
  }
  const fs::path dir = fs::path(PFM_BINARY_DIR) / "test_baseline_config";
  fs::remove_all(dir);
  fs::create_directories(dir);
  std::ofstream(dir / "p.csv") << csv.str();
  for (const std::string method : {"smm", "vof", "density"}) {
    std::ofstream(dir / "c.json") << R"({"method": ")" << method << R"(", "initial_spacing": 0.25,
        "grid": {"origin": [0, 0], "cell_size": 0.5, "n_cells": [14, 12]}})";
    const fs::path out = dir / method;
    ASSERT_EQ(run_detect_command((dir / "p.csv").string(), (dir / "c.json").string(), out.string()),
              0);
    const auto summary = read_json_file((out / "summary.json").string());
    EXPECT_EQ(summary["method"], method);
    EXPECT_EQ(summary["loops"], 1);
    EXPECT_EQ(summary["closed"], 1);
    // The block [2, 5] x [2, 4]: every boundary point within a quarter cell of its faces.
    std::ifstream in(out / "boundary.csv");
    std::string line;
    std::getline(in, line);
    EXPECT_EQ(line, "loop,x,y");
    int rows = 0;
    while (std::getline(in, line)) {
      double loop = 0, x = 0, y = 0;
      char c1 = 0, c2 = 0;
      std::istringstream(line) >> loop >> c1 >> x >> c2 >> y;
      const double outside = std::max(std::max(2.0 - x, x - 5.0), std::max(2.0 - y, y - 4.0));
      const double inside = std::min(std::min(x - 2.0, 5.0 - x), std::min(y - 2.0, 4.0 - y));
      EXPECT_LE(std::max(outside, -inside), 0.125 + 1e-9) << method << ": " << line;
      ++rows;
    }
    EXPECT_EQ(summary["points_per_loop"][0], rows);
  }
}

}  // namespace
}  // namespace pfm

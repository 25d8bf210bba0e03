// `detect` command: particle CSV in, boundary.csv and summary.json out; bad input names file,
// line and column, and leaves no output directory behind.
#include <gtest/gtest.h>
#include <omp.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <nlohmann/json.hpp>
#include <sstream>

#include "mpm/core/json_input.hpp"
#include "mpm/detect/detect_command.hpp"

namespace pfm {
namespace {

namespace fs = std::filesystem;

fs::path scratch(const std::string& name) {
  const fs::path dir = fs::path(PFM_BINARY_DIR) / "test_detect_command" / name;
  fs::remove_all(dir);
  fs::create_directories(dir);
  return dir;
}

void write(const fs::path& p, const std::string& text) {
  std::ofstream(p) << text;
}

// A block of nx x ny points 0.25 m apart from (2, 2) m.
std::string block_csv(bool with_f, int nx = 12, int ny = 8) {
  std::ostringstream s;
  s << "id,x,y,volume" << (with_f ? ",F11,F12,F21,F22" : "") << "\n";
  int id = 0;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      s << id++ << "," << 2.125 + 0.25 * i << "," << 2.125 + 0.25 * j << ",0.0625";
      if (with_f) s << ",1,0,0,1";
      s << "\n";
    }
  }
  return s.str();
}

TEST(DetectCommand, WritesBoundaryAndSummary) {
  const auto dir = scratch("ok");
  write(dir / "p.csv", block_csv(true));
  write(dir / "c.json", R"({"method": "improved", "initial_spacing": 0.25,
                            "grid": {"origin": [0, 0], "cell_size": 0.5, "n_cells": [14, 12]}})");
  ASSERT_EQ(run_detect_command((dir / "p.csv").string(), (dir / "c.json").string(),
                               (dir / "out").string()),
            0);
  std::ifstream csv(dir / "out" / "boundary.csv");
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "loop,x,y");
  int rows = 0;
  double max_x = -1e300;
  while (std::getline(csv, line)) {
    ++rows;
    double loop, x, y;
    char c1, c2;
    std::istringstream(line) >> loop >> c1 >> x >> c2 >> y;
    EXPECT_EQ(loop, 0);
    max_x = std::max(max_x, x);
  }
  EXPECT_GT(rows, 20);
  EXPECT_NEAR(max_x, 5.0, 0.02 * 0.5);  // the block's right face at x = 5 m
  const auto summary = read_json_file((dir / "out" / "summary.json").string());
  EXPECT_EQ(summary["loops"], 1);
  EXPECT_EQ(summary["closed"], 1);
  EXPECT_EQ(summary["open"], 0);
  EXPECT_EQ(summary["points_per_loop"][0], rows);
  EXPECT_TRUE(summary["timings_s"].contains("field"));
  EXPECT_FALSE(fs::exists(dir / "out" / ".boundary.csv.tmp"));
  // Provenance: this binary, the inputs, the threads.
  const auto& made = summary["provenance"];
  EXPECT_EQ(made["program"], "pfm-mpm");
  EXPECT_FALSE(made["git_revision"].get<std::string>().empty());
  EXPECT_TRUE(made.contains("build_type"));
  EXPECT_EQ(made["particles_file"], (dir / "p.csv").string());
  EXPECT_EQ(made["config_file"], (dir / "c.json").string());
  EXPECT_GE(made["threads"].get<int>(), 1);
  EXPECT_EQ(made["units"], "kN, m, s, t, kPa; plane strain; tension positive");
}

// The same files on 1 and 2 threads: the command runs the detection on the count it is given and
// writes the same boundary.csv, byte for byte. 200 x 100 points: more than one chunk of the
// survey (16,384 particles) and of every batch of the band, so that 2 threads share them.
TEST(DetectCommand, BoundaryDoesNotDependOnTheThreadCount) {
  const auto dir = scratch("threads");
  write(dir / "p.csv", block_csv(true, 200, 100));
  write(dir / "c.json", R"({"method": "improved", "initial_spacing": 0.25,
                            "grid": {"origin": [0, 0], "cell_size": 0.5, "n_cells": [112, 62]}})");
  const int threads_before = omp_get_max_threads();
  std::string text[2];
  for (const int threads : {1, 2}) {
    const fs::path out = dir / ("out" + std::to_string(threads));
    ASSERT_EQ(run_detect_command((dir / "p.csv").string(), (dir / "c.json").string(), out.string(),
                                 threads, "pfm-mpm detect"),
              0);
    EXPECT_EQ(omp_get_max_threads(), threads);
    std::ifstream csv(out / "boundary.csv");
    text[threads - 1].assign(std::istreambuf_iterator<char>(csv), {});
    const auto summary = read_json_file((out / "summary.json").string());
    EXPECT_EQ(summary["particles"], 20000);
    EXPECT_EQ(summary["provenance"]["threads"], threads);
    EXPECT_EQ(summary["provenance"]["command"], "pfm-mpm detect");
  }
  omp_set_num_threads(threads_before);
  // One closed loop around the 50 m x 25 m block, clear of the grid edges: 4 points per 0.5 m
  // cell along 150 m, some 1,200.
  EXPECT_GT(std::count(text[0].begin(), text[0].end(), '\n'), 1000);
  EXPECT_EQ(text[0], text[1]);
}

void expect_error(const std::string& name, const std::string& csv, const std::string& config,
                  const std::string& expected) {
  const auto dir = scratch(name);
  write(dir / "p.csv", csv);
  write(dir / "c.json", config);
  try {
    run_detect_command((dir / "p.csv").string(), (dir / "c.json").string(), (dir / "out").string());
    ADD_FAILURE() << name << ": no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(expected), std::string::npos) << name << ": " << e.what();
  }
  EXPECT_FALSE(fs::exists(dir / "out")) << name;
}

TEST(DetectCommand, BadInputNamesFileLineAndColumn) {
  const std::string ok_config = R"({"method": "improved"})";
  expect_error("empty", "", ok_config, "p.csv: file is empty");
  expect_error("header_only", "x,y,volume\n", ok_config, "no particle rows");
  expect_error("missing_column", "x,y\n1,2\n", ok_config, "p.csv:1: missing column \"volume\"");
  expect_error("nan", "x,y,volume\n1,2,0.1\n1,nan,0.1\n", ok_config,
               "p.csv:3: column y: must be finite");
  expect_error("text", "x,y,volume\n1,2,abc\n", ok_config,
               "p.csv:2: column volume: \"abc\" is not a number");
  expect_error("fields", "x,y,volume\n1,2\n", ok_config, "p.csv:2: 2 fields, the header has 3");
  expect_error("partial_f", "x,y,volume,F11\n1,2,0.1,1\n", ok_config, "F11, F12, F21, F22");
  expect_error("negative_volume", "x,y,volume\n1,2,-0.1\n", ok_config,
               "column volume: must be > 0");
  expect_error("bad_config", "x,y,volume\n1,2,0.1\n", R"({"improved": {"levle": 0.5}})",
               "c.json: /improved/levle: unknown key");
  expect_error("bad_shape", "x,y,volume\n1,2,0.1\n", R"({"improved": {"neighbour_shape": 1}})",
               "c.json: /improved/neighbour_shape: must be in [0, 0.9] (0 = off)");
  expect_error("bad_grid", "x,y,volume\n1,2,0.1\n",
               R"({"grid": {"origin": [0, 0], "cell_size": -1, "n_cells": [4, 4]}})",
               "c.json: /grid/cell_size");
}

}  // namespace
}  // namespace pfm

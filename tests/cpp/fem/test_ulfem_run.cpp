// The UL-FEM driver: output files and the boundary CSV contract.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "fem_reference/ulfem/ulfem_run.hpp"
#include "fem_reference/ulfem/ulfem_solver.hpp"
#include "mpm/core/json_input.hpp"
#include "ulfem_test_util.hpp"

namespace pfm::ulfem {
namespace {

namespace fs = std::filesystem;

struct BoundaryPoint {
  int loop;
  Vec2 x;
};

std::vector<BoundaryPoint> read_boundary(const std::string& path, std::string& header) {
  std::ifstream in(path);
  std::getline(in, header);
  std::vector<BoundaryPoint> points;
  std::string line;
  while (std::getline(in, line)) {
    std::istringstream s(line);
    BoundaryPoint p;
    char comma;
    s >> p.loop >> comma >> p.x.x() >> comma >> p.x.y();
    points.push_back(p);
  }
  return points;
}

// The loaded block run through run_ulfem_case: every output file exists; each boundary CSV is one
// closed loop, counter-clockwise with the deformed mesh's area (exact boundary: the shoelace
// area of the CSV equals the sum of the deformed element areas), starting at its lowest-then-
// leftmost point, with no repeated closing point.
TEST(UlFemRun, OutputsAndBoundaryContract) {
  nlohmann::json j = testing::block_case(3.0, 2.0, 0.5, 0, 2);
  j["loads"] = nlohmann::json::parse(
      R"([{"type": "vertical_pressure", "pressure": 200.0, "x_range": [1.0, 2.0]}])");
  j["time"]["end_time"] = 0.2;
  j["output"] = {{"interval", 0.05}};
  const Case c = parse_case(j, "block");
  const std::string dir = std::string(PFM_BINARY_DIR) + "/test_ulfem_run_out";
  fs::remove_all(dir);
  RunOptions options;
  options.out_dir = dir;
  options.threads = 1;
  options.progress = false;
  ASSERT_EQ(run_ulfem_case(c, options), kExitOk);
  for (const char* name : {"run.json", "particles.h5", "particles.xdmf", "mesh.h5", "mesh.xdmf",
                           "timeseries.csv", "final_particles.csv"}) {
    EXPECT_TRUE(fs::exists(fs::path(dir) / name)) << name;
  }
  const nlohmann::json run = read_json_file(dir + "/run.json");
  EXPECT_EQ(run["status"], "completed");
  EXPECT_EQ(run["summary"]["solver"], "ulfem");
  std::vector<std::string> boundaries;
  for (const auto& entry : fs::directory_iterator(dir)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("boundary_", 0) == 0) boundaries.push_back(entry.path().string());
  }
  std::sort(boundaries.begin(), boundaries.end());
  EXPECT_EQ(boundaries.size(), 5u);  // t = 0, 0.05, ..., 0.2
  ASSERT_EQ(run["outputs"].size(), 5u);
  EXPECT_EQ(run["outputs"][4]["boundary"], fs::path(boundaries.back()).filename().string());

  // timeseries.csv: the MPM's columns, then its load diagnostics and its energy ledger, which
  // closes (energy_error), then the work of the one load (= load_work); target = applied =
  // (0, -q B) = (0, -200) kN/m on the flat top, nothing lost.
  {
    std::ifstream in(dir + "/timeseries.csv");
    std::string header, line, last;
    std::getline(in, header);
    EXPECT_EQ(header,
              "time,kinetic_energy,external_work,internal_work,damping_work,momentum_x,momentum_y,"
              "load_target_fx,load_target_fy,load_applied_fx,load_applied_fy,load_lost_fx,"
              "load_lost_fy,load_off_grid_fx,load_off_grid_fy,loaded_nodes,lost_nodes,"
              "load_lost_moment,elastic_energy,plastic_dissipation,gravity_work,load_work,"
              "constraint_work,transfer_to_grid,transfer_to_particles,internal_force_work,"
              "rotation_work,volume_work,energy_error,load_work_0");
    while (std::getline(in, line)) last = line;
    std::vector<double> v;
    std::istringstream row(last);
    for (std::string cell; std::getline(row, cell, ',');) v.push_back(std::stod(cell));
    ASSERT_EQ(v.size(), 30u);
    std::printf(
        "[ulfem run] last timeseries row: target (%g, %g), applied (%g, %g), lost (%g, %g), "
        "%g loaded nodes\n",
        v[7], v[8], v[9], v[10], v[11], v[12], v[15]);
    EXPECT_NEAR(v[8], -200.0, 1e-9);
    EXPECT_NEAR(v[10], v[8], 1e-12 * 200.0);
    EXPECT_EQ(v[11], 0.0);
    EXPECT_LE(std::abs(v[28]), 1e-9 * std::abs(v[2]));
    EXPECT_NEAR(v[29], v[21], 1e-12 * std::abs(v[21]));
    EXPECT_EQ(v[12], 0.0);
    EXPECT_EQ(v[16], 0.0);
    EXPECT_GE(v[15], 3.0);
  }

  // The final state, recomputed by the solver to compare areas.
  UlFemSolver solver(c);
  const double eps = 1e-9 * solver.dt();
  while (solver.time() < c.time.end_time - eps) solver.step();
  double mesh_area = 0.0;
  for (const auto& element : solver.mesh().element_nodes) {
    for (std::size_t a = 0; a < 4; ++a) {
      const Vec2& p = solver.node_position()[static_cast<std::size_t>(element[a])];
      const Vec2& q = solver.node_position()[static_cast<std::size_t>(element[(a + 1) % 4])];
      mesh_area += 0.5 * (p.x() * q.y() - q.x() * p.y());
    }
  }
  std::string header;
  const auto points = read_boundary(boundaries.back(), header);
  EXPECT_EQ(header, "loop,x,y");
  ASSERT_EQ(points.size(), 2u * (6 + 4));  // perimeter nodes of a 6 x 4 element block
  double area = 0.0;
  for (std::size_t k = 0; k < points.size(); ++k) {
    EXPECT_EQ(points[k].loop, 0);
    const Vec2& x = points[k].x;
    const Vec2& y = points[(k + 1) % points.size()].x;
    area += 0.5 * (x.x() * y.y() - y.x() * x.y());
    EXPECT_FALSE(k > 0 && x == points.front().x) << "repeated point " << k;
    EXPECT_TRUE(x.y() > points.front().x.y() ||
                (x.y() == points.front().x.y() && x.x() >= points.front().x.x()))
        << "point " << k << " is lower than the first";
  }
  std::printf(
      "[ulfem run] %zu boundary files; final boundary area %.15g m^2, mesh area %.15g "
      "m^2, initial 6 m^2\n",
      boundaries.size(), area, mesh_area);
  EXPECT_NEAR(area, mesh_area, 1e-12 * mesh_area);
  EXPECT_LT(area, 6.0);  // compressed by gravity and the load
}

}  // namespace
}  // namespace pfm::ulfem

// The whole chain (simulate_part) on a small fixed case: three passes of the second paper's
// part 1 (plane, concave cylinder, inclined plane) on the Mikron sample.
//  - perfect drives leave no mark;
//  - a deviation planted in the axis positions shows up as a mark of that depth at that place;
//  - the reference-feed surface matches the commanded tool path's surface.
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include "cli_runner.hpp"
#include "effects_option.hpp"
#include "simulate_part.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/viz/display.hpp"
#include "vmsim/viz/image_compare.hpp"

namespace vmsim {
namespace {

const std::string kRoot = VMSIM_SOURCE_DIR;

// Writes a part file with the first `passes` passes of sample part 1 and a stock strip around
// them; returns its path.
std::string small_part(const std::filesystem::path& folder, int passes) {
  std::istringstream apt(read_file(kRoot + "/samples/parts/part1_tangency/toolpath.apt"));
  std::ostringstream out;
  int rapids = 0;
  for (std::string line; std::getline(apt, line);) {
    if (line == "RAPID" && ++rapids > 2 * passes) break;
    out << line << '\n';
  }
  out << "FINI\n";
  std::ofstream(folder / "toolpath.apt") << out.str();
  std::ofstream(folder / "part.yaml")
      << "name: part1_three_passes\n"
         "description: the first passes of sample part 1\n"
         "machine: " << kRoot << "/samples/machines/mikron_ucp710.yaml\n"
         "toolpath: toolpath.apt\n"
         "tool: {type: ball, diameter_mm: 10, corner_radius_mm: 5, length_mm: 60}\n"
         "stock: {box: {min_mm: [-12, -5, 0], max_mm: [16, -4.5, 40]}}\n"
         "feeds: {production_mm_per_min: 10000, reference_mm_per_min: 100}\n";
  return (folder / "part.yaml").string();
}

app::SimulatePartOptions options_for(const std::filesystem::path& folder) {
  app::SimulatePartOptions options;
  options.part_path = small_part(folder, 3);
  options.out_dir = (folder / "out").string();
  options.grid_m = 25e-6;
  options.renders = false;
  return options;
}

const app::ProgressSink kSilent = [](const std::string&) {};

TEST(SimulatePart, PerfectDrivesLeaveNoMark) {
  const auto folder = test::fresh_folder("simulate_perfect");
  app::SimulatePartOptions options = options_for(folder);
  options.perfect_drives = true;
  const nlohmann::json report = app::simulate_part(options, kSilent);
  EXPECT_TRUE(report["marks"].empty()) << report["marks"].dump(2);
  // Both runs cut the same geometry: the difference is the thinning tolerance (0.05 um per run).
  EXPECT_LT(std::abs(report["surface"]["deviation_min_um"].get<double>()), 0.2);
  EXPECT_LT(std::abs(report["surface"]["deviation_max_um"].get<double>()), 0.2);
  EXPECT_TRUE(std::filesystem::exists(folder / "out" / "report.json"));
  EXPECT_TRUE(std::filesystem::exists(folder / "out" / "production.vtp"));
}

TEST(SimulatePart, APlantedDeviationIsAMarkOfThatDepthAtThatPlace) {
  const auto folder = test::fresh_folder("simulate_planted");
  app::SimulatePartOptions options = options_for(folder);
  options.perfect_drives = true;
  // Z 20 um lower while X is between -6 and -4 mm on the middle pass (Y = -4.75 mm): on this
  // machine at A = C = 0, X and Y are the tip's x and y in W.
  options.production_disturbance = [](double, Eigen::VectorXd& q) {
    if (q[0] >= -6e-3 && q[0] <= -4e-3 && std::abs(q[1] + 4.75e-3) < 1e-6) q[2] -= 20e-6;
  };
  const nlohmann::json report = app::simulate_part(options, kSilent);
  ASSERT_FALSE(report["marks"].empty());
  const auto& mark = report["marks"][0];
  EXPECT_EQ(mark["kind"], "gouge");
  EXPECT_NEAR(mark["depth_um"].get<double>(), 20.0, 0.5);
  const double x_mm = mark["deepest_point_mm"][0].get<double>();
  const double y_mm = mark["deepest_point_mm"][1].get<double>();
  EXPECT_GT(x_mm, -6.0 - 0.05);
  EXPECT_LT(x_mm, -4.0 + 0.05);
  EXPECT_NEAR(y_mm, -4.75, 0.3);
  EXPECT_NEAR(mark["deepest_point_mm"][2].get<double>(), 20.0 - 0.02, 0.01);
  // Related to the tool path: the line of the APT file that programmed that stretch, and Z.
  EXPECT_NE(mark["block"].get<std::string>().find("toolpath.apt:"), std::string::npos);
  EXPECT_EQ(mark["responsible_axes"][0], "Z");
}

TEST(SimulatePart, TheReferenceRunMatchesTheCommandedSurface) {
  const auto folder = test::fresh_folder("simulate_reference");
  app::SimulatePartOptions options = options_for(folder);
  const nlohmann::json report = app::simulate_part(options, kSilent);
  // 0.1 m/min: the drives follow within a fraction of a micrometre across the surface.
  EXPECT_LT(report["surface"]["reference_vs_commanded_max_um"].get<double>(), 1.0)
      << report["surface"].dump(2);
  // Every stage was timed.
  EXPECT_GT(report["stage_seconds"]["total"].get<double>(), 0.0);
  EXPECT_TRUE(report["stage_seconds"]["production"].contains("servo"));
}

// The first paper's finding, through the whole chain: with the tuned (equivalent) torque limits of
// Eq. 10 and gravity and friction off, the dynamic plan is the kinematic one, so cycle time and
// marks agree; with gravity and friction on, the report still gives both side by side.
TEST(SimulatePart, MethodsSideBySideAgreeWithEquivalentLimitsAndNoGravityOrFriction) {
  const auto folder = test::fresh_folder("simulate_methods");
  app::SimulatePartOptions options = options_for(folder);
  options.compare_methods = true;
  options.commanded_check = false;
  options.effects = app::parse_effects("H,Hcpl,B,C");
  const nlohmann::json report = app::simulate_part(options, kSilent);
  ASSERT_TRUE(report.contains("method_comparison"));
  const auto& methods = report["method_comparison"];
  ASSERT_EQ(methods.size(), 2u);
  EXPECT_EQ(methods[0]["method"], "kinematic");
  EXPECT_EQ(methods[1]["method"], "dynamic");
  const double t_kinematic = methods[0]["duration_s"].get<double>();
  const double t_dynamic = methods[1]["duration_s"].get<double>();
  EXPECT_NEAR(t_dynamic / t_kinematic, 1.0, 0.01) << methods.dump(2);
  ASSERT_TRUE(methods[0].contains("deepest_mark")) << methods.dump(2);
  ASSERT_TRUE(methods[1].contains("deepest_mark")) << methods.dump(2);
  EXPECT_NEAR(methods[1]["deepest_mark"]["depth_um"].get<double>(),
              methods[0]["deepest_mark"]["depth_um"].get<double>(), 1.0);
  EXPECT_NEAR(methods[1]["deepest_mark"]["s_mm"].get<double>(), methods[0]["deepest_mark"]["s_mm"].get<double>(), 1.0);
}

// A flank pass of a flat end mill along a wall (the design plane y = 20 mm, material beyond):
// the Z-map cannot see the wall, the wall's own view (lines along its normal) must.
std::string wall_part(const std::filesystem::path& folder) {
  std::ofstream(folder / "toolpath.apt") << "PARTNO/flank pass along a wall\nUNITS/MM\nCUTTER/10,0\n"
                                            "FEDRAT/MMPM,10000\nFROM/-30,15,50\nRAPID\n"
                                            "GOTO/-30,15,20\nGOTO/30,15,20\nRAPID\nGOTO/30,15,50\nFINI\n";
  std::ofstream(folder / "part.yaml")
      << "name: wall_flank\n"
         "description: a flank pass along the wall y = 20 mm\n"
         "machine: " << kRoot << "/samples/machines/mikron_ucp710.yaml\n"
         "toolpath: toolpath.apt\n"
         "tool: {type: flat, diameter_mm: 10, corner_radius_mm: 0, length_mm: 60}\n"
         "stock: {box: {min_mm: [-10, 12, 0], max_mm: [10, 25, 30]}}\n"
         "design:\n"
         "  surfaces:\n"
         "    - {type: plane, point_mm: [0, 20, 0], normal: [0, -1, 0], x_range_mm: [-10, 10], z_range_mm: [20, 30]}\n"
         "    - {type: plane, point_mm: [0, 0, 20], normal: [0, 0, 1], role: floor}\n"
         "feeds: {production_mm_per_min: 10000, reference_mm_per_min: 100}\n";
  return (folder / "part.yaml").string();
}

// The wall case with perfect drives and, in the production run, Y 20 um towards the wall while X
// is between -2 and 0 mm (only the cutting move passes there).
app::SimulatePartOptions wall_options(const std::filesystem::path& folder, double grid_m) {
  app::SimulatePartOptions options;
  options.part_path = wall_part(folder);
  options.out_dir = (folder / "out").string();
  options.grid_m = grid_m;
  options.perfect_drives = true;
  options.production_disturbance = [](double, Eigen::VectorXd& q) {
    if (q[0] >= -2e-3 && q[0] <= 0.0) q[1] += 20e-6;
  };
  return options;
}

TEST(SimulatePart, APlantedWallDeviationIsAMarkOnTheWallView) {
  const auto folder = test::fresh_folder("simulate_wall");
  app::SimulatePartOptions options = wall_options(folder, 25e-6);
  options.renders = false;
  const nlohmann::json report = app::simulate_part(options, kSilent);
  const auto& views = report["surface"]["views"];
  ASSERT_EQ(views.size(), 2u) << views.dump(2);  // the Z-map and the wall (the floor is not steep)
  EXPECT_EQ(views[1]["id"], "wall1");
  // The wall stands in the Z-map as a 10 mm step between two lines: not assessed there.
  EXPECT_GT(views[0]["steep_lines_not_assessed"].get<std::size_t>(), 0u);
  EXPECT_EQ(views[0]["marks"].get<std::size_t>(), 0u) << views.dump(2);
  ASSERT_FALSE(report["marks"].empty());
  const auto& mark = report["marks"][0];
  EXPECT_EQ(mark["view"], "wall1");
  EXPECT_EQ(mark["kind"], "gouge");
  EXPECT_NEAR(mark["depth_um"].get<double>(), 20.0, 0.5);
  EXPECT_GT(mark["deepest_point_mm"][0].get<double>(), -2.0 - 0.05);
  EXPECT_LT(mark["deepest_point_mm"][0].get<double>(), 0.0 + 0.05);
  EXPECT_NEAR(mark["deepest_point_mm"][1].get<double>(), 20.0 + 0.02, 1e-3);
  EXPECT_EQ(mark["responsible_axes"][0], "Y");
  // Undisturbed, the wall is where the tool flank put it: the other lines did not move.
  EXPECT_LT(views[1]["deviation_max_um"].get<double>(), 0.2);
}

// Image tests of simulate-part's renders on the wall case with its planted deviation: compared
// with tests/app/baselines/ through vtkImageDifference, as the viz module's own image tests
// (tests/viz/test_images.cpp: same tolerance, same VMSIM_UPDATE_BASELINES=1 to regenerate after
// an intended change of the look). They need a display: ctest runs them under Xvfb
// (app.simulate_part_images_under_xvfb); elsewhere they skip.
TEST(SimulatePartImages, RendersMatchTheirBaselines) {
  std::string why_not;
  if (!viz::display_available(why_not)) GTEST_SKIP() << why_not;
  const auto folder = test::fresh_folder("simulate_images");
  app::SimulatePartOptions options = wall_options(folder, 50e-6);
  options.commanded_check = false;
  const nlohmann::json report = app::simulate_part(options, kSilent);
  ASSERT_FALSE(report["renders"].contains("skipped")) << report["renders"].dump();
  const std::filesystem::path baselines = kRoot + "/tests/app/baselines";
  const char* update = std::getenv("VMSIM_UPDATE_BASELINES");
  for (const char* name : {"surface_deviation.png", "surface_deviation_wall1.png", "worst_mark.png",
                           "deviation_histogram.png"}) {
    const auto png = folder / "out" / name;
    ASSERT_TRUE(std::filesystem::exists(png)) << png;
    if (update != nullptr && std::string(update) == "1") {
      std::filesystem::create_directories(baselines);
      std::filesystem::copy_file(png, baselines / name, std::filesystem::copy_options::overwrite_existing);
    }
    const viz::ImageDifference difference = viz::compare_png_files(png.string(), (baselines / name).string());
    ASSERT_TRUE(difference.same_size) << name;
    EXPECT_LE(difference.thresholded_error, 10.0) << name << ": error " << difference.error;
  }
}

}  // namespace
}  // namespace vmsim

// The whole chain (simulate_part) on a small fixed case: three passes of the second paper's
// part 1 (plane, concave cylinder, inclined plane) on the Mikron sample.
//  - perfect drives leave no mark;
//  - a deviation planted in the axis positions shows up as a mark of that depth at that place;
//  - the reference-feed surface matches the commanded tool path's surface.
#include <gtest/gtest.h>

#include <array>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include <numbers>
#include <set>

#include "chain_inputs.hpp"
#include "cli_runner.hpp"
#include "effects_option.hpp"
#include "part_file.hpp"
#include "simulate_part.hpp"
#include "small_part.hpp"
#include "surface_views.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/removal/nbuffer.hpp"
#include "vmsim/viz/display.hpp"
#include "vmsim/viz/image_compare.hpp"

namespace vmsim {
namespace {

const std::string kRoot = VMSIM_SOURCE_DIR;

using test::small_part;

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
  // Every validity check is in the report, with its figure, and passed.
  std::set<std::string> ids;
  for (const auto& check : report["validity_checks"]) {
    ids.insert(check["id"].get<std::string>());
    EXPECT_EQ(check["status"], "ok") << check.dump();
    EXPECT_TRUE(check.contains("value")) << check.dump();
  }
  for (const char* id : {"setpoints_on_path.production", "setpoints_on_path.reference",
                         "setpoints_within_travel.production", "actual_within_travel.reference",
                         "reference_vs_commanded"}) {
    EXPECT_EQ(ids.count(id), 1u) << id;
  }
  const std::string html = read_file(options.out_dir + "/report.html");
  EXPECT_NE(html.find("Validity checks"), std::string::npos);
  // The verdict comes first; without a tolerance it says there is none and how to give one.
  EXPECT_EQ(report["verdict"]["status"], "no_tolerance");
  EXPECT_LT(html.find("No tolerance was given"), html.find("Validity checks"));
  // A page to forward: no absolute path (of the sources, of the output) and no code identifier.
  EXPECT_EQ(html.find(VMSIM_SOURCE_DIR), std::string::npos);
  EXPECT_EQ(html.find(folder.string()), std::string::npos);
  EXPECT_EQ(html.find("_or_"), std::string::npos);
  EXPECT_EQ(html.find("following_error_peak"), std::string::npos);
  EXPECT_TRUE(std::filesystem::exists(folder / "out" / "marks.csv"));
}

TEST(SimulatePart, ACompactZmapGivesThePlainResultsWithinItsBound) {
  // The same job with plain (exact) and compact Z-map heights (float offsets from a base a tile):
  // the marks and deviations agree within the compact bound (2^-24 of the 40 mm stock's height,
  // 2.4 nm, per run); the compact heights take about half the bytes (tiles the tool does not
  // reach hold none: tests/removal/test_compact_heights.cpp); the stages report their CPU time
  // and the peak memory.
  const auto plain_folder = test::fresh_folder("simulate_plain_zmap");
  const auto compact_folder = test::fresh_folder("simulate_compact_zmap");
  app::SimulatePartOptions plain = options_for(plain_folder);
  app::SimulatePartOptions compact = options_for(compact_folder);
  compact.compact_zmap_above_lines = 0;
  plain.perfect_drives = compact.perfect_drives = true;
  const auto disturbance = [](double, Eigen::VectorXd& q) {  // a 20 um mark, as above
    if (q[0] >= -6e-3 && q[0] <= -4e-3 && std::abs(q[1] + 4.75e-3) < 1e-6) q[2] -= 20e-6;
  };
  plain.production_disturbance = compact.production_disturbance = disturbance;
  const nlohmann::json a = app::simulate_part(plain, kSilent);
  const nlohmann::json b = app::simulate_part(compact, kSilent);
  const double bound_um = 2 * removal::NBuffer::compact_bound_m(40e-3) * 1e6;
  ASSERT_EQ(a["marks"].size(), b["marks"].size());
  ASSERT_FALSE(a["marks"].empty());
  for (std::size_t m = 0; m < a["marks"].size(); ++m) {
    EXPECT_NEAR(a["marks"][m]["depth_um"].get<double>(), b["marks"][m]["depth_um"].get<double>(), bound_um);
    // Lines within the bound of the threshold may fall either side of it.
    const double lines = a["marks"][m]["lines"].get<double>();
    EXPECT_NEAR(lines, b["marks"][m]["lines"].get<double>(), std::max(2.0, 1e-3 * lines));
  }
  for (const char* key : {"deviation_min_um", "deviation_max_um", "reference_vs_commanded_max_um"}) {
    EXPECT_NEAR(a["surface"][key].get<double>(), b["surface"][key].get<double>(), bound_um) << key;
  }
  EXPECT_EQ(a["surface"]["zmap_heights"]["storage"], "plain");
  EXPECT_EQ(b["surface"]["zmap_heights"]["storage"], "compact");
  const auto& heights = b["surface"]["zmap_heights"];
  // The tool reaches the whole strip here: every tile holds offsets, 4 B a line against 8.
  EXPECT_LE(heights["tiles_allocated_production"].get<std::size_t>(), heights["tiles"].get<std::size_t>());
  EXPECT_GT(heights["tiles_allocated_production"].get<std::size_t>(), 0u);
  EXPECT_LT(heights["bytes_production"].get<double>(), 0.6 * a["surface"]["zmap_heights"]["bytes_production"].get<double>());
  EXPECT_GT(b["stage_peak_rss_mib"]["total"].get<double>(), 0.0);
  EXPECT_GE(b["stage_cpu_seconds"]["total"].get<double>(), b["stage_cpu_seconds"]["reference"]["removal"].get<double>());
}

TEST(SimulatePart, TheVerdictTakesTheToleranceFromTheOptionOrThePartFile) {
  const auto folder = test::fresh_folder("simulate_verdict");
  app::SimulatePartOptions options = options_for(folder);
  options.perfect_drives = true;
  options.commanded_check = false;
  options.production_disturbance = [](double, Eigen::VectorXd& q) {
    if (q[0] >= -6e-3 && q[0] <= -4e-3 && std::abs(q[1] + 4.75e-3) < 1e-6) q[2] -= 20e-6;
  };
  options.tolerance_m = 10e-6;
  const nlohmann::json beyond = app::simulate_part(options, kSilent);
  EXPECT_EQ(beyond["verdict"]["status"], "not_within") << beyond["verdict"].dump(2);
  EXPECT_EQ(beyond["verdict"]["tolerance_source"], "--tolerance-um");
  EXPECT_NEAR(beyond["verdict"]["worst_mark"]["depth_um"].get<double>(), 20.0, 0.5);
  options.tolerance_m = 30e-6;
  const nlohmann::json within = app::simulate_part(options, kSilent);
  EXPECT_EQ(within["verdict"]["status"], "within") << within["verdict"].dump(2);
  const std::string csv = read_file(options.out_dir + "/marks.csv");
  EXPECT_EQ(csv.rfind("rank,speck,kind,depth_um", 0), 0u);
  EXPECT_NE(csv.find("\n1,no,gouge,"), std::string::npos) << csv;
}

// The box [-12, 16] x [-5, -4.5] x [0, 40] mm of small_part as an ASCII STL: 12 outward
// triangles, `facets` of them written (fewer: an open mesh).
std::string box_stl(int facets = 12) {
  const double lo[3] = {-12, -5, 0}, hi[3] = {16, -4.5, 40};
  std::ostringstream stl;
  stl << "solid box\n";
  int written = 0;
  for (int axis = 0; axis < 3; ++axis) {
    const int u = (axis + 1) % 3, v = (axis + 2) % 3;
    for (int side = 0; side < 2; ++side) {
      // Corners of the face in (u, v) order, counter-clockwise seen from outside.
      double corner[4][3];
      const int order[4][2] = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
      for (int c = 0; c < 4; ++c) {
        const int cu = side ? order[c][0] : order[3 - c][0], cv = side ? order[c][1] : order[3 - c][1];
        corner[c][axis] = side ? hi[axis] : lo[axis];
        corner[c][u] = cu ? hi[u] : lo[u];
        corner[c][v] = cv ? hi[v] : lo[v];
      }
      for (const auto& triangle : {std::array<int, 3>{0, 1, 2}, std::array<int, 3>{0, 2, 3}}) {
        if (written++ >= facets) continue;
        stl << " facet normal 0 0 0\n  outer loop\n";
        for (int c : triangle) stl << "   vertex " << corner[c][0] << " " << corner[c][1] << " " << corner[c][2] << "\n";
        stl << "  endloop\n endfacet\n";
      }
    }
  }
  stl << "endsolid box\n";
  return stl.str();
}

// The same part with its stock box given as a closed STL: the same grid and, inside the box,
// identical lines, so identical surfaces and the same mark (here a planted deviation).
TEST(SimulatePart, AnStlStockOfTheBoxGivesTheBoxResultLineByLine) {
  const auto box_folder = test::fresh_folder("simulate_stock_box");
  const auto stl_folder = test::fresh_folder("simulate_stock_stl");
  std::ofstream(stl_folder / "stock.stl") << box_stl();
  nlohmann::json reports[2];
  for (int k = 0; k < 2; ++k) {
    const auto& folder = k == 0 ? box_folder : stl_folder;
    app::SimulatePartOptions options = options_for(folder);
    if (k == 1) options.part_path = small_part(folder, 3, "stock: {stl: stock.stl}");
    options.perfect_drives = true;
    options.commanded_check = false;
    options.production_disturbance = [](double, Eigen::VectorXd& q) {
      if (q[0] >= -6e-3 && q[0] <= -4e-3 && std::abs(q[1] + 4.75e-3) < 1e-6) q[2] -= 20e-6;
    };
    reports[k] = app::simulate_part(options, kSilent);
  }
  EXPECT_EQ(reports[1]["stock"]["triangles"], 12);
  EXPECT_EQ(reports[0]["stock"]["min_mm"], reports[1]["stock"]["min_mm"]);
  EXPECT_EQ(reports[0]["stock"]["max_mm"], reports[1]["stock"]["max_mm"]);
  // Lines inside the box: bit for bit the same lengths. Lines on the mesh's side faces (the
  // grid's first and last rows and columns) may count as outside the mesh (length 0).
  const auto nu = reports[0]["surface"]["nx"].get<int>(), nv = reports[0]["surface"]["ny"].get<int>();
  EXPECT_LE(reports[1]["stock"]["zmap_lines_outside_the_mesh"].get<int>(), 2 * (nu + nv));
  for (const char* file : {"production_heights.bin", "reference_heights.bin"}) {
    const std::string box = read_file((box_folder / "out" / file).string());
    const std::string stl = read_file((stl_folder / "out" / file).string());
    ASSERT_EQ(box.size(), stl.size()) << file;
    ASSERT_EQ(box.compare(0, 52, stl, 0, 52), 0) << file << ": the same grid";
    std::size_t inside = 0, different = 0;
    for (int j = 1; j + 1 < nv; ++j) {
      for (int i = 1; i + 1 < nu; ++i) {
        const std::size_t at = 52 + 8 * (static_cast<std::size_t>(i) + static_cast<std::size_t>(nu) * static_cast<std::size_t>(j));
        ++inside;
        different += box.compare(at, 8, stl, at, 8) != 0;
      }
    }
    EXPECT_GT(inside, 10000u);
    EXPECT_EQ(different, 0u) << file;
  }
  ASSERT_EQ(reports[0]["marks"].size(), 1u);
  ASSERT_EQ(reports[1]["marks"].size(), 1u);
  EXPECT_EQ(reports[1]["marks"][0]["depth_um"], reports[0]["marks"][0]["depth_um"]);
  EXPECT_EQ(reports[1]["marks"][0]["deepest_point_mm"], reports[0]["marks"][0]["deepest_point_mm"]);
  EXPECT_NEAR(reports[1]["marks"][0]["depth_um"].get<double>(), 20.0, 0.5);
}

// --path-tolerance-um is the limit the planner holds its path to and the check applies: the
// set points' largest distance from the programmed path stays under it and the report gives it
// as the limit; a tolerance that is not > 0 is a usage error before anything is written.
TEST(SimulatePart, ThePathToleranceOptionIsTheLimitOfTheSetPointsCheck) {
  const auto folder = test::fresh_folder("simulate_path_tolerance");
  const std::string part = small_part(folder, 1);
  const auto out = folder / "out";
  const test::RunResult run = test::run_vmsim("-q simulate-part --part " + part + " --out " + out.string() +
                                              " --no-renders --grid-um 50 --path-tolerance-um 0.25");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const nlohmann::json report = nlohmann::json::parse(read_file((out / "report.json").string()));
  int checked = 0;
  for (const auto& check : report["validity_checks"]) {
    if (check["id"].get<std::string>().rfind("setpoints_on_path.", 0) != 0) continue;
    ++checked;
    EXPECT_DOUBLE_EQ(check["limit"].get<double>(), 0.25) << check.dump();
    EXPECT_LE(check["value"].get<double>(), 0.25) << check.dump();
    EXPECT_EQ(check["status"], "ok") << check.dump();
  }
  EXPECT_EQ(checked, 2);  // reference and production
  for (const std::string bad : {"0", "-1", "nan"}) {
    const auto bad_out = folder / ("bad_" + bad);
    const test::RunResult refused = test::run_vmsim("-q simulate-part --part " + part + " --out " +
                                                    bad_out.string() + " --no-renders --path-tolerance-um " + bad);
    EXPECT_EQ(refused.exit_code, 3) << bad << ": " << refused.output;
    EXPECT_NE(refused.output.find("--path-tolerance-um must be > 0"), std::string::npos) << refused.output;
    EXPECT_FALSE(std::filesystem::exists(bad_out));
  }
}

// A stock STL that is not there, or not a closed mesh: an error naming the part file, the line
// of `stock` and the STL's problem, exit code 3 (bad input file), and no output folder.
TEST(SimulatePart, AMissingOrOpenStockStlIsALocatedErrorAndWritesNothing) {
  const auto folder = test::fresh_folder("simulate_stock_bad");
  std::ofstream(folder / "open.stl") << box_stl(11);
  for (const std::string stl : {"missing.stl", "open.stl"}) {
    SCOPED_TRACE(stl);
    app::SimulatePartOptions options = options_for(folder);
    const std::string part = small_part(folder, 1, "stock: {stl: " + stl + "}");
    options.part_path = part;
    const auto out = folder / "out";
    try {
      app::simulate_part(options, kSilent);
      ADD_FAILURE() << "no error";
    } catch (const InputError& error) {
      const std::string message = error.what();
      EXPECT_NE(message.find(part + ":6:"), std::string::npos) << message;  // line 6: stock
      EXPECT_NE(message.find("stock.stl"), std::string::npos) << message;
      EXPECT_NE(message.find(stl), std::string::npos) << message;
    }
    EXPECT_FALSE(std::filesystem::exists(out));
    const test::RunResult run =
        test::run_vmsim("-q simulate-part --part " + part + " --out " + out.string() + " --no-renders");
    EXPECT_EQ(run.exit_code, 3) << run.output;
    EXPECT_NE(run.output.find("part.yaml:6:"), std::string::npos) << run.output;
    EXPECT_FALSE(std::filesystem::exists(out));
  }
}

// Sample part 3 sweeps only the ball (cutting_length_mm = D): on its near-net stock, the
// commanded poses where the tilt is largest (about 60 deg, where the shank leans lowest) cut
// the same lines as a tool 30 mm long (its shank and the orientation sub-steps it brings).
TEST(SimulatePart, Part3BallOnlyCutsAsTheLongerToolOnItsNearNetStock) {
  const app::PartDescription part = app::load_part(kRoot + "/samples/parts/part3_five_axis/part.yaml");
  ASSERT_TRUE(part.stock_mesh.has_value());
  EXPECT_DOUBLE_EQ(part.tool.cutting_length_m, part.tool.diameter_m);
  app::ChainInputOptions chain;
  chain.part_path = kRoot + "/samples/parts/part3_five_axis/part.yaml";
  const app::ChainInputs inputs = app::load_chain_inputs(chain);
  std::vector<removal::Pose> poses;
  for (std::size_t i = inputs.path.size() - 40; i + 2 < inputs.path.size(); ++i) {
    poses.push_back({inputs.path[i].pose.tip_W_m, inputs.path[i].pose.axis_W});
  }
  ASSERT_GT(std::acos(poses.back().axis_W.z()), 59.0 * std::numbers::pi / 180.0);
  const removal::NBuffer stock = removal::NBuffer::zmap(*part.stock_mesh, 100e-6);
  removal::Tool tool;
  tool.type = removal::ToolType::ball;
  tool.diameter_m = part.tool.diameter_m;
  tool.corner_radius_m = part.tool.corner_radius_m;
  removal::CutOptions options;
  options.orientation_tolerance_m = 0.5e-6;  // fewer sub-steps: the shank must not cut at all
  std::vector<double> lengths[2];
  std::size_t sub_segments[2] = {0, 0};
  for (int k = 0; k < 2; ++k) {
    tool.length_m = k == 0 ? part.tool.cutting_length_m : 30e-3;
    removal::NBuffer buffer = stock;
    sub_segments[k] = buffer.cut(tool, poses, options).sub_segments;
    lengths[k] = buffer.lengths();
  }
  EXPECT_GT(sub_segments[1], 10 * sub_segments[0]) << "the long tool is sub-stepped";
  std::size_t cut = 0;
  double largest = 0.0;
  const std::vector<double> uncut = stock.lengths();
  for (std::size_t i = 0; i < uncut.size(); ++i) {
    cut += lengths[0][i] < uncut[i] - 1e-6;
    largest = std::max(largest, std::abs(lengths[1][i] - lengths[0][i]));
  }
  EXPECT_GT(cut, 1000u);
  EXPECT_LT(largest, 1e-9);
}

// The start of sample part 3 (ball-end normal to the dome, tilt 20 deg, the part's near-net
// stock) with perfect drives and Z 20 um lower while C is between -60 and -40 deg. The tool
// axis is the machine's Z and the dome's normal there: the sphere view (lines along the
// normals) sees a 20 um gouge, the Z-map the same gouge through the slope of the groove (at
// least 1 / cos(20 deg)).
TEST(SimulatePart, APlantedDeviationOnTheDomeIsItsDepthAlongTheNormalOnTheSphereView) {
  const auto folder = test::fresh_folder("simulate_dome");
  std::istringstream apt(read_file(kRoot + "/samples/parts/part3_five_axis/toolpath.apt"));
  std::ostringstream out;
  int gotos = 0;
  for (std::string line; std::getline(apt, line) && gotos < 90;) {
    out << line << '\n';
    gotos += line.rfind("GOTO/", 0) == 0;
  }
  out << "FINI\n";
  std::ofstream(folder / "toolpath.apt") << out.str();
  std::ofstream(folder / "part.yaml")
      << "name: dome_start\ndescription: the first 90 moves of sample part 3\n"
         "machine: " << kRoot << "/samples/machines/mikron_ucp710.yaml\n"
         "toolpath: toolpath.apt\n"
         "tool: {type: ball, diameter_mm: 10, corner_radius_mm: 5, length_mm: 60, cutting_length_mm: 10}\n"
         "stock: {stl: " << kRoot << "/samples/parts/part3_five_axis/stock.stl}\n"
         "design: {surfaces: [{type: sphere, center_mm: [0, 0, 0], radius_mm: 40, material: inside}]}\n"
         "feeds: {production_mm_per_min: 10000, reference_mm_per_min: 100}\n";
  app::SimulatePartOptions options;
  options.part_path = (folder / "part.yaml").string();
  options.out_dir = (folder / "out").string();
  options.grid_m = 50e-6;
  options.renders = false;
  options.commanded_check = false;
  options.perfect_drives = true;
  constexpr double kDegree = std::numbers::pi / 180.0;
  options.production_disturbance = [](double, Eigen::VectorXd& q) {
    if (q[4] >= -60 * kDegree && q[4] <= -40 * kDegree) q[2] -= 20e-6;
  };
  const nlohmann::json report = app::simulate_part(options, kSilent);
  const auto& views = report["surface"]["views"];
  ASSERT_EQ(views.size(), 2u) << views.dump(2);
  EXPECT_EQ(views[1]["id"], "sphere1");
  double depth[2] = {0.0, 0.0};
  for (const auto& mark : report["marks"]) {
    const int v = mark["view"] == "zmap" ? 0 : 1;
    EXPECT_EQ(mark["responsible_axes"][0], "Z");
    depth[v] = std::max(depth[v], mark["depth_um"].get<double>());
  }
  EXPECT_NEAR(depth[1], 20.0, 0.5) << report["marks"].dump(2);
  // Z-map: a shift d along n0 moves a surface point of normal m by d (m.n0) / (m.z) along z:
  // d / cos(20 deg) at the contact, most on the groove's lower flank, where the ball (centre at
  // 45 mm from the dome's) meets the stock (40.3 mm): m is gamma from n0 towards the equator.
  const double gamma = std::acos((45.0 * 45.0 + 5.0 * 5.0 - 40.3 * 40.3) / (2 * 45.0 * 5.0));
  EXPECT_GT(depth[0], 20.0 / std::cos(20 * kDegree) - 0.5) << report["marks"].dump(2);
  EXPECT_LT(depth[0], 20.0 * std::cos(gamma) / std::cos(20 * kDegree + gamma) + 0.5) << report["marks"].dump(2);
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

// The wall with its own tolerance (and a name), the part with another: the wall's 20 um mark is
// judged by the wall's, in report.json (the mark's design surface and tolerance, the verdict)
// and in report.html's verdict lines; --tolerance-um replaces the part's, not the wall's.
TEST(SimulatePart, AMarkIsJudgedByTheToleranceOfTheDesignSurfaceItLiesOn) {
  const auto folder = test::fresh_folder("simulate_wall_tolerance");
  app::SimulatePartOptions options = wall_options(folder, 50e-6);
  options.renders = false;
  const std::string original = read_file(options.part_path);
  const auto with_tolerances = [&](const std::string& wall_um, const std::string& part_um) {
    std::string yaml = original;
    const std::string wall = "x_range_mm: [-10, 10], z_range_mm: [20, 30]}";
    yaml.replace(yaml.find(wall), wall.size(),
                 "x_range_mm: [-10, 10], z_range_mm: [20, 30], name: sealing wall, tolerance_um: " + wall_um + "}");
    std::ofstream(options.part_path) << yaml << "tolerance_um: " << part_um << "\n";
  };
  with_tolerances("15", "30");
  const nlohmann::json beyond = app::simulate_part(options, kSilent);
  ASSERT_FALSE(beyond["marks"].empty());
  // The planted mark lies between the two tolerances: the wall's own (15 um) fails it, the part's
  // (30 um) and the wider wall tolerance below (25 um) pass it; deeper than 5 um (the command line).
  const double depth_um = beyond["marks"][0]["depth_um"].get<double>();
  ASSERT_GT(depth_um, 15.0);
  ASSERT_LT(depth_um, 25.0);
  // The planted disturbance: 20 um along y, the wall's normal (wall_options).
  EXPECT_NEAR(depth_um, 20.0, 1.0);
  // The marks the verdict counts beyond their tolerance, counted here from the marks' own
  // depths against the tolerance each should be judged by (the wall's, else the part's).
  const auto count_beyond = [](const nlohmann::json& report, double wall_um, double part_um) {
    int count = 0;
    for (const auto& mark : report["marks"]) {
      const bool on_wall = mark.value("design_surface", "") == "sealing wall";
      count += mark["depth_um"].get<double>() > (on_wall ? wall_um : part_um) ? 1 : 0;
    }
    return count;
  };
  EXPECT_GE(count_beyond(beyond, 15.0, 30.0), 1);
  EXPECT_EQ(beyond["verdict"]["marks_beyond_tolerance"].get<int>(), count_beyond(beyond, 15.0, 30.0));
  EXPECT_EQ(beyond["marks"][0]["design_surface"], "sealing wall");
  EXPECT_NEAR(beyond["marks"][0]["tolerance_um"].get<double>(), 15.0, 1e-9);
  EXPECT_EQ(beyond["verdict"]["status"], "not_within") << beyond["verdict"].dump(2);
  EXPECT_NE(beyond["verdict"]["headline"].get<std::string>().find("on sealing wall (tolerance 15 um)"),
            std::string::npos)
      << beyond["verdict"]["headline"];
  const std::string html = read_file(options.out_dir + "/report.html");
  EXPECT_NE(html.find("<li><b>sealing wall</b>: tolerance 15 um (its own, part file), "), std::string::npos);

  with_tolerances("25", "10");
  const nlohmann::json within = app::simulate_part(options, kSilent);
  ASSERT_FALSE(within["marks"].empty());
  EXPECT_NEAR(within["marks"][0]["depth_um"].get<double>(), depth_um, 1e-9);
  EXPECT_NEAR(within["marks"][0]["tolerance_um"].get<double>(), 25.0, 1e-9);
  EXPECT_EQ(within["verdict"]["status"], "within") << within["verdict"].dump(2);
  EXPECT_EQ(count_beyond(within, 25.0, 10.0), 0);
  EXPECT_EQ(within["verdict"]["marks_beyond_tolerance"].get<int>(), 0);
  // The command line's 5 um does not override the wall's own tolerance.
  options.tolerance_m = 5e-6;
  const nlohmann::json option = app::simulate_part(options, kSilent);
  ASSERT_FALSE(option["marks"].empty());
  EXPECT_NEAR(option["marks"][0]["tolerance_um"].get<double>(), 25.0, 1e-9);
  EXPECT_EQ(option["verdict"]["status"], "within") << option["verdict"].dump(2);
  EXPECT_EQ(option["verdict"]["tolerance_source"], "--tolerance-um");
}

// A flat end mill D10 flank-milling a design cylinder of radius 10 mm (a boss, material inside)
// or 15 mm (a bore, material outside) about the z axis, its tip at z = 20 mm: one arc of tip
// radius `tip_radius_mm` from `first_deg` to `last_deg` (points every 0.5 deg), plunging at the
// first point from 35 mm. The design patch is z from 20 to 30 mm (the stock's top).
std::string cylinder_part(const std::filesystem::path& folder, double radius_mm, bool boss, double tip_radius_mm,
                          double first_deg, double last_deg, double stock_half_width_mm) {
  std::ostringstream apt;
  const auto point = [&](double deg, double z) {
    const double a = deg * std::numbers::pi / 180.0;
    return format_double(tip_radius_mm * std::cos(a)) + "," + format_double(tip_radius_mm * std::sin(a)) + "," +
           format_double(z);
  };
  apt << "PARTNO/flank milling a cylinder\nUNITS/MM\nCUTTER/10,0\nFEDRAT/MMPM,10000\nFROM/" << point(first_deg, 50)
      << "\nRAPID\nGOTO/" << point(first_deg, 35) << "\n";
  for (double deg = first_deg; deg <= last_deg + 1e-9; deg += 0.5) apt << "GOTO/" << point(deg, 20) << "\n";
  apt << "RAPID\nGOTO/" << point(last_deg, 50) << "\nFINI\n";
  std::ofstream(folder / "toolpath.apt") << apt.str();
  const std::string w = format_double(stock_half_width_mm);
  std::ofstream(folder / "part.yaml")
      << "name: cylinder_flank\n"
         "description: flank milling a design cylinder about z\n"
         "machine: " << kRoot << "/samples/machines/mikron_ucp710.yaml\n"
         "toolpath: toolpath.apt\n"
         "tool: {type: flat, diameter_mm: 10, corner_radius_mm: 0, length_mm: 60}\n"
         "stock: {box: {min_mm: [-" << w << ", -" << w << ", 10], max_mm: [" << w << ", " << w << ", 30]}}\n"
         "design:\n"
         "  surfaces:\n"
         "    - {type: cylinder, axis_point_mm: [0, 0, 0], axis_direction: [0, 0, 1], radius_mm: "
      << format_double(radius_mm) << ", material: " << (boss ? "inside" : "outside") << ", z_range_mm: [20, 30]}\n"
         "    - {type: plane, point_mm: [0, 0, 20], normal: [0, 0, 1], role: floor}\n"
         // Perfect drives: the reference feed only sets how many servo samples the run takes.
         "feeds: {production_mm_per_min: 10000, reference_mm_per_min: 2000}\n";
  return (folder / "part.yaml").string();
}

// Perfect drives and, in the production run, the tip moved by `shift_m` along the radius from the
// z axis (+: away from it) while its azimuth is within `half_deg` of `centre_deg`.
app::SimulatePartOptions cylinder_options(const std::filesystem::path& folder, const std::string& part,
                                          double centre_deg, double half_deg, double shift_m) {
  app::SimulatePartOptions options;
  options.part_path = part;
  options.out_dir = (folder / "out").string();
  options.grid_m = 50e-6;
  options.renders = false;
  options.commanded_check = false;
  options.perfect_drives = true;
  const double c = centre_deg * std::numbers::pi / 180.0, half = half_deg * std::numbers::pi / 180.0;
  options.production_disturbance = [c, half, shift_m](double, Eigen::VectorXd& q) {
    const double a = std::atan2(q[1], q[0]);
    if (std::abs(std::remainder(a - c, 2.0 * std::numbers::pi)) > half) return;
    q[0] += shift_m * std::cos(a);
    q[1] += shift_m * std::sin(a);
  };
  return options;
}

// The deepest mark of a view, and its azimuth about z and distance from the z axis [deg, mm].
struct CylinderMark {
  double depth_um = 0.0, azimuth_deg = 0.0, radius_mm = 0.0, z_mm = 0.0;
  std::string kind;
};
CylinderMark deepest_on(const nlohmann::json& report, const std::string& view) {
  CylinderMark deepest;
  for (const auto& mark : report["marks"]) {
    if (mark["view"] != view || mark["depth_um"].get<double>() <= deepest.depth_um) continue;
    const auto& p = mark["deepest_point_mm"];
    deepest.depth_um = mark["depth_um"].get<double>();
    deepest.kind = mark["kind"].get<std::string>();
    deepest.azimuth_deg = std::atan2(p[1].get<double>(), p[0].get<double>()) * 180.0 / std::numbers::pi;
    deepest.radius_mm = std::hypot(p[0].get<double>(), p[1].get<double>());
    deepest.z_mm = p[2].get<double>();
  }
  return deepest;
}

// A boss R10 flank-milled all round (tip circle R15), X and Y 20 um towards the axis while the
// azimuth is 30 to 60 deg: the cylinder view (lines along the boss's normals) reads a 20 um gouge
// there, on the boss 20 um inside R10. The Z-map sees the vertical wall as a step: not assessed.
TEST(SimulatePart, APlantedDeviationOnABossIsItsDepthAlongTheNormalOnTheCylinderView) {
  const auto folder = test::fresh_folder("simulate_boss");
  const std::string part = cylinder_part(folder, 10.0, true, 15.0, 0.0, 360.0, 22.0);
  const nlohmann::json report = app::simulate_part(cylinder_options(folder, part, 45.0, 15.0, -20e-6), kSilent);
  const auto& views = report["surface"]["views"];
  ASSERT_EQ(views.size(), 2u) << views.dump(2);
  EXPECT_EQ(views[1]["id"], "cylinder1");
  EXPECT_NE(views[1]["title"].get<std::string>().find("all round"), std::string::npos) << views[1]["title"];
  const CylinderMark mark = deepest_on(report, "cylinder1");
  EXPECT_EQ(mark.kind, "gouge");
  EXPECT_NEAR(mark.depth_um, 20.0, 0.5) << report["marks"].dump(2);
  EXPECT_GT(mark.azimuth_deg, 30.0 - 0.5);
  EXPECT_LT(mark.azimuth_deg, 60.0 + 0.5);
  EXPECT_NEAR(mark.radius_mm, 10.0 - 0.02, 1e-3);
  EXPECT_GE(mark.z_mm, 20.0 - 1e-9);
  EXPECT_LE(mark.z_mm, 30.0 + 1e-9);
  EXPECT_GT(views[0]["steep_lines_not_assessed"].get<std::size_t>(), 0u);
  EXPECT_LT(deepest_on(report, "zmap").depth_um, 0.5) << report["marks"].dump(2);
  // Away from the planted stretch the boss is where the flank put it.
  EXPECT_LT(views[1]["deviation_max_um"].get<double>(), 0.2);
}

// A bore R15 (material outside) milled over an arc of tip radius 10 from 120 to 240 deg, X and Y
// 20 um away from the axis while the azimuth is within 10 deg of 180: the cylinder view, over
// the arc's band only (across azimuth 180 deg), reads the 20 um gouge there, 20 um beyond R15.
TEST(SimulatePart, APlantedDeviationInABoreIsItsDepthAlongTheNormalOnTheCylinderView) {
  const auto folder = test::fresh_folder("simulate_bore");
  const std::string part = cylinder_part(folder, 15.0, false, 10.0, 120.0, 240.0, 22.0);
  const nlohmann::json report = app::simulate_part(cylinder_options(folder, part, 180.0, 10.0, 20e-6), kSilent);
  const auto& views = report["surface"]["views"];
  ASSERT_EQ(views.size(), 2u) << views.dump(2);
  EXPECT_EQ(views[1]["id"], "cylinder1");
  EXPECT_EQ(views[1]["title"].get<std::string>().find("all round"), std::string::npos) << views[1]["title"];
  // The band: the arc widened by the tool diameter (10 mm of arc on R15, 38.2 deg) each side.
  const double band_deg = 120.0 + 2 * 10.0 / 15.0 * 180.0 / std::numbers::pi;
  const double spacing_mm = app::kCylinderViewMinSpacing_m * 1e3;
  EXPECT_NEAR((views[1]["nu"].get<double>() - 1) * spacing_mm / 15.0 * 180.0 / std::numbers::pi, band_deg,
              spacing_mm / 15.0 * 180.0 / std::numbers::pi + 0.2);
  const CylinderMark mark = deepest_on(report, "cylinder1");
  EXPECT_EQ(mark.kind, "gouge");
  EXPECT_NEAR(mark.depth_um, 20.0, 0.5) << report["marks"].dump(2);
  EXPECT_GT(std::abs(mark.azimuth_deg), 170.0 - 0.5);
  EXPECT_NEAR(mark.radius_mm, 15.0 + 0.02, 1e-3);
  EXPECT_GE(mark.z_mm, 20.0 - 1e-9);
  EXPECT_LE(mark.z_mm, 30.0 + 1e-9);
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

// Tools of different lengths in one run (T / M6 with G43 H, TOOL CALL, T D on the 840D): the
// machine axes put the tip of the tool in the spindle where the program says, and every stage
// (kinematics, planner, set-point checks, direct kinematics of the simulated axes, removal) takes
// that tool's length. Expected values are worked out by hand from the sample machine's geometry
// (samples/machines/mikron_ucp710.yaml at A = C = 0: the tip of a tool L long is at W z = 470 - L
// + Z, at W x = X, y = Y) and the part's set-up, not by vmsim's readers.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <numbers>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "chain_inputs.hpp"
#include "cli_runner.hpp"
#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/kinematics/path_kinematics.hpp"
#include "vmsim/planner/feedrate.hpp"

namespace vmsim {
namespace {

namespace fs = std::filesystem;
const std::string kRoot = VMSIM_SOURCE_DIR;

constexpr double kGaugeLineAboveWAtZ0Mm = 470.0;  // the sample machine at A = C = 0
constexpr double kWorkZeroZMm = 20.0;             // G54: the stock's top
constexpr double kShortMm = 60.0, kLongMm = 95.0;

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// A part with two flat end mills of different lengths; `program` is written as `file`.
fs::path write_part(const fs::path& folder, const std::string& file, const std::string& program) {
  std::ofstream(folder / file) << program;
  std::ofstream(folder / "part.yaml")
      << "name: two_lengths\n"
         "machine: " << kRoot << "/samples/machines/mikron_ucp710.yaml\n"
         "toolpath: " << file << "\n"
         "tools:\n"
         "  - {number: 1, type: flat, diameter_mm: 10, length_mm: 60, cutting_length_mm: 25}\n"
         "  - {number: 2, type: flat, diameter_mm: 6, length_mm: 95, cutting_length_mm: 25}\n"
         "stock: {box: {min_mm: [-30, -15, 0], max_mm: [30, 15, 20]}}\n"
         "setup:\n"
         "  work_offsets_mm: {G54: [0, 0, 20]}\n"
         "feeds: {production_mm_per_min: 2000, reference_mm_per_min: 100}\n";
  return folder / "part.yaml";
}

// T1 (60 mm) cuts a flat at Z-5 from, T2 (95 mm) one at Z-8 from X5 to X20; the
// lines of the two cutting moves into the flats' far ends are returned by each program.
struct Program {
  const char* file;
  const char* text;
  int t1_flat_line, t2_flat_line;  ///< the G1 / L blocks that end at X-5 Z-5 and X20 Z-8
};

const Program kGcode{"program.nc",
                     "G90 G94 G17 G49 G40 G80\n"  // 1
                     "G21\n"                      // 2
                     "G28 G91 Z0.\n"              // 3
                     "G90\n"                      // 4
                     "T1 M6\n"                    // 5
                     "G54\n"                      // 6
                     "G0 X-20. Y0.\n"             // 7
                     "G43 Z10. H1\n"              // 8
                     "G1 Z-5. F500.\n"            // 9
                     "X-5.\n"                     // 10
                     "G0 Z10.\n"                  // 11
                     "G28 G91 Z0.\n"              // 12
                     "G90\n"                      // 13
                     "T2 M6\n"                    // 14
                     "G0 X5. Y0.\n"               // 15
                     "G43 Z10. H2\n"              // 16
                     "G1 Z-8. F500.\n"            // 17
                     "X20.\n"                     // 18
                     "G0 Z10.\n"                  // 19
                     "G28 G91 Z0.\n"              // 20
                     "M30\n",
                     10, 18};

const Program kTnc{"program.h",
                   "0 BEGIN PGM TWO MM\n"                 // 1
                   "1 TOOL CALL 1 Z S5000\n"              // 2
                   "2 L X-20 Y+0 Z+10 R0 FMAX\n"          // 3
                   "3 L Z-5 F500\n"                       // 4
                   "4 L X-5\n"                            // 5
                   "5 L Z+10 FMAX\n"                      // 6
                   "6 TOOL CALL 2 Z S5000\n"              // 7
                   "7 L X+5 Y+0 FMAX\n"                   // 8
                   "8 L Z-8 F500\n"                       // 9
                   "9 L X+20\n"                           // 10
                   "10 L Z+10 FMAX\n"                     // 11
                   "11 END PGM TWO MM\n",
                   5, 10};

const Program kSiemens{"program.mpf",
                       "G90 G17 G71 G54\n"    // 1
                       "T1 M6 D1\n"           // 2
                       "G0 X-20 Y0 Z10\n"     // 3
                       "G1 Z-5 F500\n"        // 4
                       "X-5\n"                // 5
                       "G0 Z10\n"             // 6
                       "T2 M6 D1\n"           // 7
                       "G0 X5 Y0\n"           // 8
                       "Z10\n"                // 9
                       "G1 Z-8 F500\n"        // 10
                       "X20\n"                // 11
                       "G0 Z10\n"             // 12
                       "M30\n",
                       5, 11};

/// The kinematics trace's rows: column name -> values, and the source line of each row.
struct Trace {
  std::map<std::string, std::vector<double>> columns;
};

Trace read_trace(const fs::path& path) {
  Trace trace;
  std::ifstream in(path);
  std::string line;
  std::vector<std::string> names;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> fields;
    std::stringstream split(line);
    for (std::string field; std::getline(split, field, ',');) fields.push_back(field);
    if (names.empty()) {
      names = fields;
      continue;
    }
    for (std::size_t c = 0; c < fields.size() && c < names.size(); ++c) trace.columns[names[c]].push_back(std::stod(fields[c]));
  }
  return trace;
}

// Machine Z where the tip of a tool L long is at work Z: Z = (work zero + Z) + L - 470.
double machine_z_mm(double work_z_mm, double tool_length_mm) {
  return kWorkZeroZMm + work_z_mm + tool_length_mm - kGaugeLineAboveWAtZ0Mm;
}

class ToolLengthsThreeAxis : public ::testing::TestWithParam<Program> {};

// (a) and (c): machine Z at the two flats is the work offset plus each tool's own length, through
// `vmsim kinematics`; `vmsim plan` plans it.
TEST_P(ToolLengthsThreeAxis, MachineZIsTheWorkOffsetPlusEachToolsLength) {
  const Program& p = GetParam();
  const fs::path folder = test::fresh_folder(std::string("tool_lengths_") + p.file);
  const fs::path part = write_part(folder, p.file, p.text);
  const test::RunResult kinematics =
      test::run_vmsim("kinematics --part " + part.string() + " --out " + (folder / "k.csv").string());
  ASSERT_EQ(kinematics.exit_code, 0) << kinematics.output;
  const Trace trace = read_trace(folder / "k.csv");
  ASSERT_TRUE(trace.columns.count("line") && trace.columns.count("Z.cmd") && trace.columns.count("X.cmd"));
  const auto& lines = trace.columns.at("line");
  const auto at_line = [&](int line, const char* column) {
    for (std::size_t r = lines.size(); r-- > 0;) {
      if (static_cast<int>(lines[r]) == line) return trace.columns.at(column)[r];
    }
    ADD_FAILURE() << "no row of line " << line;
    return std::nan("");
  };
  // T1: Z-5 with 60 mm: 20 - 5 + 60 - 470 = -395; T2: Z-8 with 95 mm: 20 - 8 + 95 - 470 = -363.
  EXPECT_NEAR(at_line(p.t1_flat_line, "Z.cmd"), machine_z_mm(-5, kShortMm), 1e-6);
  EXPECT_NEAR(at_line(p.t1_flat_line, "X.cmd"), -5.0, 1e-6);
  EXPECT_NEAR(at_line(p.t2_flat_line, "Z.cmd"), machine_z_mm(-8, kLongMm), 1e-6);
  EXPECT_NEAR(at_line(p.t2_flat_line, "X.cmd"), 20.0, 1e-6);
  EXPECT_NEAR(machine_z_mm(-5, kShortMm), -395.0, 1e-12);
  EXPECT_NEAR(machine_z_mm(-8, kLongMm), -363.0, 1e-12);
  const test::RunResult plan = test::run_vmsim("plan --no-plot --no-third-order --part " + part.string() + " --out " +
                                               (folder / "plan").string());
  EXPECT_EQ(plan.exit_code, 0) << plan.output;
  fs::remove_all(folder);
}

INSTANTIATE_TEST_SUITE_P(Readers, ToolLengthsThreeAxis, ::testing::Values(kGcode, kTnc, kSiemens),
                         [](const ::testing::TestParamInfo<Program>& program_info) {
                           const std::string file = program_info.param.file;
                           return file == "program.nc" ? std::string("Gcode")
                                  : file == "program.h" ? std::string("Heidenhain")
                                                        : std::string("Siemens840d");
                         });

std::vector<double> heights(const fs::path& file, int& nu, int& nv, Eigen::Vector3d& origin, double& spacing) {
  const std::string bytes = read_text(file);
  const std::size_t header = 8 + 3 * 4 + 4 * 8;
  std::int32_t dims[3];
  std::memcpy(dims, bytes.data() + 8, sizeof dims);
  nu = dims[0];
  nv = dims[1];
  double geometry[4];
  std::memcpy(geometry, bytes.data() + 20, sizeof geometry);
  origin = Eigen::Vector3d(geometry[0], geometry[1], geometry[2]);
  spacing = geometry[3];
  std::vector<double> out(static_cast<std::size_t>(nu) * static_cast<std::size_t>(nv));
  std::memcpy(out.data(), bytes.data() + header, out.size() * 8);
  return out;
}

// (a) through simulate-part: every check ok, and the Z-map at each flat is where the program
// puts it (15 mm and 12 mm in W), between them (T1 D10 reaches x = 0, T2 D6 x = 2) the stock's top untouched (no tool cuts across
// the change: the new tool's first motion starts where its own tip was).
TEST(ToolLengths, SimulatePartCutsEachFlatAtItsProgrammedHeight) {
  const fs::path folder = test::fresh_folder("tool_lengths_simulate");
  const fs::path part = write_part(folder, kGcode.file, kGcode.text);
  const test::RunResult run = test::run_vmsim("-q simulate-part --no-renders --grid-um 250 --part " + part.string() +
                                              " --out " + (folder / "sim").string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const nlohmann::json report = nlohmann::json::parse(read_text(folder / "sim" / "report.json"));
  for (const auto& check : report["validity_checks"]) {
    EXPECT_EQ(check["status"], "ok") << check.dump();  // the G28 overshoot too: within tolerance
  }
  for (const char* run_file : {"production_heights.bin", "reference_heights.bin"}) {
    int nu = 0, nv = 0;
    Eigen::Vector3d origin;
    double spacing = 0.0;
    const std::vector<double> h = heights(folder / "sim" / run_file, nu, nv, origin, spacing);
    ASSERT_GT(nu, 0);
    const auto height_mm = [&](double x_mm, double y_mm) {
      const int iu = static_cast<int>(std::lround((x_mm * 1e-3 - origin.x()) / spacing));
      const int iv = static_cast<int>(std::lround((y_mm * 1e-3 - origin.y()) / spacing));
      return (origin.z() + h[static_cast<std::size_t>(iu + nu * iv)]) * 1e3;
    };
    // Z-map lines are exact heights; the drives' following error at 2000 mm/min is far below
    // 1 um on a plane.
    for (double y : {-2.0, 0.0, 2.0}) {
      EXPECT_NEAR(height_mm(-12.5, y), 15.0, 1e-3) << run_file << " T1 flat, y = " << y;
      EXPECT_NEAR(height_mm(12.5, y), 12.0, 1e-3) << run_file << " T2 flat, y = " << y;
      EXPECT_NEAR(height_mm(1.0, y), 20.0, 1e-9) << run_file << " between the flats, y = " << y;
    }
    // Each flat as wide as its tool: D10 leaves |y| < 5 at 15 mm, D6 |y| < 3 at 12 mm.
    EXPECT_NEAR(height_mm(-12.5, 4.5), 15.0, 1e-3) << run_file;
    EXPECT_NEAR(height_mm(-12.5, 5.5), 20.0, 1e-9) << run_file;
    EXPECT_NEAR(height_mm(12.5, 2.5), 12.0, 1e-3) << run_file;
    EXPECT_NEAR(height_mm(12.5, 3.5), 20.0, 1e-9) << run_file;
  }
  fs::remove_all(folder);
}

// (b) 5-axis TCP (G43.4) on the table-table sample machine, the tool change between two tilted
// moves: the set points' direct kinematics, each with the length of the tool in the spindle
// (T2 from line 13 on), give the programmed tips (work zero + X Y Z) within the planner's path
// tolerance; the same set points with the other tool's length would be 35 mm off.
TEST(ToolLengths, TcpSetPointsPutEachToolsTipOnTheProgrammedPath) {
  const fs::path folder = test::fresh_folder("tool_lengths_tcp");
  const std::string program =
      "G90 G94 G17 G21 G54\n"                 // 1
      "T1 M6\n"                               // 2
      "G43.4 H1\n"                            // 3
      "G0 X0. Y0. Z30. A0. C0.\n"             // 4
      "G0 A-20. C0.\n"                        // 5  tilted at the safe height
      "G1 Z-2. F1000.\n"                      // 6
      "G1 X20. Y0. Z-2.\n"                    // 7
      "G1 X22. Y1. Z-2. A-21. C3.\n"          // 8  5-axis: tip and tool axis move
      "G0 Z30.\n"                             // 9
      "G49\n"                                 // 10
      "G28 G91 Z0.\n"                         // 11
      "G90\n"                                 // 12
      "T2 M6\n"                               // 13
      "G43.4 H2\n"                            // 14
      "G0 X20. Y10. Z30. A-21. C3.\n"         // 15
      "G1 Z-2. F1000.\n"                      // 16
      "G1 X22. Y11. Z-2. A-22. C6.\n"         // 17 5-axis
      "G1 X0. Y10. Z-2.\n"                    // 18
      "G0 Z30.\n"                             // 19
      "G49\n"                                 // 20
      "G28 G91 Z0.\n"                         // 21
      "M30\n";
  const fs::path part = write_part(folder, "program.nc", program);
  app::ChainInputOptions options;
  options.part_path = part.string();
  const app::ChainInputs inputs = app::load_chain_inputs(options);
  const kinematics::PathKinematics path = kinematics::solve_path_kinematics(
      inputs.machine, inputs.path, inputs.q_start, inputs.tool_length_m, inputs.block_names, inputs.path_kinematics);
  planner::FeedrateOptions plan_options;
  plan_options.third_order = false;
  plan_options.point_feed_m_per_s = app::point_feeds_m_per_s(inputs, path, app::FeedSetting{1000.0 / 60000.0, 0.0});
  plan_options.rapid_end = app::rapid_ends(inputs);
  const planner::FeedratePlan plan = planner::plan_feedrate(inputs.machine, path, plan_options);
  // The programmed feed moves, by hand: tips in W = (0, 0, 20) + X Y Z; the tool of each.
  struct Move {
    int line;
    Eigen::Vector3d from_mm, to_mm;
    double tool_mm;
    bool turns;  ///< the tool axis turns: the planner's turning tolerance applies
  };
  const std::vector<Move> moves{{6, {0, 0, 50}, {0, 0, 18}, kShortMm, false},
                                {7, {0, 0, 18}, {20, 0, 18}, kShortMm, false},
                                {8, {20, 0, 18}, {22, 1, 18}, kShortMm, true},
                                {16, {20, 10, 50}, {20, 10, 18}, kLongMm, false},
                                {17, {20, 10, 18}, {22, 11, 18}, kLongMm, true},
                                {18, {22, 11, 18}, {0, 10, 18}, kLongMm, false}};
  std::map<int, std::size_t> checked;
  for (std::size_t k = 0; k < plan.setpoints.s_m.size(); ++k) {
    // The path point the set point's motion runs towards, and its source line.
    const double s = plan.setpoints.s_m[k];
    std::size_t i = 0;
    while (i + 1 < path.s_m.size() && path.s_m[i] < s) ++i;
    if (i == 0 || !(s > path.s_m[i - 1])) continue;  // at a point: either motion's end
    const int line = inputs.toolpath.blocks[static_cast<std::size_t>(inputs.path[i].block)].line;
    for (const Move& move : moves) {
      if (move.line != line) continue;
      const Eigen::VectorXd q = plan.setpoints.q.col(static_cast<Eigen::Index>(k));
      const Eigen::Vector3d tip = kinematics::forward_kinematics(inputs.machine, q, move.tool_mm * 1e-3).tip_W_m;
      const Eigen::Vector3d a = move.from_mm * 1e-3, b = move.to_mm * 1e-3;
      const double f = std::clamp((tip - a).dot(b - a) / (b - a).squaredNorm(), 0.0, 1.0);
      const double tolerance_m = move.turns ? plan_options.turning_path_tolerance_m : plan_options.path_tolerance_m;
      EXPECT_LE((a + f * (b - a) - tip).norm(), tolerance_m) << "line " << line << " s = " << s;
      const double other_mm = move.tool_mm == kShortMm ? kLongMm : kShortMm;
      const Eigen::Vector3d other = kinematics::forward_kinematics(inputs.machine, q, other_mm * 1e-3).tip_W_m;
      EXPECT_NEAR((other - tip).norm(), 35e-3, 1e-9);
      ++checked[line];
    }
  }
  for (const Move& move : moves) EXPECT_GE(checked[move.line], 10u) << "line " << move.line;
  // The programmed rotary words are the axes (the program's branch), with either tool.
  const int a_axis = inputs.machine.axis_index("A"), c_axis = inputs.machine.axis_index("C");
  for (std::size_t i = 0; i < inputs.path.size(); ++i) {
    const int line = inputs.toolpath.blocks[static_cast<std::size_t>(inputs.path[i].block)].line;
    if (line == 17) {
      EXPECT_NEAR(path.q(a_axis, static_cast<Eigen::Index>(i)) * 180.0 / std::numbers::pi, -22.0, 1e-9);
      EXPECT_NEAR(path.q(c_axis, static_cast<Eigen::Index>(i)) * 180.0 / std::numbers::pi, 6.0, 1e-9);
      const Eigen::Vector3d tip =
          kinematics::forward_kinematics(inputs.machine, path.q.col(static_cast<Eigen::Index>(i)), kLongMm * 1e-3).tip_W_m;
      EXPECT_TRUE(tip.isApprox(Eigen::Vector3d(22e-3, 11e-3, 18e-3), 1e-9)) << tip.transpose();
    }
  }
  // And simulate-part runs it with every check ok.
  const test::RunResult run = test::run_vmsim("-q simulate-part --no-renders --grid-um 400 --reference-feed-mm-per-min 200 --part " +
                                              part.string() + " --out " + (folder / "sim").string());
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const nlohmann::json report = nlohmann::json::parse(read_text(folder / "sim" / "report.json"));
  for (const auto& check : report["validity_checks"]) {
    EXPECT_EQ(check["status"], "ok") << check.dump();
  }
  fs::remove_all(folder);
}

}  // namespace
}  // namespace vmsim

// The Heidenhain TNC corpus (tests/data/posted_tnc/: conversational programs as hyperMILL, NX
// and PowerMill posts write them, 3-axis, 3+2 and simultaneous 5-axis, each with its part file)
// runs unmodified through `vmsim kinematics`, `vmsim plan` and `vmsim simulate-part`, with the
// program's BLK FORM as the stock; and each program gives the same poses as the same tool path
// written in ISO G-code (program_iso.nc beside it, read by the G-code reader, an independent
// reader of the same motion).
#include <gtest/gtest.h>

#include <Eigen/Core>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "chain_inputs.hpp"
#include "cli_runner.hpp"

namespace vmsim {
namespace {

namespace fs = std::filesystem;

const fs::path kCorpus = fs::path(VMSIM_SOURCE_DIR) / "tests/data/posted_tnc";

struct Case {
  const char* folder;
  /// How close the two programs' poses are [mm]: both round their numbers to 3 decimals; in the
  /// tilted plane the TNC's numbers are in the tilted axes and the ISO's in W (each rounded), and
  /// the ISO twin gives the tilted links as chords of 2 deg (0.4 um from the arc).
  double same_within_mm;
  bool simulate;  ///< simulate-part runs to the end (see the note at kCases)
  /// The stock in W [mm]: the program's BLK FORM (MIN, MAX in the preset's coordinates) moved
  /// by the preset's place in W (the part file's G54).
  std::vector<double> stock_min_mm, stock_max_mm;
};

// powermill_5axis used to stop at simulate-part's check of the reference (3.1 um against the
// programmed polyline's surface, limit 2 um); the check now cuts the planned path the set points
// follow, and the program runs through.
const Case kCases[] = {
    {"hypermill_3axis", 2e-3, true, {-50, -40, 0}, {50, 40, 30}},  // BLK FORM Z-30 .. Z+0, preset at W z 30
    {"nx_3plus2", 2e-3, true, {-50, -40, 0}, {50, 40, 30}},
    {"powermill_5axis", 2e-3, true, {-30, -30, 0}, {30, 30, 26}},  // BLK FORM Z+0 .. Z+26, preset at W 0
    // APPR PLT / DEP LT under RL, LBL section repeats and subprograms, cycles 200 / 203: the ISO
    // twin gives the tool centre and each cycle's moves computed by generate.py.
    {"hypermill_contour_holes", 2e-3, true, {-50, -40, 0}, {50, 40, 30}},
};

class PostedTncProgram : public ::testing::TestWithParam<Case> {};

TEST_P(PostedTncProgram, RunsUnmodifiedThroughKinematicsPlanAndSimulatePart) {
  const Case& c = GetParam();
  const fs::path part = kCorpus / c.folder / "part.yaml";
  const fs::path out = test::fresh_folder(std::string("posted_tnc_") + c.folder);
  const test::RunResult kinematics =
      test::run_vmsim("kinematics --part " + part.string() + " --out " + (out / "k.csv").string());
  ASSERT_EQ(kinematics.exit_code, 0) << kinematics.output;
  const test::RunResult plan = test::run_vmsim("plan --no-plot --no-third-order --part " + part.string() +
                                               " --out " + (out / "plan").string());
  ASSERT_EQ(plan.exit_code, 0) << plan.output;
  if (!c.simulate) return;
  const test::RunResult simulate = test::run_vmsim("-q simulate-part --no-renders --grid-um 200 --part " +
                                                   part.string() + " --out " + (out / "sim").string());
  ASSERT_EQ(simulate.exit_code, 0) << simulate.output;
  // The stock is the program's BLK FORM (the part file gives none), in W (Case::stock_*).
  std::ifstream report_file(out / "sim" / "report.json");
  const nlohmann::json report = nlohmann::json::parse(report_file);
  const std::vector<double> min = report["stock"]["min_mm"], max = report["stock"]["max_mm"];
  ASSERT_EQ(min.size(), 3u);
  ASSERT_EQ(max.size(), 3u);
  for (std::size_t k = 0; k < 3; ++k) {  // (the preset's offset went through the kinematics: 1e-12 mm)
    EXPECT_NEAR(min[k], c.stock_min_mm[k], 1e-9) << k;
    EXPECT_NEAR(max[k], c.stock_max_mm[k], 1e-9) << k;
  }
}

/// The tool path as the chain reads it (the part's machine and set-up), corners not blended.
toolpath::Toolpath read_through_the_part(const fs::path& part, const fs::path& program) {
  app::ChainInputOptions options;
  options.part_path = part.string();
  options.toolpath_path = program.string();
  options.corner_tolerance_override = true;  // with 0: no blending, the points as read
  options.corner_tolerance_m = 0.0;
  return app::load_chain_inputs(options).toolpath;
}

/// The distance [mm] from pose (p, a) to the polyline of `path`'s poses and the angle [rad]
/// between a and the polyline's axis there (the smallest over segments within `near_mm` of p:
/// a turn on the spot has several axes at one tip).
std::pair<double, double> distance_to(const toolpath::Toolpath& path, const Eigen::Vector3d& p_mm,
                                      const Eigen::Vector3d& axis, double near_mm) {
  double best = std::numeric_limits<double>::infinity();
  double best_angle = std::numeric_limits<double>::infinity();
  for (std::size_t i = 0; i + 1 < path.points.size(); ++i) {
    const Eigen::Vector3d a = path.points[i].tip_W_m * 1e3, b = path.points[i + 1].tip_W_m * 1e3;
    const Eigen::Vector3d d = b - a;
    const double t = d.squaredNorm() > 0 ? std::clamp((p_mm - a).dot(d) / d.squaredNorm(), 0.0, 1.0) : 0.0;
    const double distance = (a + t * d - p_mm).norm();
    best = std::min(best, distance);
    if (distance <= near_mm) {
      // Along a turn on the spot (d = 0) every axis between the two ends is on the path.
      for (const double s : d.squaredNorm() > 0 ? std::vector<double>{t} : std::vector<double>{0.0, 0.25, 0.5, 0.75, 1.0}) {
        const Eigen::Vector3d along =
            ((1 - s) * path.points[i].axis_W + s * path.points[i + 1].axis_W).normalized();
        best_angle = std::min(best_angle, std::atan2(along.cross(axis).norm(), along.dot(axis)));
      }
    }
  }
  return {best, best_angle};
}

TEST_P(PostedTncProgram, GivesTheSamePosesAsItsIsoTwin) {
  const Case& c = GetParam();
  const fs::path part = kCorpus / c.folder / "part.yaml";
  const toolpath::Toolpath tnc = read_through_the_part(part, kCorpus / c.folder / "program.h");
  const toolpath::Toolpath iso = read_through_the_part(part, kCorpus / c.folder / "program_iso.nc");
  ASSERT_GT(tnc.points.size(), 50u);
  // Both ways: every pose of one lies on the other's path (tip and axis).
  for (const auto& [from, to, name] : {std::tuple{&tnc, &iso, "TNC on ISO"}, std::tuple{&iso, &tnc, "ISO on TNC"}}) {
    double worst_mm = 0.0, worst_rad = 0.0;
    std::size_t worst_point = 0;
    for (std::size_t i = 0; i < from->points.size(); ++i) {
      const auto [distance, angle] =
          distance_to(*to, from->points[i].tip_W_m * 1e3, from->points[i].axis_W, c.same_within_mm);
      if (distance > worst_mm) worst_point = i;
      worst_mm = std::max(worst_mm, distance);
      worst_rad = std::max(worst_rad, angle);
    }
    EXPECT_LE(worst_mm, c.same_within_mm) << name << ", worst at point " << worst_point;
    // 3-decimal numbers in the 3+2 program move the tip, not the axis; the 7-decimal tool
    // vectors and 3-decimal angles of the 5-axis program turn it by at most 1e-5 rad.
    EXPECT_LE(worst_rad, 2e-5) << name;
  }
  // The same first and last pose.
  EXPECT_LE((tnc.points.front().tip_W_m - iso.points.front().tip_W_m).norm() * 1e3, c.same_within_mm);
  EXPECT_LE((tnc.points.back().tip_W_m - iso.points.back().tip_W_m).norm() * 1e3, c.same_within_mm);
  EXPECT_EQ(tnc.stock_box.has_value(), true);
}

INSTANTIATE_TEST_SUITE_P(Corpus, PostedTncProgram, ::testing::ValuesIn(kCases),
                         [](const ::testing::TestParamInfo<Case>& case_info) { return std::string(case_info.param.folder); });

// A TNC program with an error: the file, line, column and word; exit 3; nothing written.
TEST(PostedTncProgram, BadInputExitsThreeAndWritesNothing) {
  const fs::path folder = test::fresh_folder("posted_tnc_bad");
  fs::copy_file(kCorpus / "hypermill_3axis" / "part.yaml", folder / "part.yaml");
  std::ifstream in(kCorpus / "hypermill_3axis" / "program.h");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const std::string good = "23 L X+30 Y-20\n";
  ASSERT_NE(text.find(good), std::string::npos);
  // APPR LT without its length LEN: a located error naming the word.
  text.replace(text.find(good), good.size(), "23 APPR LT X+30 Y-20 RL\n");
  std::ofstream(folder / "program.h") << text;
  // The part file names the machine relative to the corpus folder.
  std::string part_text;
  {
    std::ifstream part_in(folder / "part.yaml");
    part_text.assign((std::istreambuf_iterator<char>(part_in)), std::istreambuf_iterator<char>());
  }
  const std::string machine = "../../../../samples/machines/mikron_ucp710.yaml";
  part_text.replace(part_text.find(machine), machine.size(),
                    (fs::path(VMSIM_SOURCE_DIR) / "samples/machines/mikron_ucp710.yaml").string());
  std::ofstream(folder / "part.yaml") << part_text;
  for (const std::string& command : {"kinematics --out " + (folder / "k.csv").string(),
                                    "simulate-part --no-renders --out " + (folder / "sim").string()}) {
    const test::RunResult run = test::run_vmsim(command + " --part " + (folder / "part.yaml").string());
    EXPECT_EQ(run.exit_code, 3) << run.output;
    EXPECT_NE(run.output.find("program.h:24:9: 'LT': APPR LT needs the length LEN"), std::string::npos) << run.output;
  }
  EXPECT_FALSE(fs::exists(folder / "k.csv"));
  EXPECT_FALSE(fs::exists(folder / "sim"));
}

}  // namespace
}  // namespace vmsim

// The posted-program corpus (tests/data/posted/: ISO G-code as ten CAM posts and controls write
// it, each with its part file) runs unmodified through `vmsim kinematics` and `vmsim plan`, and
// the axes go where the program and the set-up put them. The expected axis positions are computed
// here from the program text with a small reader of its own (absolute blocks that give or keep
// X, Y and Z, outside cycles, macros and reference returns), not by vmsim's G-code reader.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include "cli_runner.hpp"

namespace vmsim {
namespace {

namespace fs = std::filesystem;

const fs::path kCorpus = fs::path(VMSIM_SOURCE_DIR) / "tests/data/posted";

// The sample machine (samples/machines/mikron_ucp710.yaml) at A = C = 0: the tip of a tool of
// length L is at W z = 470 - L + Z (gauge line 600 mm above the base at Z = 0, W 130 mm above
// the base on the table), and at W x = X, y = Y.
constexpr double kToolLengthMm = 60.0;
constexpr double kTipAboveWAtZ0Mm = 470.0 - kToolLengthMm;

std::string read_text(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

/// The set-point rows of a kinematics trace: line -> axis values of the last row of that line.
struct TraceRows {
  std::vector<std::string> columns;
  std::map<int, std::vector<double>> last_row_of_line;
};

TraceRows read_trace(const fs::path& path) {
  TraceRows rows;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::vector<std::string> fields;
    std::stringstream split(line);
    for (std::string field; std::getline(split, field, ',');) fields.push_back(field);
    if (rows.columns.empty()) {
      rows.columns = fields;
      continue;
    }
    std::vector<double> values;
    for (const std::string& field : fields) values.push_back(std::stod(field));
    int line_column = -1;
    for (std::size_t c = 0; c < rows.columns.size(); ++c) {
      if (rows.columns[c] == "line") line_column = static_cast<int>(c);
    }
    if (line_column >= 0) rows.last_row_of_line[static_cast<int>(values[static_cast<std::size_t>(line_column)])] = values;
  }
  return rows;
}

int column_of(const TraceRows& rows, const std::string& name) {
  for (std::size_t c = 0; c < rows.columns.size(); ++c) {
    if (rows.columns[c] == name) return static_cast<int>(c);
  }
  return -1;
}

/// A block with the tool tip's work position fully known: its line and X Y Z in mm.
struct KnownPosition {
  int line = 0;
  double x_mm = 0, y_mm = 0, z_mm = 0;
};

/// Reads the program's plain absolute blocks (see the file comment) and gives every motion block
/// whose end position is known in all three axes.
std::vector<KnownPosition> known_positions(const std::string& program) {
  std::vector<KnownPosition> known;
  std::optional<double> x, y, z;
  double unit_mm = 1.0;
  bool in_cycle = false;
  bool motion_modal = false;
  bool tcp = false;      // G43.4 / G43.5: X Y Z are the tip under TCP, checked elsewhere
  bool shifted = false;  // a G52 / G92 / G10 / G68 seen
  std::istringstream lines(program);
  std::string text;
  int line = 0;
  const std::regex word(R"(([A-Z])\s*([-+]?(?:\d+\.?\d*|\.\d+)))");
  while (std::getline(lines, text)) {
    ++line;
    std::string upper;
    int depth = 0;
    for (char c : text) {  // comments out, upper case
      if (c == '(') ++depth;
      if (depth == 0 && c == ';') break;
      if (depth == 0) upper += static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
      if (c == ')' && depth > 0) --depth;
    }
    if (upper.find_first_of("#[=") != std::string::npos || upper.find("O1") != std::string::npos ||
        upper.find("IF") != std::string::npos || upper.find("WHILE") != std::string::npos) {
      x.reset(), y.reset(), z.reset();  // a macro: this reader does not evaluate it
      continue;
    }
    std::map<char, double> words;
    std::vector<double> g_codes;
    for (auto it = std::sregex_iterator(upper.begin(), upper.end(), word); it != std::sregex_iterator(); ++it) {
      const char letter = (*it)[1].str()[0];
      const double value = std::stod((*it)[2].str());
      if (letter == 'G') {
        g_codes.push_back(value);
      } else {
        words[letter] = value;
      }
    }
    bool plain = true;
    for (double g : g_codes) {
      if (g == 20) unit_mm = 25.4;
      if (g == 21) unit_mm = 1.0;
      if (g == 80) in_cycle = false;
      if (g == 73 || (g >= 81 && g <= 89)) in_cycle = true;
      if (g == 0 || g == 1 || g == 2 || g == 3) motion_modal = true;
      if (std::abs(g - 43.4) < 1e-9 || std::abs(g - 43.5) < 1e-9) tcp = true;
      if (g == 49) tcp = false;
      // Local offsets and rotations: the rest of the program is beyond this reader.
      if (g == 52 || g == 92 || g == 10 || g == 68) shifted = true;
      // Reference returns, machine coordinates, incremental: positions unknown until given again.
      if (g == 28 || g == 30 || g == 53 || g == 91) plain = false;
    }
    if (shifted) break;
    if (!plain || in_cycle || tcp) {
      x.reset(), y.reset(), z.reset();
      continue;
    }
    const bool moves = words.count('X') || words.count('Y') || words.count('Z');
    if (words.count('X')) x = words['X'] * unit_mm;
    if (words.count('Y')) y = words['Y'] * unit_mm;
    if (words.count('Z')) z = words['Z'] * unit_mm;
    if (moves && motion_modal && x && y && z) known.push_back({line, *x, *y, *z});
  }
  return known;
}

struct Case {
  const char* folder;
  const char* program;
  double work_zero_z_mm;  ///< the part file's G54 z
};

const Case kCases[] = {
    {"fusion360_mm", "program.nc", 30},      {"fusion360_inch", "program.nc", 30},
    {"mastercam", "program.nc", 30},         {"powermill", "program.tap", 30},
    {"nx", "program.ptp", 30},               {"freecad_linuxcnc", "program.ngc", 30},
    {"haas", "program.nc", 30},              {"linuxcnc_macros", "program.ngc", 30},
    {"fanuc_macro_b", "program.nc", 30},     {"five_axis_tcp", "program.nc", 0},
};

class PostedProgram : public ::testing::TestWithParam<Case> {};

TEST_P(PostedProgram, RunsUnmodifiedAndTheAxesGoWhereTheProgramPutsThem) {
  const Case& c = GetParam();
  const fs::path part = kCorpus / c.folder / "part.yaml";
  const fs::path out = test::fresh_folder(std::string("posted_") + c.folder);
  const test::RunResult kinematics =
      test::run_vmsim("kinematics --part " + part.string() + " --out " + (out / "k.csv").string());
  ASSERT_EQ(kinematics.exit_code, 0) << kinematics.output;
  const test::RunResult plan = test::run_vmsim("plan --no-plot --part " + part.string() + " --out " +
                                               (out / "plan").string());
  ASSERT_EQ(plan.exit_code, 0) << plan.output;

  const TraceRows rows = read_trace(out / "k.csv");
  const int x_column = column_of(rows, "X.cmd"), y_column = column_of(rows, "Y.cmd"),
            z_column = column_of(rows, "Z.cmd");
  ASSERT_GE(x_column, 0);
  ASSERT_GE(z_column, 0);
  std::size_t checked = 0;
  for (const KnownPosition& known : known_positions(read_text(kCorpus / c.folder / c.program))) {
    const auto row = rows.last_row_of_line.find(known.line);
    if (row == rows.last_row_of_line.end()) continue;  // a block that adds no point (no motion)
    const std::vector<double>& values = row->second;
    // 1 um: the trace's decimals; inch values are exact multiples of 25.4 um.
    EXPECT_NEAR(values[static_cast<std::size_t>(x_column)], known.x_mm, 1e-3) << c.folder << " line " << known.line;
    EXPECT_NEAR(values[static_cast<std::size_t>(y_column)], known.y_mm, 1e-3) << c.folder << " line " << known.line;
    EXPECT_NEAR(values[static_cast<std::size_t>(z_column)], known.z_mm + c.work_zero_z_mm - kTipAboveWAtZ0Mm, 1e-3)
        << c.folder << " line " << known.line;
    ++checked;
  }
  // Programs in TCP mode or driven by macros have few plain blocks; the others have many.
  const std::string folder = c.folder;
  if (folder != "five_axis_tcp" && folder != "linuxcnc_macros" && folder != "fanuc_macro_b") {
    EXPECT_GE(checked, 10u) << c.folder;
  }
}

INSTANTIATE_TEST_SUITE_P(Corpus, PostedProgram, ::testing::ValuesIn(kCases),
                         [](const ::testing::TestParamInfo<Case>& info) { return std::string(info.param.folder); });

// Under G43.4 the rotary axes go to the programmed A and C words (the program chooses the
// branch): every block with A and C gives those axis values.
TEST(PostedProgramFiveAxis, RotaryAxesAreTheProgrammedWords) {
  const fs::path part = kCorpus / "five_axis_tcp/part.yaml";
  const fs::path out = test::fresh_folder("posted_five_axis_words");
  const test::RunResult kinematics =
      test::run_vmsim("kinematics --part " + part.string() + " --out " + (out / "k.csv").string());
  ASSERT_EQ(kinematics.exit_code, 0) << kinematics.output;
  const TraceRows rows = read_trace(out / "k.csv");
  const int a_column = column_of(rows, "A.cmd"), c_column = column_of(rows, "C.cmd");
  ASSERT_GE(a_column, 0);
  ASSERT_GE(c_column, 0);
  std::istringstream lines(read_text(kCorpus / "five_axis_tcp/program.nc"));
  const std::regex words(R"(A([-+]?[\d.]+)\s+C([-+]?[\d.]+))");
  std::string text;
  int line = 0;
  std::size_t checked = 0;
  while (std::getline(lines, text)) {
    ++line;
    std::smatch match;
    if (!std::regex_search(text, match, words)) continue;
    const auto row = rows.last_row_of_line.find(line);
    if (row == rows.last_row_of_line.end()) continue;
    EXPECT_NEAR(row->second[static_cast<std::size_t>(a_column)], std::stod(match[1].str()), 1e-4) << "line " << line;
    EXPECT_NEAR(row->second[static_cast<std::size_t>(c_column)], std::stod(match[2].str()), 1e-4) << "line " << line;
    ++checked;
  }
  EXPECT_GE(checked, 1000u);
}

}  // namespace
}  // namespace vmsim

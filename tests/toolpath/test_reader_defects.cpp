// Tool path readers against hostile input: each test is a defect a user found with mutated
// files (a byte-order mark, bytes that are not UTF-8, subnormal and overflowing numbers, huge
// coordinates, rotary words beyond the travel, a 360 deg turn merged away, arcs that expand
// without bound). The readers are never silently wrong: they read the file as meant, or throw an
// error that names the file, line, column and value.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <cmath>
#include <cstdio>
#include <numbers>
#include <string>
#include <vector>

#include "reader_test_support.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {
namespace {

using test::expect_vector;
using test::input_error_of;

const std::string kBom = "\xEF\xBB\xBF";

Toolpath apt(const std::string& text, const ReaderOptions& options = {}) {
  return parse_apt(text, "part.apt", options);
}
Toolpath gcode(const std::string& text, const ReaderOptions& options = {}) {
  return parse_gcode(text, "part.nc", options);
}
std::string apt_error(const std::string& text) {
  return input_error_of([&] { apt(text); });
}
std::string gcode_error(const std::string& text, const ReaderOptions& options = {}) {
  return input_error_of([&] { gcode(text, options); });
}

#define EXPECT_CONTAINS(text, part) \
  EXPECT_NE(std::string(text).find(part), std::string::npos) << "in: " << (text)

// --- 1. Byte-order mark ----------------------------------------------------------------------

TEST(ReaderDefects, AptByteOrderMarkBeforeUnitsInchesStillReadsInches) {
  const std::string body = "UNITS/INCHES\nFEDRAT/10\nGOTO/1,0,0\nGOTO/2,0,0\n";
  const Toolpath with_bom = apt(kBom + body);
  ASSERT_EQ(with_bom.points.size(), 2u);
  expect_vector(with_bom.points[1].tip_W_m, {2 * 25.4e-3, 0, 0});
  EXPECT_TRUE(with_bom.warnings.empty());
  const Toolpath without = apt(body);
  ASSERT_EQ(without.points.size(), with_bom.points.size());
  for (std::size_t i = 0; i < without.points.size(); ++i) {
    EXPECT_EQ(without.points[i].tip_W_m, with_bom.points[i].tip_W_m);
  }
}

TEST(ReaderDefects, GcodeByteOrderMarkIsSkippedLikeTheAptReaderDoes) {
  const std::string body = "G20 G1 X1 F10\nG1 X2\n";
  const Toolpath with_bom = gcode(kBom + body);
  ASSERT_EQ(with_bom.points.size(), 2u);
  expect_vector(with_bom.points[1].tip_W_m, {2 * 25.4e-3, 0, 0});
  // Columns are counted after the mark, as an editor shows them.
  EXPECT_CONTAINS(gcode_error(kBom + "G1 X1 Q2 F10\n"), "part.nc:1:7:");
}

TEST(ReaderDefects, ByteOrderMarkOnlyFileHasNoMotion) {
  EXPECT_CONTAINS(apt_error(kBom), "no motion");
  EXPECT_CONTAINS(gcode_error(kBom + "\n"), "no motion");
}

// --- 2. Bytes that are not UTF-8 -------------------------------------------------------------

TEST(ReaderDefects, AptByteThatIsNotUtf8IsALocatedInputError) {
  // Was a warning whose text later broke the JSON summary: "internal error", exit 1.
  const std::string message = apt_error("FEDRAT/100\nGOTO/0,0,0\nFOO\xFF/1\nGOTO/1,0,0\n");
  EXPECT_CONTAINS(message, "part.apt:3:4:");
  EXPECT_CONTAINS(message, "0xFF");
  EXPECT_CONTAINS(message, "UTF-8");
}

TEST(ReaderDefects, GcodeByteThatIsNotUtf8IsALocatedInputError) {
  const std::string message = gcode_error("G1 X0 F100\nG1 X1 (caf\xE9)\n");
  EXPECT_CONTAINS(message, "part.nc:2:11:");
  EXPECT_CONTAINS(message, "0xE9");
}

TEST(ReaderDefects, TruncatedUtf8SequenceAndNulAreErrors) {
  EXPECT_CONTAINS(gcode_error("G1 X0 F100\n(\xC3"), "part.nc:2:2:");
  EXPECT_CONTAINS(apt_error(std::string("FEDRAT/100\nGOTO/0,0,0\0\n", 24)), "0x00");
  EXPECT_CONTAINS(apt_error("FEDRAT/100\nGOTO/0,0,0\nPPRINT \xED\xA0\x80\n"), "0xED");  // surrogate
}

TEST(ReaderDefects, Utf8CommentsAreAccepted) {
  EXPECT_EQ(gcode("G1 X0 F100 (café ✓ 𝑥)\nG1 X1\n").points.size(), 2u);
  EXPECT_EQ(apt("PPRINT café\nFEDRAT/100\nGOTO/0,0,0 $$ ✓\nGOTO/1,0,0\n").points.size(), 2u);
}

// --- 3. Numbers: finite, normal, plausible ---------------------------------------------------

TEST(ReaderDefects, AptSubnormalFeedIsRefusedWithItsValue) {
  const std::string message = apt_error("FEDRAT/MMPM,4.9e-324\nGOTO/0,0,0\nGOTO/1,0,0\n");
  EXPECT_CONTAINS(message, "part.apt:1:13:");
  EXPECT_CONTAINS(message, "4.9e-324");
}

TEST(ReaderDefects, AptTinyButNormalFeedIsImplausible) {
  const std::string message = apt_error("FEDRAT/1e-300\nGOTO/0,0,0\nGOTO/1,0,0\n");
  EXPECT_CONTAINS(message, "part.apt:1:8:");
  EXPECT_CONTAINS(message, "1e-300");
  EXPECT_CONTAINS(apt_error("FEDRAT/1e300\nGOTO/0,0,0\nGOTO/1,0,0\n"), "1e300");
}

TEST(ReaderDefects, AptOverflowingNumberIsRefusedWithItsValueAndLine) {
  const std::string message = apt_error("FEDRAT/100\nGOTO/1e400,0,0\n");
  EXPECT_CONTAINS(message, "part.apt:2:6:");
  EXPECT_CONTAINS(message, "1e400");
  EXPECT_CONTAINS(message, "too large");
  EXPECT_CONTAINS(apt_error("FEDRAT/100\nGOTO/1e-400,0,0\n"), "too small");
}

TEST(ReaderDefects, AptHugeCoordinateIsRefused) {
  const std::string message = apt_error("FEDRAT/100\nGOTO/0,0,0\nGOTO/0,1e300,0\n");
  EXPECT_CONTAINS(message, "part.apt:3:8:");
  EXPECT_CONTAINS(message, "1e300");
  // Inches: 1e5 in is 2.54e6 mm, beyond the limit; 1e4 in is not.
  EXPECT_CONTAINS(apt_error("UNITS/INCHES\nFEDRAT/1\nGOTO/1e5,0,0\n"), "1e5");
  EXPECT_EQ(apt("UNITS/INCHES\nFEDRAT/1\nGOTO/1e4,0,0\n").points.size(), 1u);
}

TEST(ReaderDefects, AptCutterSpindleAndTolerancesAreChecked) {
  EXPECT_CONTAINS(apt_error("CUTTER/4.9e-324\nFEDRAT/1\nGOTO/0,0,0\n"), "4.9e-324");
  EXPECT_CONTAINS(apt_error("CUTTER/1e300\nFEDRAT/1\nGOTO/0,0,0\n"), "1e300");
  EXPECT_CONTAINS(apt_error("CUTTER/10,4.9e-324\nFEDRAT/1\nGOTO/0,0,0\n"), "4.9e-324");
  EXPECT_CONTAINS(apt_error("SPINDL/1e400,CLW\nFEDRAT/1\nGOTO/0,0,0\n"), "1e400");
  EXPECT_CONTAINS(apt_error("SPINDL/RPM,1e9\nFEDRAT/1\nGOTO/0,0,0\n"), "spindle speed");
  EXPECT_CONTAINS(apt_error("INTOL/4.9e-324\nFEDRAT/1\nGOTO/0,0,0\n"), "4.9e-324");
  EXPECT_CONTAINS(apt_error("OUTTOL/1e300\nFEDRAT/1\nGOTO/0,0,0\n"), "tolerance");
  // Plain ones pass.
  EXPECT_EQ(apt("SPINDL/RPM,12000,CLW\nINTOL/0.01\nTOLER/0.001,0.002\nFEDRAT/1\nGOTO/0,0,0\n")
                .points.size(),
            1u);
}

TEST(ReaderDefects, AptHugeToolAxisComponentsStillGiveTheirDirection) {
  // The norm of (1e300, 1e300, 0) overflows: was "zero tool axis vector".
  const Toolpath path = apt("TLAXIS/1e300,1e300,0\nFEDRAT/1\nGOTO/0,0,0\n");
  expect_vector(path.points[0].axis_W, Eigen::Vector3d(1, 1, 0).normalized(), 1e-15);
  const Toolpath tiny = apt("FEDRAT/1\nGOTO/0,0,0,1e-200,0,1e-200\n");
  expect_vector(tiny.points[0].axis_W, Eigen::Vector3d(1, 0, 1).normalized(), 1e-15);
}

TEST(ReaderDefects, GcodeSubnormalFeedWrittenWithoutExponentIsRefused) {
  const std::string subnormal = "0." + std::string(323, '0') + "49";
  const std::string message = gcode_error("G1 X1 F" + subnormal + "\n");
  EXPECT_CONTAINS(message, "part.nc:1:7:");
  EXPECT_CONTAINS(message, "subnormal");
  // Normal but implausible.
  EXPECT_CONTAINS(gcode_error("G1 X1 F0.0000000001\n"), "feed rate");
  EXPECT_CONTAINS(gcode_error("G93 G1 X1 F100000000\n"), "inverse-time feed");
}

TEST(ReaderDefects, GcodeOverflowingAndHugeNumbersAreRefusedWithValueAndLine) {
  const std::string message = gcode_error("G1 X0 F100\nG1 X1" + std::string(400, '0') + "\n");
  EXPECT_CONTAINS(message, "part.nc:2:4:");
  EXPECT_CONTAINS(message, "too large");
  EXPECT_CONTAINS(gcode_error("G1 X0 F100\nG1 Y1000000000\n"), "part.nc:2:4:");
  EXPECT_CONTAINS(gcode_error("G1 X0 F100\nG1 Y1000000000\n"), "1000000000");
  EXPECT_CONTAINS(gcode_error("G1 X0 F100\nG2 X0 Y0 I1000000000\n"), "1000000000");
  EXPECT_CONTAINS(gcode_error("G1 X0 F100 S100000000000\n"), "spindle speed");
  EXPECT_CONTAINS(gcode_error("N100000000000 G1 X0 F100\n"), "block number");
  EXPECT_CONTAINS(gcode_error("G1 X0 F100 M100000000000000000000\n"), "M code");
}

TEST(ReaderDefects, GcodeIncrementalPositionsCannotGrowWithoutBound) {
  std::string program = "G91 G1 X0 F100\n";
  for (int i = 0; i < 3; ++i) program += "X900000\n";
  const std::string message = gcode_error(program);
  EXPECT_CONTAINS(message, "part.nc:3:");
  EXPECT_CONTAINS(message, "1800000");
}

// --- 4. Rotary words: the travel, and turns that return to the same pose --------------------

/// A table-table machine in miniature: C turns the workpiece about z (an endless axis), A is
/// limited to [-120, 30] deg like the Mikron's; X Y Z are the tip before the table turns. A
/// word outside the travel throws InfeasibleError, as the vmsim program's callback does.
AxisWordPose c_table_pose(const std::vector<std::pair<char, double>>& words) {
  Eigen::Vector3d p = Eigen::Vector3d::Zero();
  double c_deg = 0.0;
  for (const auto& [letter, value] : words) {
    if (letter >= 'X' && letter <= 'Z') p[letter - 'X'] = value;
    if (letter == 'C') c_deg = value;
    if (letter == 'A' && (value < -120.0 || value > 30.0)) {
      throw InfeasibleError("axis word A" + std::to_string(value) +
                            " is outside the travel of axis A [-120, 30] deg");
    }
  }
  const double c = -c_deg * std::numbers::pi / 180.0;
  const Eigen::Vector3d tip_mm(std::cos(c) * p.x() - std::sin(c) * p.y(),
                               std::sin(c) * p.x() + std::cos(c) * p.y(), p.z());
  return {tip_mm * 1e-3, Eigen::Vector3d::UnitZ()};
}

TEST(ReaderDefects, RotaryWordOutsideTheTravelIsInfeasibleNamingTheBlock) {
  ReaderOptions options;
  options.axis_words_to_pose = c_table_pose;
  try {
    gcode("G1 X10 Y0 Z0 A0 C0 F100\nG1 A720\n", options);
    FAIL() << "no error";
  } catch (const InfeasibleError& error) {
    const std::string message = error.what();
    EXPECT_CONTAINS(message, "part.nc:2:");
    EXPECT_CONTAINS(message, "G1 A720");
    EXPECT_CONTAINS(message, "[-120, 30]");
  }
}

TEST(ReaderDefects, AFullTurnOfAnEndlessAxisIsARealMotionNotMergedAway) {
  ReaderOptions options;
  options.axis_words_to_pose = c_table_pose;
  // The tip at 10 mm from the C axis: C0 -> C360 sweeps it once round the circle. It was one
  // point ("repeats the previous pose"): the turn had vanished.
  const Toolpath path = gcode("G1 X10 Y0 Z0 C0 F100\nG1 C360\n", options);
  ASSERT_EQ(path.points.size(), 5u);
  for (std::size_t k = 1; k < 5; ++k) {
    const double c = -static_cast<double>(k) * std::numbers::pi / 2.0;
    expect_vector(path.points[k].tip_W_m, Eigen::Vector3d(std::cos(c), std::sin(c), 0) * 10e-3,
                  1e-15);
    EXPECT_EQ(path.points[k].block, 1);
  }
  // A turn of less than 180 deg is left whole: the inverse kinematics follows it.
  EXPECT_EQ(gcode("G1 X10 Y0 Z0 C0 F100\nG1 C170\n", options).points.size(), 2u);
}

// --- 5. Expansion limits ----------------------------------------------------------------------

TEST(ReaderDefects, AnArcOfTooManyPointsIsRefusedBeforeItIsMade) {
  ReaderOptions options;
  options.arc_chord_tolerance_m = 1e-12;
  // A full circle of radius 1 m at a 1e-12 m chord error: 2.2 million points.
  const std::string message = gcode_error("G1 X1000 Y0 F100\nG2 X1000 Y0 I-1000 J0\n", options);
  EXPECT_CONTAINS(message, "part.nc:2:");
  EXPECT_CONTAINS(message, "expands to 22214");
  EXPECT_CONTAINS(message, "points per block");
}

// --- 6. Found by mutating the samples ---------------------------------------------------------

TEST(ReaderDefects, GcodeLineOfMillionsOfWordsIsRefusedBeforeTheyAreKept) {
  // 10 MB of "X1": the words of the line were all kept (about 100 bytes each) before the
  // repeated address was found; a 2.6 GB line took all the memory.
  std::string program = "G1 X0 F100\nG1";
  for (int i = 0; i < 3'400'000; ++i) program += " X1";
  const std::string message = gcode_error(program + "\n");
  EXPECT_CONTAINS(message, "part.nc:2:");
  EXPECT_CONTAINS(message, "more than 64 words in one block");
}

TEST(ReaderDefects, AptRecordOfTenMegabytesIsRefusedAndALongCommentIsNot) {
  std::string record = "GOTO/0,0,0";
  while (record.size() < 10'000'000) record += ",1,2,3";
  const std::string message = apt_error("MULTAX/OFF\nFEDRAT/1\n" + record + "\n");
  EXPECT_CONTAINS(message, "part.apt:3:");
  EXPECT_CONTAINS(message, "longer than 4194304 bytes");
  const std::string comment = "PPRINT " + std::string(10'000'000, 'x') + "\n";
  EXPECT_EQ(apt(comment + "FEDRAT/1\nGOTO/0,0,0\n").points.size(), 1u);
  EXPECT_EQ(gcode("(" + std::string(10'000'000, 'x') + ")\nG1 X0 F1\n").points.size(), 1u);
}

}  // namespace
}  // namespace vmsim::toolpath

namespace vmsim::toolpath {
namespace {

// A FIFO named as the tool path blocked the reader for ever (it waited for a writer): refused at
// once, naming the file, like every other input (common read_file).
TEST(ReaderDefects, AFifoAsToolPathIsRefusedAtOnce) {
  const std::string fifo = ::testing::TempDir() + "/vmsim_toolpath_fifo.nc";
  std::remove(fifo.c_str());
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  try {
    read_toolpath(fifo, {});
    ADD_FAILURE() << "a FIFO was read as a tool path";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find(fifo), std::string::npos) << error.what();
  }
  std::remove(fifo.c_str());
}

}  // namespace
}  // namespace vmsim::toolpath

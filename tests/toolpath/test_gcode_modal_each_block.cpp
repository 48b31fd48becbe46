// Fanuc modal macro call "each block" (G66.1 P<program> [L<count>] <arguments>): the G66.1 block
// calls the macro with its arguments, then every block with words other than N calls the macro
// instead of running, its own words the arguments (A -> #1 ... Z -> #26, as G65), until G67.
// Blocks with only N, assignments or comments are no calls; the macro's own blocks do not call
// it again. Each program is compared with its expansion written by hand and with tool-tip points
// worked out by hand.
#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "reader_test_support.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {
namespace {

using test::expect_same_points;
using test::gcode;
using test::gcode_error;

/// True when the path passes through the tip (x, y, z) in mm.
bool passes_through(const Toolpath& path, double x_mm, double y_mm, double z_mm) {
  const Eigen::Vector3d tip_m(x_mm * 1e-3, y_mm * 1e-3, z_mm * 1e-3);
  for (const PathPoint& p : path.points) {
    if ((p.tip_W_m - tip_m).norm() < 1e-12) return true;
  }
  return false;
}

// A point macro: to X (#24) + Q (#17), Y (#25) at Z5, down to Z -#26 at F (#9), back up.
// "+ 0" / "+ #17": an argument not given is empty, 0 in arithmetic.
const std::string kPointMacro =
    "O9300 (POINT AT X+Q Y, DEPTH Z, FEED F)\n"
    "G90 G0 X[#24 + #17] Y[#25 + 0] Z5\n"
    "G1 Z[0 - #26] F#9\n"
    "G0 Z5\n"
    "M99\n";

TEST(GcodeModalEachBlock, EveryBlockWithWordsCallsTheMacroWithItsWordsUntilG67) {
  const std::string program =
      "G0 X0 Y0 Z10\n"                // before G66.1: runs
      "G66.1 P9300 X1 Y2 Z3 F100\n"   // the G66.1 block calls too
      "X10 Y20 Z1 F200\n"             // a plain block: a call, not a move
      "N5\n"                          // only N: no call
      "#100 = 7\n"                    // an assignment: no call
      "(A COMMENT)\n"                 // no call
      "X#100 Y-1 Z0.5 F50\n"          // words made by a parameter
      "F300 Q6 Z2\n"                  // no axis to move: still a call; X is not the G66.1's X1
      "N8 G67\n"                      // cancels, no call
      "G0 X50 Y50 Z10\n"              // runs
      "M30\n" +
      kPointMacro;
  const std::string by_hand =
      "G0 X0 Y0 Z10\n"
      "G90 G0 X1 Y2 Z5\nG1 Z-3 F100\nG0 Z5\n"
      "G90 G0 X10 Y20 Z5\nG1 Z-1 F200\nG0 Z5\n"
      "G90 G0 X7 Y-1 Z5\nG1 Z-0.5 F50\nG0 Z5\n"
      "G90 G0 X6 Y0 Z5\nG1 Z-2 F300\nG0 Z5\n"
      "G0 X50 Y50 Z10\n";
  const Toolpath path = gcode(program);
  expect_same_points(path, gcode(by_hand));
  // The bottoms of the four calls, worked out by hand (mm).
  EXPECT_TRUE(passes_through(path, 1, 2, -3));
  EXPECT_TRUE(passes_through(path, 10, 20, -1));
  EXPECT_TRUE(passes_through(path, 7, -1, -0.5));
  EXPECT_TRUE(passes_through(path, 6, 0, -2));
  // The called blocks never ran as moves: the tool was never at Z1 / Z0.5 / Z2 of those blocks.
  EXPECT_FALSE(passes_through(path, 10, 20, 1));
  EXPECT_FALSE(passes_through(path, 7, -1, 0.5));
  // The macro's blocks name their own lines (the O9300 body from line 13 on).
  ASSERT_GE(path.points.size(), 2u);
  EXPECT_EQ(path.blocks[static_cast<std::size_t>(path.points[1].block)].line, 13);
}

TEST(GcodeModalEachBlock, RepeatsSubprogramBlocksAndGotoReturn) {
  // L2: each call runs the macro twice (the second run from the same arguments). Blocks of an
  // M98 subprogram are called; the M98 and M99 blocks still call and return. A GOTO in a called
  // block: the macro returns to the GOTO's target.
  const std::string program =
      "G0 X0 Y0 Z10\n"
      "G66.1 P9300 L2 X1 Y1 Z1 F100\n"
      "M98 P20\n"
      "X3 Y3 Z3 F100 GOTO 9\n"
      "X4 Y4 Z4 F100\n"  // jumped over: no call
      "N9 G67\n"
      "M30\n"
      "O20\n"
      "X2 Y2 Z2 F100\n"
      "M99\n" +
      kPointMacro;
  std::string by_hand = "G0 X0 Y0 Z10\n";
  for (const char* point : {"X1 Y1", "X2 Y2", "X3 Y3"}) {
    const std::string depth(1, point[1]);
    for (int run = 0; run < 2; ++run) {
      by_hand += std::string("G90 G0 ") + point + " Z5\nG1 Z-" + depth + " F100\nG0 Z5\n";
    }
  }
  const Toolpath path = gcode(program);
  expect_same_points(path, gcode(by_hand));
  EXPECT_TRUE(passes_through(path, 2, 2, -2));
  EXPECT_FALSE(passes_through(path, 4, 4, -4));
}

TEST(GcodeModalEachBlock, BadInputIsALocatedError) {
  struct Case {
    std::string text, where, what;
  };
  const std::vector<Case> cases = {
      {"G0 X0 Y0 Z0\nG66.1 P77 X1\n", "part.nc:2:1: 'G66.1'", "no macro program O77"},
      {"G0 X0 Y0 Z0\nG66.1 X1\n", "part.nc:2:1: 'G66.1'", "G66.1 needs P"},
      {"G0 X0 Y0 Z0\nG66 P10 G66.1 P10\nM30\nO10\nM99\n", "part.nc:2:9: 'G66.1'",
       "not in one block with G66"},
      // G, L, P are no arguments: a G1 under G66.1 is refused, not dropped.
      {"G0 X0 Y0 Z0\nG66.1 P10\nG1 X5 F100\nM30\nO10\nG0 Z1\nM99\n", "part.nc:3:1: 'G1'",
       "not a macro argument"},
      {"G0 X0 Y0 Z0\nG66.1 P10\nX5 P3\nM30\nO10\nG0 Z1\nM99\n", "part.nc:3:4: 'P3'",
       "under G66.1 P10 (line 2)"},
      // An error inside the macro names the macro's line.
      {"G0 X0 Y0 Z0\nG66.1 P10 A1\nM30\nO10\nG1 X[1 / 0] F100\nM99\n", "part.nc:5:",
       "division by zero"},
  };
  for (const Case& c : cases) {
    const std::string message = gcode_error(c.text);
    EXPECT_NE(message.find(c.where), std::string::npos) << c.text << " -> " << message;
    EXPECT_NE(message.find(c.what), std::string::npos) << c.text << " -> " << message;
  }
}

TEST(GcodeModalEachBlock, NestingDeeperThanTheLimitIsALocatedError) {
  ReaderOptions options;
  options.max_call_depth = 1;
  // From the main program one level is allowed: the G66.1 block and the next block call (each
  // call lifts the tool 1 mm: Z0, Z1, Z2).
  const Toolpath allowed =
      gcode("G0 X0 Y0 Z0\nG66.1 P10\nX5\nG67\nM30\nO10\nG91 G0 Z1\nG90\nM99\n", options);
  ASSERT_EQ(allowed.points.size(), 3u);
  EXPECT_NEAR(allowed.points.back().tip_W_m.z(), 2e-3, 1e-12);
  EXPECT_NEAR(allowed.points.back().tip_W_m.x(), 0.0, 1e-12);
  // The G66.1 block inside an M98 subprogram (already one call deep) cannot call.
  std::string message =
      gcode_error("G0 X0 Y0 Z0\nM98 P20\nM30\nO20\nG66.1 P10\nM99\nO10\nG0 Z1\nM99\n", options);
  EXPECT_NE(message.find("part.nc:5:1: 'G66.1': the modal call G66.1 P10 (line 5) nests calls "
                         "more than 1 deep"),
            std::string::npos)
      << message;
  // Nor a block of an M98 subprogram under a G66.1 of the main program.
  message = gcode_error(
      "G0 X0 Y0 Z0\nG66.1 P10\nM98 P20\nM30\nO20\nX5 Y1\nM99\nO10\nG0 Z1\nM99\n", options);
  EXPECT_NE(message.find("part.nc:6:1: 'X5': the modal call G66.1 P10 (line 2) nests calls "
                         "more than 1 deep"),
            std::string::npos)
      << message;
}

}  // namespace
}  // namespace vmsim::toolpath

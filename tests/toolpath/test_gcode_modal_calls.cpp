// Fanuc modal macro calls: G66 P<program> [L<count>] <arguments> calls the macro after every
// following block that moves an axis, with the arguments of the G66 block (A -> #1, B -> #2 ...,
// as G65), until G67. Each program is compared with its expansion written by hand.
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

// A drilling macro as a shop writes it: #1 (A) the depth, #2 (B) the clearance, #9 (F) the feed.
const std::string kDrillMacro =
    "O9100 (DRILL AT THE CURRENT POSITION)\n"
    "G1 Z-#1 F#9\n"
    "G0 Z#2\n"
    "M99\n";

TEST(GcodeModalCalls, G66CallsTheMacroAfterEveryMoveBlockUntilG67) {
  const std::string program =
      "G0 X0 Y0 Z10\n"
      "G66 P9100 A2 B5 F120\n"
      "G0 X10 Y10\n"    // a move: the macro runs after it
      "G0X20\n"         // a move without blanks
      "G4 P100\n"       // a dwell: no call
      "M8\n"            // no axis: no call
      "#100 = 30\n"     // an assignment: no call
      "X#100 Y5\n"      // a move made by a parameter: a call
      "G67\n"
      "X40\n"           // after G67: no call
      "M30\n" +
      kDrillMacro;
  const std::string by_hand =
      "G0 X0 Y0 Z10\n"
      "G0 X10 Y10\n"
      "G1 Z-2 F120\nG0 Z5\n"
      "G0 X20\n"
      "G1 Z-2 F120\nG0 Z5\n"
      "X30 Y5\n"
      "G1 Z-2 F120\nG0 Z5\n"
      "X40\n";
  const Toolpath path = gcode(program);
  expect_same_points(path, gcode(by_hand));
  // The macro's blocks name their own lines (the O9100 body from line 13 on).
  ASSERT_GE(path.points.size(), 3u);
  EXPECT_EQ(path.blocks[static_cast<std::size_t>(path.points[2].block)].line, 13);
}

TEST(GcodeModalCalls, RepeatsArgumentsFreshEachCallAndMovesInsideTheMacroDoNotCallAgain) {
  // L2: the macro runs twice per move; each run starts from the G66 arguments (#1 counts up
  // inside, from A1). The macro's own moves do not call it (no endless recursion).
  const std::string program =
      "G0 X0 Y0 Z10\n"
      "G66 P9200 L2 A1\n"
      "G0 X10\n"
      "Y10\n"
      "G67\n"
      "M30\n"
      "O9200\n"
      "G1 Z[-#1] F100\n"
      "#1 = #1 + 1\n"
      "G0 Z[#1 + 5]\n"
      "M99\n";
  const std::string by_hand =
      "G0 X0 Y0 Z10\n"
      "G0 X10\n"
      "G1 Z-1 F100\nG0 Z7\n"
      "G1 Z-1\nG0 Z7\n"
      "G0 Y10\n"
      "G1 Z-1\nG0 Z7\n"
      "G1 Z-1\nG0 Z7\n";
  expect_same_points(gcode(program), gcode(by_hand));
}

TEST(GcodeModalCalls, MovesOfAnM98SubprogramCallAndAGotoReturnsWhereItJumps) {
  // Under G66 the moves of an M98 subprogram call the macro as well (the modal state is the
  // control's); a move block with a GOTO calls the macro, then goes on at the GOTO's target.
  const std::string program =
      "G0 X0 Y0 Z10\n"
      "G66 P9100 A3 B4 F90\n"
      "M98 P500\n"
      "G0 X5 GOTO 20\n"
      "G0 X99\n"
      "N20 G67\n"
      "M30\n"
      "O500\n"
      "G0 Y7\n"
      "M99\n" +
      kDrillMacro;
  const std::string by_hand =
      "G0 X0 Y0 Z10\n"
      "G0 Y7\n"
      "G1 Z-3 F90\nG0 Z4\n"
      "G0 X5\n"
      "G1 Z-3\nG0 Z4\n";
  expect_same_points(gcode(program), gcode(by_hand));
}

TEST(GcodeModalCalls, BadInputIsALocatedError) {
  struct Case {
    std::string text, where, what;
  };
  const std::vector<Case> cases = {
      {"G0 X0 Y0 Z0\nG66 P77 A1\n", "part.nc:2:1: 'G66'", "no macro program O77"},
      {"G0 X0 Y0 Z0\nG66 A1\n", "part.nc:2:1: 'G66'", "G66 needs P"},
      {"G0 X0 Y0 Z0\nG66 P10 G0\nM30\nO10\nM99\n", "part.nc:2:9: 'G0'", "not a G66 argument"},
      {"G0 X0 Y0 Z0\nG66 P10 L-1\nM30\nO10\nM99\n", "part.nc:2:9: 'L-1'", "non-negative"},
      {"G0 X0 Y0 Z0\nG65 P10 G66.1 P10\nM30\nO10\nM99\n", "part.nc:2:9: 'G66.1'",
       "not in one block with G65"},
      {"G0 X0 Y0 Z0\nG65 P10 G66 P10\n", "part.nc:2:", "G65 and G66 in one block"},
      // An error inside the macro names the macro's line.
      {"G0 X0 Y0 Z0\nG66 P10 A1\nG0 X5\nM30\nO10\nG1 X[1 / 0] F100\nM99\n", "part.nc:6:",
       "division by zero"},
  };
  for (const Case& c : cases) {
    const std::string message = gcode_error(c.text);
    EXPECT_NE(message.find(c.where), std::string::npos) << c.text << " -> " << message;
    EXPECT_NE(message.find(c.what), std::string::npos) << c.text << " -> " << message;
  }
}

TEST(GcodeModalCalls, NestingAndExecutedBlockLimits) {
  // With calls one deep at most, a move of an M98 subprogram (already one call deep) cannot call
  // the modal macro: the error names the move word, the G66 and the limit.
  ReaderOptions options;
  options.max_call_depth = 1;
  const std::string nested =
      "G0 X0 Y0 Z0\nG66 P10\nM98 P20\nM30\nO20\nG1 X5 F100\nM99\nO10\nG0 Z1\nM99\n";
  std::string message = gcode_error(nested, options);
  EXPECT_NE(message.find("part.nc:6:4: 'X5': the modal call G66 P10 (line 2) nests calls more "
                         "than 1 deep"),
            std::string::npos)
      << message;
  // From the main program one level is allowed: the same modal call runs.
  EXPECT_EQ(gcode("G0 X0 Y0 Z0\nG66 P10\nG1 X5 F100\nM30\nO10\nG0 Z1\nM99\n", options)
                .points.size(),
            3u);
  // A loop of moves under G66 that never ends stops at max_executed_blocks.
  ReaderOptions limited;
  limited.max_executed_blocks = 500;
  message = gcode_error("G0 X0 Y0 Z0\nG66 P10\nN1 G0 X1\nG0 X2\nGOTO 1\nM30\nO10\nG0 Z1\nM99\n",
                        limited);
  EXPECT_NE(message.find("more than 500 blocks run"), std::string::npos) << message;
  EXPECT_NE(message.find("part.nc:"), std::string::npos) << message;
}

}  // namespace
}  // namespace vmsim::toolpath

// G-code programs (toolpath/src/gcode_program.cpp): parameters, expressions, loops, jumps and
// subprograms of Fanuc Custom Macro B and LinuxCNC. Each program is compared with the plain
// program it stands for, written out by hand (both read by parse_gcode must give the same
// points), or with values evaluated by hand from the controls' documented rules.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
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

/// The value [mm] an expression gives as the X word of a feed move (after `prelude` blocks).
double x_of(const std::string& expression, const std::string& prelude = "") {
  // From X-999, so that a value of 0 is a motion too.
  const Toolpath path = gcode(prelude + "G0 X-999 Y0 Z0\nG1 F100 X" + expression + "\n");
  EXPECT_EQ(path.points.size(), 2u) << expression;
  return path.points.back().tip_W_m.x() * 1e3;
}

TEST(GcodeMacros, AWhileLoopDrillsTheHolePatternOfThePlainProgram) {
  // Fanuc: four holes 12.5 mm apart along X, two rows 8 mm apart, peck depth from a parameter.
  const std::string program =
      "%\n"
      "O1000 (HOLE PATTERN)\n"
      "#100 = 12.5 (PITCH X)\n"
      "#101 = 8 (ROW PITCH)\n"
      "#102 = -3 (DEPTH)\n"
      "G21 G90 G0 X0 Y0 Z5\n"
      "#2 = 0\n"
      "WHILE [#2 LT 2] DO 1\n"
      "  #1 = 0\n"
      "  WHILE [#1 LT 4] DO 2\n"
      "    G0 X[#1 * #100] Y[#2 * #101]\n"
      "    G1 Z#102 F120\n"
      "    G0 Z5\n"
      "    #1 = #1 + 1\n"
      "  END 2\n"
      "  #2 = #2 + 1\n"
      "END 1\n"
      "G0 X0 Y0\n"
      "M30\n"
      "%\n";
  std::string plain = "G21 G90 G0 X0 Y0 Z5\n";
  const char* xs[] = {"0", "12.5", "25", "37.5"};
  for (const char* y : {"0", "8"}) {
    for (const char* x : xs) {
      plain += std::string("G0 X") + x + " Y" + y + "\nG1 Z-3 F120\nG0 Z5\n";
    }
  }
  plain += "G0 X0 Y0\nM30\n";
  const Toolpath path = gcode(program);
  expect_same_points(path, gcode(plain));
  // Every plunge comes from the same source block, line 12, as written.
  int plunges = 0;
  for (const PathPoint& p : path.points) {
    if (p.kind != MotionKind::linear) continue;
    ++plunges;
    const SourceBlock& block = path.blocks[static_cast<std::size_t>(p.block)];
    EXPECT_EQ(block.line, 12);
    EXPECT_EQ(block.text, "G1 Z#102 F120");
  }
  EXPECT_EQ(plunges, 8);
}

TEST(GcodeMacros, AParametricCircleFromSinAndCosGivesTheHandEvaluatedPoints) {
  // LinuxCNC: named parameters, o-word while; 12 points of a circle of radius 20 mm, every
  // 30 deg (cos 30 deg = sqrt(3)/2: 20 cos 30 = 17.32050807568877).
  const std::string program =
      "#<r> = 20\n"
      "#<n> = 12\n"
      "#<i> = 0\n"
      "G0 X#<r> Y0 Z0\n"
      "F500\n"
      "o100 while [#<i> LT #<n>]\n"
      "  #<i> = [#<i> + 1]\n"
      "  #<a> = [360 * #<i> / #<n>]\n"
      "  G1 X[#<r> * COS[#<a>]] Y[#<r> * SIN[#<a>]]\n"
      "o100 endwhile\n"
      "M2\n";
  const std::string plain =
      "G0 X20 Y0 Z0\nF500\n"
      "G1 X17.32050807568877 Y10\n"
      "G1 X10 Y17.32050807568877\n"
      "G1 X0 Y20\n"
      "G1 X-10 Y17.32050807568877\n"
      "G1 X-17.32050807568877 Y10\n"
      "G1 X-20 Y0\n"
      "G1 X-17.32050807568877 Y-10\n"
      "G1 X-10 Y-17.32050807568877\n"
      "G1 X0 Y-20\n"
      "G1 X10 Y-17.32050807568877\n"
      "G1 X17.32050807568877 Y-10\n"
      "G1 X20 Y0\n";
  expect_same_points(gcode(program), gcode(plain));
}

TEST(GcodeMacros, NestedFanucSubprogramsAndMacroCallsGiveThePlainProgram) {
  // The main program calls O2000 twice (M98 L2): a square of side #100, each time 1 mm deeper
  // (#101 starts vacant: 0 in arithmetic). Then the macro O3000 (G65, A -> #1, B -> #2) draws
  // B lines at X = A, 2 mm apart in Y, with IF / GOTO, and calls O2000 once more (nested M98,
  // which shares the macro's locals).
  const std::string program =
      "O0001 (MAIN)\n"
      "G90 G0 X0 Y0 Z10\n"
      "#100 = 5\n"
      "M98 P2000 L2\n"
      "G65 P3000 A20 B3\n"
      "G0 Z50\n"
      "M30\n"
      "O2000 (SQUARE)\n"
      "#101 = #101 - 1\n"
      "G1 Z#101 F200\n"
      "G91 X#100\n"
      "Y#100\n"
      "X-#100\n"
      "Y-#100\n"
      "G90\n"
      "M99\n"
      "O3000 (LINES)\n"
      "#10 = 0\n"
      "N10 IF [#10 GE #2] GOTO 20\n"
      "G1 X#1 Y[#10 * 2]\n"
      "#10 = #10 + 1\n"
      "GOTO 10\n"
      "N20 M98 P2000\n"
      "M99\n";
  const std::string square = "G91 X5\nY5\nX-5\nY-5\nG90\n";
  const std::string plain = "G90 G0 X0 Y0 Z10\n"
                            "G1 Z-1 F200\n" + square +
                            "G1 Z-2 F200\n" + square +
                            "G1 X20 Y0\nG1 X20 Y2\nG1 X20 Y4\n"
                            "G1 Z-3 F200\n" + square +
                            "G0 Z50\n";
  const Toolpath path = gcode(program);
  expect_same_points(path, gcode(plain));
  // A point made in a subprogram names the subprogram's line.
  EXPECT_EQ(path.blocks[static_cast<std::size_t>(path.points[1].block)].line, 10);
}

TEST(GcodeMacros, SubprogramsMayComeBeforeTheMainProgramAndThePackedCallRepeats) {
  // As some posts write: the subprogram first, then the main program; M98 P30010 is O0010
  // three times (Fanuc's packed form kkkknnnn).
  const std::string program =
      "%\n"
      "O0010 (STEP)\n"
      "G91 G1 X1 F100\n"
      "G90\n"
      "M99\n"
      "O0001 (MAIN)\n"
      "G90 G0 X0 Y0 Z0\n"
      "M98 P30010\n"
      "M98 P10 L2\n"
      "M30\n"
      "%\n";
  expect_same_points(gcode(program),
                     gcode("G90 G0 X0 Y0 Z0\nG1 X1 F100\nX2\nX3\nX4\nX5\n"));
}

TEST(GcodeMacros, IfGotoSkipsBlocksAndIfThenAssigns) {
  const std::string program =
      "#1 = 3\n"
      "G0 X0 Y0 Z0\n"
      "IF [#1 GT 2] GOTO 100\n"
      "G1 X99 F100 (skipped)\n"
      "N100 G1 X1 F100\n"
      "IF [#1 EQ 3] THEN #2 = 7\n"
      "G1 Y#2\n"
      "IF [#1 LT 0] THEN #3 = 1\n"
      "G1 X#3 Y2 (#3 is vacant: no X word)\n"
      "IF [#3 EQ #0] GOTO 200\n"
      "G1 Z99\n"
      "N200 G1 Z-1\n"
      "M30\n";
  expect_same_points(gcode(program),
                     gcode("G0 X0 Y0 Z0\nG1 X1 F100\nG1 Y7\nG1 Y2\nG1 Z-1\n"));
}

TEST(GcodeMacros, LinuxCncSubroutinesWithArgumentsAndControlFlow) {
  // o<slot> sub: a slot from (#1, #2) of length #3 at depth #4; it calls o<plunge>. The main
  // program runs an if / elseif / else chain, a do / while, a repeat with break and continue.
  const std::string program =
      "o<plunge> sub\n"
      "  G1 Z#1 F100\n"
      "o<plunge> endsub\n"
      "o<slot> sub\n"
      "  G0 X#1 Y#2\n"
      "  o<plunge> call [#4]\n"
      "  G1 X[#1 + #3]\n"
      "  G0 Z5\n"
      "o<slot> endsub\n"
      "G0 X0 Y0 Z5\n"
      "o<slot> call [0] [0] [10] [-1]\n"
      "o<slot> call [0] [5] [10] [-2]\n"
      "#<k> = 2\n"
      "o1 if [#<k> EQ 1]\n"
      "  G1 Y100\n"
      "o1 elseif [#<k> EQ 2]\n"
      "  G1 Y20\n"
      "o1 else\n"
      "  G1 Y200\n"
      "o1 endif\n"
      "#<n> = 0\n"
      "o2 do\n"
      "  #<n> = [#<n> + 1]\n"
      "  G1 X[#<n>]\n"
      "o2 while [#<n> LT 3]\n"
      "#<j> = 0\n"
      "o3 repeat [10]\n"
      "  #<j> = [#<j> + 1]\n"
      "  o4 if [#<j> EQ 2]\n"
      "    o3 continue\n"
      "  o4 endif\n"
      "  o5 if [#<j> GT 4]\n"
      "    o3 break\n"
      "  o5 endif\n"
      "  G1 Y[20 + #<j>]\n"
      "o3 endrepeat\n"
      "M2\n";
  const std::string plain =
      "G0 X0 Y0 Z5\n"
      "G0 X0 Y0\nG1 Z-1 F100\nG1 X10\nG0 Z5\n"
      "G0 X0 Y5\nG1 Z-2 F100\nG1 X10\nG0 Z5\n"
      "G1 Y20\n"
      "G1 X1\nG1 X2\nG1 X3\n"
      "G1 Y21\nG1 Y23\nG1 Y24\n";
  expect_same_points(gcode(program), gcode(plain));
}

TEST(GcodeMacros, FanucMacroCallArgumentsMapToTheirLocals) {
  // G65 argument specification I: A B C I J K D E F H M Q R S T U V W X Y Z ->
  // #1 #2 #3 #4 #5 #6 #7 #8 #9 #11 #13 #17 #18 #19 #20 #21 #22 #23 #24 #25 #26; the macro moves
  // to X = the sum of each local times its own number, so that one wrong mapping shows.
  std::string program = "G0 X0 Y0 Z0\nG65 P9000 A1 B1 C1 I1 J1 K1 D1 E1 F1 H1 M1 Q1 R1 S1 T1 U1 "
                        "V1 W1 X1 Y1 Z1\nM30\nO9000\n#30 = 0\n";
  const int locals[] = {1, 2, 3, 4, 5, 6, 7, 8, 9, 11, 13, 17, 18, 19, 20, 21, 22, 23, 24, 25, 26};
  int expected = 0;
  for (const int l : locals) {
    program += "#30 = #30 + #" + std::to_string(l) + " * " + std::to_string(l) + "\n";
    expected += l;
  }
  program += "IF [#10 NE #0] GOTO 99 (#10 was not given: vacant)\nG1 X#30 F100\nN99 M99\n";
  const Toolpath path = gcode(program);
  ASSERT_EQ(path.points.size(), 2u);
  EXPECT_NEAR(path.points[1].tip_W_m.x() * 1e3, expected, 1e-12);
}

TEST(GcodeMacros, ExpressionsFollowTheDocumentedPrecedenceAndFunctions) {
  // LinuxCNC precedence: ** before * / MOD before + - before comparisons before AND OR XOR.
  EXPECT_DOUBLE_EQ(x_of("[1 + 2 * 3 ** 2]"), 19.0);
  EXPECT_DOUBLE_EQ(x_of("[2 ** 3 ** 2]"), 64.0);  // left to right: (2^3)^2
  EXPECT_DOUBLE_EQ(x_of("[10 - 4 - 3]"), 3.0);
  EXPECT_DOUBLE_EQ(x_of("[12 / 4 / 3]"), 1.0);
  EXPECT_DOUBLE_EQ(x_of("[7 MOD 3]"), 1.0);
  EXPECT_DOUBLE_EQ(x_of("[-7 MOD 3]"), 2.0);  // LinuxCNC: 0 <= remainder < |divisor|
  EXPECT_DOUBLE_EQ(x_of("[1 + 1 EQ 2]"), 1.0);
  EXPECT_DOUBLE_EQ(x_of("[1 LT 2 AND 3 GT 4]"), 0.0);
  EXPECT_DOUBLE_EQ(x_of("[1 LT 2 OR 3 GT 4]"), 1.0);
  EXPECT_DOUBLE_EQ(x_of("[1 XOR 1]"), 0.0);
  EXPECT_DOUBLE_EQ(x_of("[2 GE 2] "), 1.0);
  EXPECT_DOUBLE_EQ(x_of("[2 LE 1]"), 0.0);
  EXPECT_DOUBLE_EQ(x_of("[2 NE 1]"), 1.0);
  EXPECT_DOUBLE_EQ(x_of("[-[2 + 3]]"), -5.0);
  // Functions, angles in degrees.
  EXPECT_NEAR(x_of("[SIN[30]]"), 0.5, 1e-15);
  EXPECT_NEAR(x_of("[COS[60]]"), 0.5, 1e-15);
  EXPECT_NEAR(x_of("[TAN[45]]"), 1.0, 1e-15);
  EXPECT_NEAR(x_of("[ASIN[1]]"), 90.0, 1e-13);
  EXPECT_NEAR(x_of("[ACOS[0]]"), 90.0, 1e-13);
  EXPECT_NEAR(x_of("[ATAN[1]/[1]]"), 45.0, 1e-13);
  EXPECT_NEAR(x_of("[ATAN[-1]/[-1]]"), -135.0, 1e-13);
  EXPECT_NEAR(x_of("[ATAN[1,-1]]"), 135.0, 1e-13);
  EXPECT_NEAR(x_of("[ATAN[1]/[1] * 2]"), 90.0, 1e-13);
  EXPECT_DOUBLE_EQ(x_of("[SQRT[16]]"), 4.0);
  EXPECT_DOUBLE_EQ(x_of("[ABS[-2.5]]"), 2.5);
  EXPECT_DOUBLE_EQ(x_of("[ROUND[2.5]]"), 3.0);
  EXPECT_DOUBLE_EQ(x_of("[FIX[-1.2]]"), -1.0);  // Fanuc: the fraction dropped
  EXPECT_DOUBLE_EQ(x_of("[FUP[-1.2]]"), -2.0);  // Fanuc: away from zero
  EXPECT_DOUBLE_EQ(x_of("[FIX[1.8]]"), 1.0);
  EXPECT_DOUBLE_EQ(x_of("[FUP[1.2]]"), 2.0);
  EXPECT_NEAR(x_of("[LN[EXP[2]]]"), 2.0, 1e-15);
  EXPECT_DOUBLE_EQ(x_of("[EXISTS[#<a>] + 2 * EXISTS[#<b>]]", "#<a> = 1\n"), 1.0);
  EXPECT_NEAR(x_of("SIN[90]"), 1.0, 1e-15);  // LinuxCNC: a function as a word's value
  // Parameters: indirect, ##, unary minus, signs.
  EXPECT_DOUBLE_EQ(x_of("#[#1 + 1]", "#1 = 4\n#5 = 2.5\n"), 2.5);
  EXPECT_DOUBLE_EQ(x_of("##1", "#1 = 150\n#150 = 7\n"), 7.0);
  EXPECT_DOUBLE_EQ(x_of("-#1", "#1 = 4\n"), -4.0);
  EXPECT_DOUBLE_EQ(x_of("-#1", "#1 = -4\n"), 4.0);
  EXPECT_DOUBLE_EQ(x_of("#<_g>", "#<_G> = 3 (names ignore case)\n"), 3.0);
  // Fanuc vacant: #0 EQ a vacant parameter; vacant + 1 = 1.
  EXPECT_DOUBLE_EQ(x_of("[#7 EQ #0]"), 1.0);
  EXPECT_DOUBLE_EQ(x_of("[#7 EQ 0]"), 0.0);
  EXPECT_DOUBLE_EQ(x_of("[#7 + 1]"), 1.0);
  EXPECT_DOUBLE_EQ(x_of("[#0 LT 1]"), 1.0);
  // LinuxCNC: the values set on a line take effect after the line: #2 gets the old #1.
  EXPECT_DOUBLE_EQ(x_of("#2", "#1 = 1\n#1 = 5 #2 = #1\n"), 1.0);
}

TEST(GcodeMacros, AMacroValueOfAnIntegerAddressIsRounded) {
  // Fanuc: M#1 with #1 = 3.4999999 is M3; likewise T H D N (not G: G43.4 is a code).
  const Toolpath path = gcode("#1 = 12.4999\nG0 X0 Y0 Z0\nN#1 G1 X1 F100\nN[#1 + 0.1] X2\n");
  ASSERT_EQ(path.blocks.size(), 3u);
  EXPECT_EQ(path.blocks[1].block_number, 12);
  EXPECT_EQ(path.blocks[2].block_number, 13);
}

TEST(GcodeMacros, AVacantWordIsLeftOut) {
  // Fanuc: "G90 X#1" with #1 vacant is "G90": the axis keeps its position.
  expect_same_points(gcode("G0 X1 Y2 Z3\nG1 F100 X#1 Y#2 Z-[#3]\nG1 X#4 Y5\n"),
                     gcode("G0 X1 Y2 Z3\nG1 F100\nG1 Y5\n"));
}

TEST(GcodeMacros, WordsGetTheirNumbersAnywhere) {
  expect_same_points(
      gcode("#1 = 1\n#2 = 250\n#3 = 12.5\nG#1 X0 Y0 Z0 F#2\nG[#1 + 1] X#3 Y0 I[#3 / 2] J0\n"),
      gcode("G1 X0 Y0 Z0 F250\nG2 X12.5 Y0 I6.25 J0\n"));
}

TEST(GcodeMacros, ErrorsNameTheFileLineColumnAndWord) {
  struct Case {
    std::string text, where, what;
  };
  const std::vector<Case> cases = {
      {"G0 X0 Y0 Z0\n#1 = [2 / 0]\n", "part.nc:2:7: '2 / 0'", "division by zero"},
      {"G0 X0 Y0 Z0\n#1 = [2 MOD [1 - 1]]\n", "part.nc:2:7:", "MOD by zero"},
      {"G0 X0 Y0 Z0\nG1 F100 X[SQRT[-4]]\n", "part.nc:2:11: 'SQRT[-4]'", "negative"},
      {"G0 X0 Y0 Z0\nG1 F100 X[ASIN[2]]\n", "part.nc:2:11:", "within [-1, 1]"},
      {"G0 X0 Y0 Z0\nG1 F100 X[LN[0]]\n", "part.nc:2:11:", "not positive"},
      {"G0 X0 Y0 Z0\n#1 = [10 ** 400]\n", "part.nc:2:7:", "too large"},
      {"G0 X0 Y0 Z0\nGOTO 50\n", "part.nc:2:1: 'GOTO'", "no block N50"},
      // GOTO stays within its program: N10 of O2 is not a target for O1.
      {"G0 X0 Y0 Z0\nM98 P1\nM30\nO1\nGOTO 10\nM99\nO2\nN10 M99\n", "part.nc:5:1: 'GOTO'",
       "no block N10 in this program"},
      {"G0 X0 Y0 Z0\nM98 P1234\n", "part.nc:2:1: 'M98'", "no subprogram O1234"},
      {"G0 X0 Y0 Z0\nG65 P77 A1\n", "part.nc:2:1: 'G65'", "no macro program O77"},
      {"G0 X0 Y0 Z0\no<nowhere> call\n", "part.nc:2:1: 'o'", "no subroutine o<nowhere>"},
      {"G0 X0 Y0 Z0\nWHILE [1 LT 2] DO 1\nG1 X1 F100\n", "part.nc:2:1: 'WHILE'",
       "without its END 1"},
      {"G0 X0 Y0 Z0\nEND 2\n", "part.nc:2:1: 'END'", "without its WHILE"},
      {"G0 X0 Y0 Z0\no7 if [0]\nG1 X1 F100\n", "part.nc:2:1: 'o'", "if without its endif"},
      {"G0 X0 Y0 Z0\no8 endwhile\n", "part.nc:2:1: 'o'", "endwhile without its while"},
      {"G0 X0 Y0 Z0\no9 sub\nG1 X1 F100\n", "part.nc:2:1: 'o'", "sub without its endsub"},
      {"G0 X0 Y0 Z0\no9 return\n", "part.nc:2:4: 'return'", "outside a called o-word"},
      {"G0 X0 Y0 Z0\nG1 F100 X#<nope>\n", "part.nc:2:10: '#<nope>'", "not defined"},
      {"G0 X0 Y0 Z0\nG1 F100 X#5001\n", "part.nc:2:10: '#5001'", "control system variables"},
      {"G0 X0 Y0 Z0\n#0 = 1\n", "part.nc:2:1: '#0'", "read only"},
      {"G0 X0 Y0 Z0\n#3000 = 12 (NO TOOL LENGTH)\n", "part.nc:2:1: '#3000'",
       "alarm 12 (NO TOOL LENGTH)"},
      {"G0 X0 Y0 Z0\n#[1.5] = 1\n", "part.nc:2:1: '#[1.5]'", "non-negative integer"},
      {"G0 X0 Y0 Z0\nG1 F100 X[1 + ]\n", "part.nc:2:15: ']'", "expected a number"},
      {"G0 X0 Y0 Z0\nG1 F100 X[1 + 2\n", "part.nc:2:16:", "expected ']'"},
      {"G0 X0 Y0 Z0\nIF [1] X5\n", "part.nc:2:8: 'X'", "expected GOTO or THEN"},
      {"G0 X0 Y0 Z0\n#<a = 1\n", "part.nc:2:2: '<'", "not closed"},
      {"G0 X0 Y0 Z0\nG66 P10 A1\n", "part.nc:2:1: 'G66'", "no macro program O10"},
      {"G0 X0 Y0 Z0\nEND 188888888888888\n", "part.nc:2:5: '188888888888888'",
       "integer within +-1e9"},
      {"G0 X0 Y0 Z0\nGOTO [2.5]\n", "part.nc:2:6: '[2.5]'", "integer within +-1e9, got 2.5"},
      {"G0 X0 Y0 Z0\nG65 P[10 ** 12]\n", "part.nc:2:5: 'P1000000000000'", "non-negative integer"},
      {"G0 X0 Y0 Z0\nM98 P1000\nM30\nO1000\nG1 X1 F100\n", "part.nc:2:", "no M99"},
      {"G0 X0 Y0 Z0\nM98 P1000\nM30\nO1000\nG1 X1 F100\nO2000\nM99\n", "part.nc:6:1: 'O2000'",
       "runs into the next program"},
      // An error of the block interpreter in a word made from an expression names the source
      // column of that word, and quotes it with its value.
      {"#1 = 2000000\nG0 X0 Y0 Z0\nG1 F100 Y5 X#1\n", "part.nc:3:12: 'X2000000'", "outside"},
      {"#1 = 7.5\nG0 X0 Y0 Z0\nG#1 X1\n", "part.nc:3:1: 'G7.5'", "unsupported G-code"},
  };
  for (const Case& c : cases) {
    const std::string message = gcode_error(c.text);
    EXPECT_NE(message.find(c.where), std::string::npos) << c.text << " -> " << message;
    EXPECT_NE(message.find(c.what), std::string::npos) << c.text << " -> " << message;
  }
}

TEST(GcodeMacros, ARunawayLoopStopsAtTheLimitNamingTheBlock) {
  ReaderOptions options;
  options.max_executed_blocks = 1000;
  const std::string loop = "G0 X0 Y0 Z0\nN10 #1 = #1 + 1\nGOTO 10\n";
  const std::string message = gcode_error(loop, options);
  EXPECT_NE(message.find("part.nc:"), std::string::npos) << message;
  EXPECT_NE(message.find("more than 1000 blocks run"), std::string::npos) << message;
  // The GOTO loop: the count starts at the first jump; the error names a block of the loop.
  EXPECT_TRUE(message.find("part.nc:2:") != std::string::npos ||
              message.find("part.nc:3:") != std::string::npos)
      << message;
  EXPECT_NE(gcode_error("G0 X0 Y0 Z0\nWHILE [1 EQ 1] DO 1\nEND 1\n", options)
                .find("max_executed_blocks"),
            std::string::npos);
  // A loop of n rounds runs, after its first END jumps back, 4 (n - 1) + 1 blocks (WHILE, two
  // blocks, END; the last WHILE): 997 for 250 rounds, within 1000; 1001 for 251, beyond.
  const auto rounds = [](int n) {
    return "G0 X0 Y0 Z0\n#1 = 0\nWHILE [#1 LT " + std::to_string(n) +
           "] DO 1\n#1 = #1 + 1\nG1 X[#1 / 10] F100\nEND 1\n";
  };
  EXPECT_EQ(gcode(rounds(250), options).points.size(), 251u);
  EXPECT_NE(gcode_error(rounds(251), options).find("more than 1000 blocks run"), std::string::npos);
  // A program that never jumps is not limited: 2000 blocks straight through.
  std::string straight = "G0 X0 Y0 Z0\n";
  for (int i = 1; i < 2000; ++i) straight += "G1 X" + std::to_string(i) + " F100\n";
  EXPECT_EQ(gcode(straight, options).points.size(), 2000u);
}

TEST(GcodeMacros, CallsNestedTooDeepAreAnError) {
  ReaderOptions options;
  options.max_call_depth = 10;
  const std::string recursion =
      "o100 sub\n#1 = [#1 + 1]\no100 call [#1]\no100 endsub\nG0 X0 Y0 Z0\no100 call [0]\n";
  const std::string message = gcode_error(recursion, options);
  EXPECT_NE(message.find("part.nc:3:"), std::string::npos) << message;
  EXPECT_NE(message.find("nested more than 10 deep"), std::string::npos) << message;
  // Ten levels are allowed: calls [0] .. [9], moves X1 .. X9.
  const std::string ten =
      "o100 sub\n"
      "o101 if [#1 LT 9]\n"
      "G1 X[#1 + 1] F100\n"
      "o100 call [#1 + 1]\n"
      "o101 endif\n"
      "o100 endsub\n"
      "G0 X0 Y0 Z0\n"
      "o100 call [0]\n";
  EXPECT_EQ(gcode(ten, options).points.size(), 10u);
}

TEST(GcodeMacros, APlainProgramKeepsItsBlocksAsWritten) {
  const std::string plain =
      "%\nO1234 (NAME)\nN10 G90 G0 X0 Y0 Z0\nN20 G1 X1.000 F100 (MOVE) ; END\nN30 TRAORI\nM30\n";
  const Toolpath path = gcode(plain);
  ASSERT_EQ(path.blocks.size(), 2u);
  EXPECT_EQ(path.blocks[1].text, "N20 G1 X1.000 F100 (MOVE) ; END");
  EXPECT_EQ(path.blocks[1].line, 4);
  EXPECT_EQ(path.blocks[1].block_number, 20);
}

}  // namespace
}  // namespace vmsim::toolpath

namespace vmsim::toolpath {
namespace {

/// A fresh folder for one test's files.
std::filesystem::path fresh_folder(const std::string& name) {
  const std::filesystem::path folder =
      std::filesystem::path(::testing::TempDir()) / ("vmsim_gcode_macros_" + name);
  std::filesystem::remove_all(folder);
  std::filesystem::create_directories(folder);
  return folder;
}

void write_file(const std::filesystem::path& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

TEST(GcodeMacros, SubprogramsInOtherFilesOfTheFolder) {
  // M98 P1234 finds O1234.nc (with its O line), G65 P77 finds 77.nc (the body alone), o<side>
  // call finds side.ngc (LinuxCNC).
  const std::filesystem::path folder = fresh_folder("files");
  write_file(folder / "main.nc", "G0 X0 Y0 Z0\nM98 P1234\nG65 P77 A3\no<side> call [2]\nM30\n");
  write_file(folder / "O1234.nc", "%\nO1234 (STEP)\nG1 X1 F100\nM99\n%\n");
  write_file(folder / "77.nc", "G1 Y#1\nM99\n");
  write_file(folder / "side.ngc", "o<side> sub\nG1 Z-#1\no<side> endsub\n");
  const Toolpath path = read_gcode((folder / "main.nc").string());
  expect_same_points(path, gcode("G0 X0 Y0 Z0\nG1 X1 F100\nG1 Y3\nG1 Z-2\n"));
  // Each block names its own file and line.
  const SourceBlock& step = path.blocks[static_cast<std::size_t>(path.points[1].block)];
  EXPECT_EQ(step.file, (folder / "O1234.nc").string());
  EXPECT_EQ(step.line, 3);
  const SourceBlock& side = path.blocks[static_cast<std::size_t>(path.points[3].block)];
  EXPECT_EQ(side.file, (folder / "side.ngc").string());
  EXPECT_EQ(side.line, 2);

  // An error in a subprogram file names that file.
  write_file(folder / "bad.nc", "G0 X0 Y0 Z0\nM98 P1235\nM30\n");
  write_file(folder / "O1235.nc", "G1 X1 Q5 F100\nM99\n");
  const std::string message =
      test::input_error_of([&] { read_gcode((folder / "bad.nc").string()); });
  EXPECT_NE(message.find((folder / "O1235.nc").string() + ":1:7: 'Q5'"), std::string::npos)
      << message;
  write_file(folder / "bad2.nc", "G0 X0 Y0 Z0\nM98 P1236\nM30\n");
  write_file(folder / "O1236.nc", "#1 = [1 / 0]\nM99\n");
  const std::string message2 =
      test::input_error_of([&] { read_gcode((folder / "bad2.nc").string()); });
  EXPECT_NE(message2.find((folder / "O1236.nc").string() + ":1:7: '1 / 0'"), std::string::npos)
      << message2;

  // parse_gcode (text, no folder) looks in no folder.
  EXPECT_NE(gcode_error("G0 X0 Y0 Z0\nM98 P1234\n").find("no subprogram O1234"),
            std::string::npos);
}

}  // namespace
}  // namespace vmsim::toolpath

namespace vmsim::toolpath {
namespace {

TEST(GcodeMacros, AProgramEndingWithM99IsTheMainProgramWhenNoneEndsWithM30) {
  // A file of one program that ends with M99 (it would loop on the control): it runs once.
  expect_same_points(gcode("O0001\nG0 X0 Y0 Z0\nG1 X1 F100\nM99\n"),
                     gcode("G0 X0 Y0 Z0\nG1 X1 F100\n"));
}

}  // namespace
}  // namespace vmsim::toolpath

namespace vmsim::toolpath {
namespace {

TEST(GcodeMacros, ReturnedValuesRepeatedMacroCallsAndM99InTheMainProgram) {
  // LinuxCNC: return [v] / endsub [v] leave v in #<_value>.
  expect_same_points(gcode("o<half> sub\n"
                           "o1 if [#1 LT 0]\n"
                           "  o<half> return [0]\n"
                           "o1 endif\n"
                           "o<half> endsub [#1 / 2]\n"
                           "G0 X0 Y0 Z0\n"
                           "o<half> call [7]\n"
                           "G1 X#<_value> F100\n"
                           "o<half> call [-7]\n"
                           "G1 Y[#<_value> + 1]\n"
                           "M2\n"),
                     gcode("G0 X0 Y0 Z0\nG1 X3.5 F100\nG1 Y1\n"));
  // Fanuc G65 L3: three runs, each from the arguments again (#1 counts up inside, from A1).
  expect_same_points(gcode("G0 X0 Y0 Z0\nG65 P10 L3 A1\nM30\n"
                           "O10\n#1 = #1 + 1\n#100 = #100 + #1\nG1 X#100 F100\nM99\n"),
                     gcode("G0 X0 Y0 Z0\nG1 X2 F100\nX4\nX6\n"));
  // M99 in the main program ends it (the control would start again): the blocks after it are
  // not run.
  expect_same_points(gcode("G0 X0 Y0 Z0\nG1 X1 F100\nM99\nG1 X5\nM30\n"),
                     gcode("G0 X0 Y0 Z0\nG1 X1 F100\n"));
}

}  // namespace
}  // namespace vmsim::toolpath

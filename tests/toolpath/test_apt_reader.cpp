// APT/CL reader: numbers, units, continuation, tool axis, records, and each kind of bad input.
// Expected values are hand-computed from the files (1 in = 25.4 mm, 1 mm/min = 1/60000 m/s).
#include <gtest/gtest.h>

#include <string>

#include "vmsim/common/errors.hpp"
#include "reader_test_support.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath {
namespace {

Toolpath apt(const std::string& text) { return parse_apt(text, "part.apt"); }

/// The message of the InputError that parsing `text` throws ("" when it does not throw).
std::string apt_error(const std::string& text) {
  return test::input_error_of([&] { apt(text); });
}

using test::expect_vector;

TEST(AptReader, FromIsARapidStartAndGotoIsLinearInMetres) {
  const Toolpath path = apt("FROM/0,0,100\nFEDRAT/600\nGOTO/10,20,30\n");
  ASSERT_EQ(path.points.size(), 2u);
  expect_vector(path.points[0].tip_W_m, {0.0, 0.0, 0.1});
  EXPECT_EQ(path.points[0].kind, MotionKind::rapid);
  EXPECT_EQ(path.points[0].feed_m_per_s, 0.0);
  expect_vector(path.points[1].tip_W_m, {0.010, 0.020, 0.030});
  expect_vector(path.points[1].axis_W, {0.0, 0.0, 1.0});
  EXPECT_EQ(path.points[1].kind, MotionKind::linear);
  EXPECT_NEAR(path.points[1].feed_m_per_s, 0.01, 1e-17);  // 600 mm/min = 10 mm/s
  ASSERT_EQ(path.blocks.size(), 2u);
  EXPECT_EQ(path.blocks[path.points[1].block].line, 3);
  EXPECT_EQ(path.blocks[path.points[1].block].text, "GOTO/10,20,30");
  EXPECT_EQ(path.blocks[path.points[1].block].file, "part.apt");
  EXPECT_TRUE(path.warnings.empty());
}

TEST(AptReader, InchesAndFeedUnits) {
  const Toolpath path = apt(
      "UNITS/INCHES\n"
      "FEDRAT/10,IPM\n"
      "RAPID\n"
      "GOTO/1,2,3\n"
      "GOTO/2,2,3\n"
      "FEDRAT/MMPM,127\n"
      "GOTO/3,2,3\n"
      "FEDRAT/5\n"  // inches per minute under UNITS/INCHES
      "GOTO/4,2,3\n"
      "UNITS/MM\n"
      "FEDRAT/IPM,2\n"
      "GOTO/5,2,3\n");
  ASSERT_EQ(path.points.size(), 5u);
  expect_vector(path.points[0].tip_W_m, {0.0254, 0.0508, 0.0762});
  EXPECT_EQ(path.points[0].kind, MotionKind::rapid);  // RAPID applies to the next GOTO only
  EXPECT_EQ(path.points[1].kind, MotionKind::linear);
  EXPECT_NEAR(path.points[1].feed_m_per_s, 0.254 / 60.0, 1e-17);  // 10 in/min = 254 mm/min
  EXPECT_NEAR(path.points[2].feed_m_per_s, 0.127 / 60.0, 1e-17);
  EXPECT_NEAR(path.points[3].feed_m_per_s, 0.127 / 60.0, 1e-17);  // 5 in/min = 127 mm/min
  expect_vector(path.points[4].tip_W_m, {0.005, 0.002, 0.003});  // back in mm
  EXPECT_NEAR(path.points[4].feed_m_per_s, 0.0508 / 60.0, 1e-17);
}

TEST(AptReader, ContinuationJoinsLinesAndCommentsAreSkipped) {
  const Toolpath path = apt(
      "$$ a comment line\n"
      "FEDRAT/60\n"
      "GOTO/1.5,$\n"
      "   -2.5,$   $$ a comment after the continuation mark\n"
      "   3.25  $$ and one at the end\n"
      "GOTO/4,5,6 $$ GOTO/7,8,9\n");
  ASSERT_EQ(path.points.size(), 2u);
  expect_vector(path.points[0].tip_W_m, {0.0015, -0.0025, 0.00325});
  EXPECT_EQ(path.blocks[path.points[0].block].line, 3);
  EXPECT_EQ(path.blocks[path.points[0].block].text, "GOTO/1.5,    -2.5,    3.25");
  expect_vector(path.points[1].tip_W_m, {0.004, 0.005, 0.006});
  EXPECT_EQ(path.blocks[path.points[1].block].line, 6);
}

TEST(AptReader, MultaxAndTlaxisSetTheToolAxis) {
  const Toolpath path = apt(
      "FEDRAT/100\n"
      "TLAXIS/0,3,4\n"
      "GOTO/1,2,3\n"            // TLAXIS axis
      "MULTAX/ON\n"
      "GOTO/1,2,4,0,0,2\n"      // own axis, normalised
      "GOTO/1,2,5,1,0,0,1,2,6,0,-1,0\n"  // two points under MULTAX/ON
      "MULTAX/OFF\n"
      "GOTO/1,2,7,1,2,8\n"      // two points with the current axis
      "TLAXIS/-2,0,0\n"
      "GOTO/1,2,9\n");
  ASSERT_EQ(path.points.size(), 7u);
  expect_vector(path.points[0].axis_W, {0.0, 0.6, 0.8});
  expect_vector(path.points[1].tip_W_m, {0.001, 0.002, 0.004});
  expect_vector(path.points[1].axis_W, {0.0, 0.0, 1.0});
  expect_vector(path.points[2].axis_W, {1.0, 0.0, 0.0});
  expect_vector(path.points[3].tip_W_m, {0.001, 0.002, 0.006});
  expect_vector(path.points[3].axis_W, {0.0, -1.0, 0.0});
  EXPECT_EQ(path.points[2].block, path.points[3].block);
  expect_vector(path.points[4].tip_W_m, {0.001, 0.002, 0.007});
  expect_vector(path.points[4].axis_W, {0.0, -1.0, 0.0});  // the last given axis stays
  expect_vector(path.points[5].tip_W_m, {0.001, 0.002, 0.008});
  expect_vector(path.points[6].axis_W, {-1.0, 0.0, 0.0});
  // Without MULTAX a GOTO takes 3 or 6 values.
  const Toolpath plain = apt("FEDRAT/100\nGOTO/0,0,0,0,1,0\nGOTO/0,0,1\n");
  expect_vector(plain.points[0].axis_W, {0.0, 1.0, 0.0});
  expect_vector(plain.points[1].axis_W, {0.0, 1.0, 0.0});
}

TEST(AptReader, UnknownRecordIsAWarningWithItsLine) {
  const Toolpath path = apt(
      "PARTNO A PART, WITH $ AND / IN ITS NAME\n"
      "PPRINT ANY TEXT, 1.2.3\n"
      "MACHIN/MILL,1\n"
      "SPINDL/RPM,10000,CLW\n"
      "COOLNT/ON\n"
      "LOADTL/1\n"
      "FEDRAT/100\n"
      "WOBBLE/1,2\n"
      "GOTO/1,2,3\n"
      "END\n");
  ASSERT_EQ(path.points.size(), 1u);
  ASSERT_EQ(path.warnings.size(), 1u);
  EXPECT_EQ(path.warnings[0].line, 8);
  EXPECT_EQ(path.warnings[0].file, "part.apt");
  EXPECT_NE(path.warnings[0].message.find("WOBBLE"), std::string::npos);
}

// LOADTL/n puts tool n in the spindle for the motions that follow (PathPoint::tool_number);
// before any LOADTL the part file's tool (-1). A tool number that is not whole is an error.
TEST(AptReader, LoadtlSetsTheToolNumberOfTheFollowingMotions) {
  const Toolpath path = apt(
      "FROM/0,0,100\nFEDRAT/600\nGOTO/1,0,100\nLOADTL/7,LENGTH,60\nGOTO/2,0,100\n"
      "GOTO/3,0,100\nLOADTL/2\nGOTO/4,0,100\n");
  ASSERT_EQ(path.points.size(), 5u);
  const int expected[] = {-1, -1, 7, 7, 2};
  for (std::size_t i = 0; i < 5; ++i) EXPECT_EQ(path.points[i].tool_number, expected[i]) << i;
  EXPECT_TRUE(path.warnings.empty());
  EXPECT_NE(apt_error("FEDRAT/600\nLOADTL/2.5\nGOTO/1,2,3\n").find("part.apt:2"), std::string::npos);
  EXPECT_NE(apt_error("FEDRAT/600\nLOADTL/2.5\nGOTO/1,2,3\n").find("'2.5'"), std::string::npos);
}

TEST(AptReader, CutterDiameterAndCornerRadius) {
  Toolpath path = apt("CUTTER/10,2\nFEDRAT/1\nGOTO/0,0,0\n");
  EXPECT_NEAR(*path.cutter_diameter_m, 0.010, 1e-18);
  EXPECT_NEAR(*path.cutter_corner_radius_m, 0.002, 1e-18);
  path = apt("UNITS/INCHES\nCUTTER/0.5,0.25,0,0.25,0,0,3\nFEDRAT/1\nGOTO/0,0,0\n");
  EXPECT_NEAR(*path.cutter_diameter_m, 0.0127, 1e-18);
  EXPECT_NEAR(*path.cutter_corner_radius_m, 0.00635, 1e-18);
  path = apt("CUTTER/6\nFEDRAT/1\nGOTO/0,0,0\n");
  EXPECT_NEAR(*path.cutter_corner_radius_m, 0.0, 0.0);
}

TEST(AptReader, FiniEndsTheFileAndZeroLengthMovesAddNoPoint) {
  const Toolpath path =
      apt("FROM/1,1,1\nFEDRAT/10\nGOTO/1,1,1\nGOTO/2,1,1\nFINI\nGOTO/this is not read\n");
  ASSERT_EQ(path.points.size(), 2u);
  EXPECT_EQ(path.points[0].kind, MotionKind::rapid);
  expect_vector(path.points[1].tip_W_m, {0.002, 0.001, 0.001});
}

TEST(AptReader, MalformedGotoNamesFileLineColumnAndWord) {
  const std::string message = apt_error("FEDRAT/100\nGOTO/1.0, 2.x, 3\n");
  EXPECT_NE(message.find("part.apt:2:11:"), std::string::npos) << message;
  EXPECT_NE(message.find("'2.x'"), std::string::npos) << message;
}

TEST(AptReader, MalformedNumberOnAContinuationLineNamesThatLine) {
  const std::string message = apt_error("FEDRAT/100\nGOTO/1,$\n  2,$\n    3e\n");
  EXPECT_NE(message.find("part.apt:4:5:"), std::string::npos) << message;
  EXPECT_NE(message.find("'3e'"), std::string::npos) << message;
}

TEST(AptReader, EachKindOfBadInputIsAnError) {
  struct Case {
    const char* text;
    const char* where;  // file:line:column expected in the message
    const char* what;   // a word expected in the message
  };
  const Case cases[] = {
      {"FEDRAT/100\nGOTO/1,2\n", "part.apt:2:1:", "GOTO needs"},
      {"FEDRAT/100\nGOTO/1,2,3,4\n", "part.apt:2:1:", "got 4"},
      {"FEDRAT/100\nGOTO/1,,3\n", "part.apt:2:8:", "empty value"},
      {"FEDRAT/100\nGOTO/1,2,3,0,0,0\n", "part.apt:2:12:", "zero tool axis"},
      {"FEDRAT/100\nMULTAX/ON\nGOTO/1,2,3\n", "part.apt:3:1:", "MULTAX is on"},
      {"FEDRAT/100\nMULTAX/OFF\nGOTO/1,2,3,4\n", "part.apt:3:1:", "MULTAX is off"},
      {"FEDRAT/100\nMULTAX/MAYBE\n", "part.apt:2:8:", "MAYBE"},
      {"FEDRAT/100\nTLAXIS/0,0,0\n", "part.apt:2:1:", "zero tool axis"},
      {"FEDRAT/100\nTLAXIS/0,1\n", "part.apt:2:1:", "TLAXIS needs"},
      {"FROM/0,0,0\nGOTO/1,2,3\n", "part.apt:2:1:", "before any FEDRAT"},
      {"FEDRAT/0\n", "part.apt:1:8:", "positive"},
      {"FEDRAT/-5,MMPM\n", "part.apt:1:8:", "positive"},
      {"FEDRAT/2,MMPR\n", "part.apt:1:10:", "per revolution"},
      {"FEDRAT/2,FURLONGS\n", "part.apt:1:10:", "FURLONGS"},
      {"FEDRAT/2,3\n", "part.apt:1:10:", "second value"},
      {"UNITS/FEET\n", "part.apt:1:7:", "FEET"},
      {"CUTTER/-1\n", "part.apt:1:8:", "diameter"},
      {"CUTTER/10,6\n", "part.apt:1:11:", "corner radius"},
      {"FEDRAT/100\nGOTO 1,2,3\n", "part.apt:2:6:", "expected '/'"},
      {"RAPID/1\n", "part.apt:1:7:", "no value"},
      {"FEDRAT/100\nCUTCOM/LEFT\n", "part.apt:2:1:", "cutter compensation"},
      {"FEDRAT/100\nCIRCLE/0,0,0,0,0,1,5\n", "part.apt:2:1:", "circular"},
      {"FEDRAT/100\nGOTO/1,2,$\n", "part.apt:2", "continued"},
      {"", "part.apt:", "no motion"},
      {"$$ only a comment\nPARTNO NOTHING\nFEDRAT/100\n", "part.apt:", "no motion"},
  };
  for (const Case& c : cases) {
    const std::string message = apt_error(c.text);
    EXPECT_NE(message.find(c.where), std::string::npos) << c.text << " -> " << message;
    EXPECT_NE(message.find(c.what), std::string::npos) << c.text << " -> " << message;
  }
}

TEST(AptReader, ReadsAFileAndNamesItInErrors) {
  const std::string file = std::string(VMSIM_SOURCE_DIR) + "/tests/data/toolpaths/five_axis.apt";
  const Toolpath path = read_toolpath(file);
  ASSERT_EQ(path.points.size(), 7u);
  EXPECT_EQ(path.blocks[path.points.back().block].file, file);
  EXPECT_EQ(path.blocks[path.points[4].block].line, 15);  // the continued GOTO
  EXPECT_TRUE(path.warnings.empty());
  EXPECT_NEAR(*path.cutter_diameter_m, 0.010, 1e-18);

  const std::string missing = std::string(VMSIM_SOURCE_DIR) + "/tests/data/toolpaths/none.apt";
  try {
    read_apt(missing);
    ADD_FAILURE() << "no error for a missing file";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find(missing), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace vmsim::toolpath

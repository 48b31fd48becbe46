// Hostile part files: misspelt keys, wrong YAML types, keys given twice, extra documents,
// implausible numbers, byte-order marks (also in an STL stock). Each is a located InputError,
// exit code 3 from the program, never "internal error".
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <fstream>
#include <string>

#include "cli_runner.hpp"
#include "part_file.hpp"
#include "vmsim/common/errors.hpp"

namespace vmsim {
namespace {

const std::string kRoot = VMSIM_SOURCE_DIR;

// The lines of a valid part file; `tool_line` (line 4) and `extra` (appended) vary.
std::string part_text(const std::string& tool_line, const std::string& extra = "") {
  return "name: defects\n"
         "machine: " + kRoot + "/samples/machines/mikron_ucp710.yaml\n"
         "toolpath: " + kRoot + "/samples/parts/part1_tangency/toolpath.apt\n" +
         tool_line + "\n"
         "stock: {box: {min_mm: [-40, -5, 0], max_mm: [40, 5, 40]}}\n"
         "feeds: {production_mm_per_min: 10000, reference_mm_per_min: 100}\n" + extra;
}

const std::string kGoodTool = "tool: {type: ball, diameter_mm: 10, corner_radius_mm: 5, length_mm: 60}";

std::string write_part(const std::string& test_name, const std::string& text) {
  const auto folder = test::fresh_folder(test_name);
  std::ofstream(folder / "part.yaml") << text;
  return (folder / "part.yaml").string();
}

// The message of load_part, "" when it loads; fails the test on any other exception type.
std::string error_of(const std::string& test_name, const std::string& text) {
  const std::string path = write_part(test_name, text);
  try {
    app::load_part(path);
  } catch (const InputError& error) {
    return error.what();
  } catch (const std::exception& error) {
    ADD_FAILURE() << "not an InputError: " << error.what();
    return std::string("not an InputError: ") + error.what();
  }
  return "";
}

TEST(PartFileDefects, TheBaseTextLoads) { EXPECT_EQ(error_of("part_ok", part_text(kGoodTool)), ""); }

// A stock STL name longer than the file system allows threw std::filesystem::filesystem_error
// ("File name too long"), an internal error (found by fuzz_part_file).
TEST(PartFileDefects, AStlNameTooLongForTheFileSystemIsLocated) {
  std::string text = part_text(kGoodTool);
  text.replace(text.find("stock: {box: {min_mm: [-40, -5, 0], max_mm: [40, 5, 40]}}"),
               std::string("stock: {box: {min_mm: [-40, -5, 0], max_mm: [40, 5, 40]}}").size(),
               "stock: {stl: " + std::string(5000, 'a') + ".stl}");
  const std::string message = error_of("part_long_stl", text);
  EXPECT_NE(message.find("part.yaml:5"), std::string::npos) << message;
  EXPECT_NE(message.find("stock.stl: no file"), std::string::npos) << message;
}

TEST(PartFileDefects, MisspeltKeyIsRefusedWithTheNearestKnownOne) {
  const std::string error = error_of(
      "part_misspelt",
      part_text("tool: {type: ball, diameter_mm: 10, length_mm: 60, cuting_length_mm: 10}"));
  EXPECT_NE(error.find("part.yaml:4:"), std::string::npos) << error;
  EXPECT_NE(error.find("unknown field 'tool.cuting_length_mm' (did you mean 'cutting_length_mm'?)"),
            std::string::npos)
      << error;
}

TEST(PartFileDefects, MisspeltTopLevelKeyIsRefused) {
  const std::string error =
      error_of("part_top_misspelt", part_text(kGoodTool, "desing: {surfaces: []}\n"));
  EXPECT_NE(error.find("part.yaml:7:1: unknown field 'desing' (did you mean 'design'?)"),
            std::string::npos)
      << error;
}

TEST(PartFileDefects, MapWhereANumberIsExpectedIsLocated) {
  const std::string error = error_of(
      "part_map_number",
      part_text("tool: {type: ball, diameter_mm: 10, corner_radius_mm: {r: 5}, length_mm: 60}"));
  EXPECT_NE(error.find("part.yaml:4:"), std::string::npos) << error;
  EXPECT_NE(error.find("tool.corner_radius_mm: expected a number, got a map"), std::string::npos)
      << error;
}

TEST(PartFileDefects, TextWhereANumberIsExpectedIsLocated) {
  const std::string error = error_of(
      "part_text_number",
      part_text("tool: {type: ball, diameter_mm: 10, corner_radius_mm: five, length_mm: 60}"));
  EXPECT_NE(error.find("tool.corner_radius_mm: 'five' is not a number"), std::string::npos)
      << error;
}

TEST(PartFileDefects, MapWhereATextIsExpectedIsLocated) {
  const std::string error =
      error_of("part_map_text", part_text(kGoodTool, "description: {a: 1}\n"));
  EXPECT_NE(error.find("part.yaml:7:"), std::string::npos) << error;
  EXPECT_NE(error.find("description: expected a text value, got a map"), std::string::npos)
      << error;
}

TEST(PartFileDefects, KeyGivenTwiceIsRefused) {
  const std::string error = error_of(
      "part_twice",
      part_text("tool: {type: ball, diameter_mm: 10, length_mm: 60, diameter_mm: 12}"));
  EXPECT_NE(error.find("part.yaml:4:"), std::string::npos) << error;
  EXPECT_NE(error.find("'diameter_mm' is given twice"), std::string::npos) << error;
}

TEST(PartFileDefects, SecondDocumentIsRefused) {
  const std::string error =
      error_of("part_second_document", part_text(kGoodTool, "---\nname: other\n"));
  EXPECT_NE(error.find("part.yaml:8:"), std::string::npos) << error;
  EXPECT_NE(error.find("second YAML document"), std::string::npos) << error;
}

TEST(PartFileDefects, SubnormalDiameterIsRefusedWithItsValue) {
  const std::string error = error_of(
      "part_subnormal", part_text("tool: {type: ball, diameter_mm: 4.9e-324, length_mm: 60}"));
  EXPECT_NE(error.find("'4.9e-324'"), std::string::npos) << error;
}

TEST(PartFileDefects, AbsurdToolLengthIsRefused) {
  const std::string error =
      error_of("part_long_tool", part_text("tool: {type: ball, diameter_mm: 10, length_mm: 1e300}"));
  EXPECT_NE(error.find("tool.length_mm"), std::string::npos) << error;
  EXPECT_NE(error.find("not a plausible"), std::string::npos) << error;
}

TEST(PartFileDefects, UnknownPatchTypeIsRefusedWithTheNearestType) {
  const std::string error = error_of(
      "part_patch_type",
      part_text(kGoodTool, "design: {surfaces: [{type: plain, point_mm: [0, 0, 0], normal: [0, 0, 1]}]}\n"));
  EXPECT_NE(error.find("did you mean 'plane'?"), std::string::npos) << error;
}

TEST(PartFileDefects, MisspeltPatchKeyIsRefused) {
  const std::string error = error_of(
      "part_patch_key",
      part_text(kGoodTool,
                "design: {surfaces: [{type: sphere, centre_mm: [0, 0, 0], center_mm: [0, 0, 0], "
                "radius_mm: 4, material: inside}]}\n"));
  EXPECT_NE(error.find("unknown field 'design.surfaces[0].centre_mm' (did you mean 'center_mm'?)"),
            std::string::npos)
      << error;
}

TEST(PartFileDefects, ByteOrderMarkIsSkipped) {
  EXPECT_EQ(error_of("part_bom", "\xEF\xBB\xBF" + part_text(kGoodTool)), "");
}

TEST(PartFileDefects, AsciiStlStockWithAByteOrderMarkIsRead) {
  const auto folder = test::fresh_folder("part_stl_bom");
  // A tetrahedron, outward normals, after a byte-order mark.
  std::ofstream(folder / "stock.stl")
      << "\xEF\xBB\xBFsolid t\n"
         "facet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex 0 10 0\nvertex 10 0 0\nendloop\nendfacet\n"
         "facet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex 10 0 0\nvertex 0 0 10\nendloop\nendfacet\n"
         "facet normal 0 0 0\nouter loop\nvertex 0 0 0\nvertex 0 0 10\nvertex 0 10 0\nendloop\nendfacet\n"
         "facet normal 0 0 0\nouter loop\nvertex 10 0 0\nvertex 0 10 0\nvertex 0 0 10\nendloop\nendfacet\n"
         "endsolid t\n";
  std::string text = part_text(kGoodTool);
  const std::string box = "stock: {box: {min_mm: [-40, -5, 0], max_mm: [40, 5, 40]}}";
  text.replace(text.find(box), box.size(), "stock: {stl: stock.stl}");
  std::ofstream(folder / "part.yaml") << text;
  const app::PartDescription part = app::load_part((folder / "part.yaml").string());
  ASSERT_TRUE(part.stock_mesh.has_value());
  EXPECT_EQ(part.stock_mesh->triangles.size(), 4u);
}

TEST(PartFileDefects, ProgramExitsWith3OnAWrongType) {
  const auto folder = test::fresh_folder("part_cli_type");
  const std::string path = write_part(
      "part_cli_type",
      part_text("tool: {type: ball, diameter_mm: 10, corner_radius_mm: [5], length_mm: 60}"));
  const test::RunResult run = test::run_vmsim("kinematics --part " + path + " --out " +
                                              (folder / "axes.csv").string());
  EXPECT_EQ(run.exit_code, 3) << run.output;
  EXPECT_NE(run.output.find("part.yaml:4:"), std::string::npos) << run.output;
  EXPECT_EQ(run.output.find("internal error"), std::string::npos) << run.output;
}

TEST(PartFileDefects, ProgramExitsWith3OnAFifo) {
  const auto folder = test::fresh_folder("part_cli_fifo");
  const std::string fifo = (folder / "part.yaml").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const test::RunResult run =
      test::run_vmsim("kinematics --part " + fifo + " --out " + (folder / "axes.csv").string());
  EXPECT_EQ(run.exit_code, 3) << run.output;
  EXPECT_NE(run.output.find("FIFO"), std::string::npos) << run.output;
}

}  // namespace
}  // namespace vmsim

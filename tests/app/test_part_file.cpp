// Part files (app/part_file.hpp): the design patches simulate-part looks along, and the errors a
// bad patch gives (the file, the line, the field and the value).
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "cli_runner.hpp"
#include "part_file.hpp"
#include "vmsim/common/errors.hpp"

namespace vmsim {
namespace {

const std::string kRoot = VMSIM_SOURCE_DIR;

// A part file whose design is the one patch `patch` (line 7 of the file); returns its path.
std::string part_with_patch(const std::filesystem::path& folder, const std::string& patch) {
  std::ofstream(folder / "part.yaml")
      << "name: one_patch\n"
         "machine: " << kRoot << "/samples/machines/mikron_ucp710.yaml\n"
         "toolpath: toolpath.apt\n"
         "tool: {type: flat, diameter_mm: 10, length_mm: 60}\n"
         "stock: {box: {min_mm: [-20, -20, 0], max_mm: [20, 20, 30]}}\n"
         "design:\n"
         "  surfaces: [" << patch << "]\n"
         "feeds: {production_mm_per_min: 10000, reference_mm_per_min: 100}\n";
  return (folder / "part.yaml").string();
}

TEST(PartFile, ACylinderPatchIsReadInMetresWithAUnitAxis) {
  const auto folder = test::fresh_folder("part_cylinder");
  const app::PartDescription part = app::load_part(part_with_patch(
      folder, "{type: cylinder, axis_point_mm: [1, 2, 3], axis_direction: [0, 0, 2], radius_mm: 10, "
              "material: inside, z_range_mm: [20, 30]}"));
  ASSERT_EQ(part.design_cylinders.size(), 1u);
  const app::DesignCylinder& cylinder = part.design_cylinders[0];
  EXPECT_TRUE(cylinder.axis_point_W_m.isApprox(Eigen::Vector3d(1e-3, 2e-3, 3e-3)));
  EXPECT_TRUE(cylinder.axis_W.isApprox(Eigen::Vector3d::UnitZ()));
  EXPECT_DOUBLE_EQ(cylinder.radius_m, 10e-3);
  EXPECT_TRUE(cylinder.material_inside);
  EXPECT_DOUBLE_EQ(cylinder.min_W_m.z(), 20e-3);
  EXPECT_DOUBLE_EQ(cylinder.max_W_m.z(), 30e-3);
  EXPECT_TRUE(std::isinf(cylinder.min_W_m.x()) && cylinder.min_W_m.x() < 0);
  EXPECT_TRUE(std::isinf(cylinder.max_W_m.y()) && cylinder.max_W_m.y() > 0);
  // Sample part 1: the concave R15 fillet between its planes.
  const app::PartDescription part1 = app::load_part(kRoot + "/samples/parts/part1_tangency/part.yaml");
  ASSERT_EQ(part1.design_cylinders.size(), 1u);
  EXPECT_FALSE(part1.design_cylinders[0].material_inside);
  EXPECT_TRUE(part1.design_cylinders[0].axis_W.isApprox(Eigen::Vector3d::UnitY()));
  EXPECT_DOUBLE_EQ(part1.design_cylinders[0].max_W_m.x(), 7.5e-3);
  EXPECT_EQ(part1.design_planes.size(), 2u);
}

// Each bad cylinder: an InputError at line 7 of the part file naming the field and the value.
TEST(PartFile, ABadCylinderIsALocatedErrorNamingTheFieldAndTheValue) {
  const auto folder = test::fresh_folder("part_cylinder_bad");
  const std::string good = "axis_point_mm: [0, 0, 0], axis_direction: [0, 0, 1], radius_mm: 10, material: inside";
  struct Case {
    std::string patch, field, value;
  };
  const Case cases[] = {
      {"axis_point_mm: [0, 0], axis_direction: [0, 0, 1], radius_mm: 10, material: inside",
       "design.surfaces[0].axis_point_mm", "[x, y, z]"},
      {"axis_point_mm: [0, 0, a], axis_direction: [0, 0, 1], radius_mm: 10, material: inside",
       "design.surfaces[0].axis_point_mm", "'a'"},
      {"axis_point_mm: [0, 0, 0], axis_direction: [0, 0, 0], radius_mm: 10, material: inside",
       "design.surfaces[0].axis_direction", "[0, 0, 0]"},
      {"axis_point_mm: [0, 0, 0], radius_mm: 10, material: inside", "design.surfaces[0].axis_direction", "missing"},
      {"axis_point_mm: [0, 0, 0], axis_direction: [0, 0, 1], radius_mm: -2, material: inside",
       "design.surfaces[0].radius_mm", "'-2'"},
      {"axis_point_mm: [0, 0, 0], axis_direction: [0, 0, 1], radius_mm: ten, material: inside",
       "design.surfaces[0].radius_mm", "'ten'"},
      {"axis_point_mm: [0, 0, 0], axis_direction: [0, 0, 1], radius_mm: 10, material: sideways",
       "design.surfaces[0].material", "'sideways'"},
      {good + ", z_range_mm: [30, 20]", "design.surfaces[0].z_range_mm", "[30, 20]"},
      {good + ", x_range_mm: [1]", "design.surfaces[0].x_range_mm", "[low, high]"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.patch);
    const std::string path = part_with_patch(folder, "{type: cylinder, " + c.patch + "}");
    try {
      app::load_part(path);
      ADD_FAILURE() << "no error";
    } catch (const InputError& error) {
      const std::string message = error.what();
      EXPECT_NE(message.find(path + ":7:"), std::string::npos) << message;
      EXPECT_NE(message.find(c.field), std::string::npos) << message;
      EXPECT_NE(message.find(c.value), std::string::npos) << message;
    }
  }
}

// A patch's own tolerance and name (the report's verdict on the marks that lie on it); a patch
// without them gets "design surface <k> (<type>)" and the part's tolerance (0 here: its own).
TEST(PartFile, APatchMayHaveItsOwnToleranceAndName) {
  const auto folder = test::fresh_folder("part_patch_tolerance");
  const app::PartDescription part = app::load_part(part_with_patch(
      folder, "{type: plane, point_mm: [0, 20, 0], normal: [0, -1, 0], name: sealing face, tolerance_um: 4.5}, "
              "{type: cylinder, axis_point_mm: [0, 0, 0], axis_direction: [0, 0, 1], radius_mm: 10, material: inside, "
              "z_range_mm: [20, 30]}"));
  ASSERT_EQ(part.design_patches.size(), 2u);
  EXPECT_EQ(part.design_patches[0].name, "sealing face");
  EXPECT_EQ(part.design_patches[0].type, "plane");
  EXPECT_DOUBLE_EQ(part.design_patches[0].tolerance_m, 4.5e-6);
  EXPECT_EQ(part.design_patches[1].name, "design surface 2 (cylinder)");
  EXPECT_EQ(part.design_patches[1].tolerance_m, 0.0);
  EXPECT_DOUBLE_EQ(part.design_patches[1].min_W_m.z(), 20e-3);
  ASSERT_EQ(part.design_planes.size(), 1u);
  ASSERT_EQ(part.design_cylinders.size(), 1u);
  EXPECT_EQ(part.design_planes[0].patch_index, 0u);
  EXPECT_EQ(part.design_cylinders[0].patch_index, 1u);
  EXPECT_EQ(part.tolerance_m, 0.0);
}

// A bad tolerance of a patch: an InputError at line 7 naming the field and the value.
TEST(PartFile, ABadPatchToleranceIsALocatedErrorNamingTheValue) {
  const auto folder = test::fresh_folder("part_patch_tolerance_bad");
  for (const std::string value : {"-3", "0", "ten", "20000"}) {
    SCOPED_TRACE(value);
    const std::string path = part_with_patch(
        folder, "{type: plane, point_mm: [0, 0, 20], normal: [0, 0, 1], tolerance_um: " + value + "}");
    try {
      app::load_part(path);
      ADD_FAILURE() << "no error";
    } catch (const InputError& error) {
      const std::string message = error.what();
      EXPECT_NE(message.find(path + ":7:"), std::string::npos) << message;
      EXPECT_NE(message.find("design.surfaces[0].tolerance_um"), std::string::npos) << message;
      EXPECT_NE(message.find(value), std::string::npos) << message;
    }
  }
}

}  // namespace
}  // namespace vmsim

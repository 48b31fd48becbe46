// Surface views (app/surface_views.hpp) against their closed form: a cylinder view's lines run
// along the cylinder's normals from inside the material to out of it, over the patch where the
// tool tips come near, and nowhere else.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "part_file.hpp"
#include "surface_views.hpp"
#include "vmsim/common/errors.hpp"

namespace vmsim {
namespace {

// Sample part 1's concave R15 fillet (axis along y at x = 0, z = 35; the patch x in [0, 7.5] mm).
app::PartDescription fillet_part() {
  app::PartDescription part;
  app::DesignCylinder fillet;
  fillet.axis_point_W_m = Eigen::Vector3d(0, 0, 35e-3);
  fillet.axis_W = Eigen::Vector3d::UnitY();
  fillet.radius_m = 15e-3;
  fillet.material_inside = false;
  fillet.min_W_m.x() = 0.0;
  fillet.max_W_m.x() = 7.5e-3;
  fillet.min_W_m.y() = -5e-3;
  fillet.max_W_m.y() = 5e-3;
  part.design_cylinders.push_back(fillet);
  return part;
}

const removal::Box kStock{Eigen::Vector3d(-40e-3, -5e-3, 0), Eigen::Vector3d(40e-3, 5e-3, 40e-3)};

// Tips of a ball D10 along the pass y = y_m, from x = -46 to 42 mm: on the floor, in the fillet
// (the ball's centre 10 mm from the axis) and on the inclined plane.
std::vector<Eigen::Vector3d> pass_tips(double y_m) {
  std::vector<Eigen::Vector3d> tips;
  for (double x = -46e-3; x <= 42e-3; x += 0.2e-3) {
    double z = 20e-3;
    if (x > 0 && x < 5e-3) z = 30e-3 - std::sqrt(10e-3 * 10e-3 - x * x);
    if (x >= 5e-3) z = 30e-3 - 10e-3 * std::cos(std::numbers::pi / 6) + (x - 5e-3) * std::tan(std::numbers::pi / 6);
    tips.emplace_back(x, y_m, z);
  }
  return tips;
}

TEST(SurfaceViews, ACylinderViewsLinesAreItsNormalsOverThePatchTheTipsReach) {
  const app::PartDescription part = fillet_part();
  std::vector<Eigen::Vector3d> tips = pass_tips(-4.75e-3);
  const std::vector<Eigen::Vector3d> more = pass_tips(4.75e-3);
  tips.insert(tips.end(), more.begin(), more.end());
  const std::vector<app::SurfaceView> views = app::surface_views(part, kStock, 20e-6, tips, 10e-3);
  ASSERT_EQ(views.size(), 2u);
  const app::SurfaceView& view = views[1];
  EXPECT_EQ(view.id, "cylinder1");
  EXPECT_FALSE(view.zmap);
  EXPECT_EQ(view.shape, app::ViewShape::cylinder);
  EXPECT_DOUBLE_EQ(view.spacing_m, app::kCylinderViewMinSpacing_m);
  const double bin_m = 15e-3 * 2 * std::numbers::pi / 3600;  // the band is found to a 0.1 deg bin
  double x_min = 1.0, x_max = -1.0, y_min = 1.0, y_max = -1.0;
  for (int j = 0; j < view.nv; ++j) {
    for (int i = 0; i < view.nu; ++i) {
      Eigen::Vector3d origin, direction;
      view.line(i, j, origin, direction);
      // The foot on the cylinder, the direction along its normal towards the axis (out of the
      // material of a concave fillet), the origin 1 mm behind the surface.
      const Eigen::Vector3d foot = origin + view.depth_inside_m * direction;
      const Eigen::Vector3d radial(foot.x(), 0.0, foot.z() - 35e-3);
      ASSERT_NEAR(radial.norm(), 15e-3, 1e-12) << i << ", " << j;
      ASSERT_NEAR(direction.norm(), 1.0, 1e-12);
      ASSERT_NEAR(direction.y(), 0.0, 1e-12);
      ASSERT_NEAR(direction.dot(-radial.normalized()), 1.0, 1e-12);
      EXPECT_DOUBLE_EQ(view.depth_inside_m, 1e-3);
      x_min = std::min(x_min, foot.x());
      x_max = std::max(x_max, foot.x());
      y_min = std::min(y_min, foot.y());
      y_max = std::max(y_max, foot.y());
    }
  }
  // Over the patch: x from 0 to 7.5 mm (to a bin and a line), y over the stock's -5 to 5 mm.
  EXPECT_GE(x_min, -1e-12);
  EXPECT_LT(x_min, bin_m + view.spacing_m);
  EXPECT_LE(x_max, 7.5e-3 + 1e-12);
  EXPECT_GT(x_max, 7.5e-3 - bin_m - view.spacing_m);
  // Rows at the centres of the axial cells: half a spacing inside each end.
  EXPECT_NEAR(y_min, -5e-3 + 0.5 * view.spacing_m, 1e-12);
  EXPECT_NEAR(y_max, 5e-3 - 0.5 * view.spacing_m, 1e-9);
  EXPECT_EQ(view.nv, static_cast<int>(std::round(10e-3 / view.spacing_m)));
  // Neighbouring lines are a spacing apart on the surface (along the arc and along the axis).
  Eigen::Vector3d a, b, c, direction;
  view.line(0, 0, a, direction);
  view.line(1, 0, b, direction);
  view.line(0, 1, c, direction);
  const double inner_radius = 16e-3;  // the origins: 1 mm behind the surface, away from the axis
  EXPECT_NEAR((b - a).norm(), 2 * inner_radius * std::sin(view.spacing_m / 15e-3 / 2), 1e-12);
  EXPECT_NEAR((c - a).norm(), view.spacing_m, 1e-12);
}

// Tips far from the fillet (a pass on the plane beyond reach), or the patch outside the stock:
// no cylinder view.
TEST(SurfaceViews, NoCylinderViewWhereTheTipsDoNotComeNear) {
  const app::PartDescription part = fillet_part();
  std::vector<Eigen::Vector3d> far;
  for (double x = -46e-3; x < -30e-3; x += 0.2e-3) far.emplace_back(x, 0.0, 20e-3);
  EXPECT_EQ(app::surface_views(part, kStock, 20e-6, far, 10e-3).size(), 1u);
  const removal::Box elsewhere{Eigen::Vector3d(-40e-3, 10e-3, 0), Eigen::Vector3d(40e-3, 20e-3, 40e-3)};
  EXPECT_EQ(app::surface_views(part, elsewhere, 20e-6, pass_tips(0.0), 10e-3).size(), 1u);
}

// A boss (material inside) with tips all round it: the band closes round the axis, the lines
// point away from it.
TEST(SurfaceViews, ACylinderViewAllRoundABossLooksAwayFromTheAxis) {
  app::PartDescription part;
  app::DesignCylinder boss;
  boss.axis_W = Eigen::Vector3d::UnitZ();
  boss.radius_m = 10e-3;
  boss.material_inside = true;
  boss.min_W_m.z() = 20e-3;
  boss.max_W_m.z() = 30e-3;
  part.design_cylinders.push_back(boss);
  std::vector<Eigen::Vector3d> tips;
  for (int k = 0; k < 360; ++k) {
    const double a = k * std::numbers::pi / 180;
    tips.emplace_back(15e-3 * std::cos(a), 15e-3 * std::sin(a), 20e-3);
  }
  const removal::Box stock{Eigen::Vector3d(-22e-3, -22e-3, 10e-3), Eigen::Vector3d(22e-3, 22e-3, 30e-3)};
  const std::vector<app::SurfaceView> views = app::surface_views(part, stock, 50e-6, tips, 10e-3);
  ASSERT_EQ(views.size(), 2u);
  const app::SurfaceView& view = views[1];
  EXPECT_EQ(view.nu, static_cast<int>(std::ceil(2 * std::numbers::pi * 10e-3 / view.spacing_m)));
  EXPECT_NEAR(view.nu * view.azimuth_step_rad, 2 * std::numbers::pi, 1e-12);
  EXPECT_NEAR(view.axial_first_m, 20e-3 + 0.5 * view.spacing_m, 1e-12);  // the first cell's centre
  ASSERT_EQ(view.nv, static_cast<int>(std::round(10e-3 / view.spacing_m)));
  for (int i = 0; i < view.nu; i += 7) {
    Eigen::Vector3d origin, direction;
    view.line(i, view.nv / 2, origin, direction);
    const Eigen::Vector3d foot = origin + view.depth_inside_m * direction;
    EXPECT_NEAR(std::hypot(foot.x(), foot.y()), 10e-3, 1e-12);
    EXPECT_NEAR(foot.z(), 20e-3 + (view.nv / 2 + 0.5) * view.spacing_m, 1e-12);  // the middle row's cell centre
    EXPECT_NEAR(direction.dot(Eigen::Vector3d(foot.x(), foot.y(), 0).normalized()), 1.0, 1e-12);
    EXPECT_NEAR(std::atan2(foot.y(), foot.x()), std::remainder(i * view.azimuth_step_rad, 2 * std::numbers::pi), 1e-9);
  }
}

// The design surface a mark lies on: a wall's or cylinder's view is its patch's; on the Z-map,
// of the patches whose ranges hold the point, the tightest tolerance (a patch without its own
// has the part's); a point on no patch: none.
TEST(SurfaceViews, AMarkLiesOnItsViewsPatchOrOnTheTightestPatchHoldingIt) {
  app::PartDescription part;
  app::DesignPatch floor, fillet, land;
  floor.type = "quadratic_height";
  floor.min_W_m.x() = -20e-3, floor.max_W_m.x() = 20e-3;
  fillet.type = "cylinder";
  fillet.min_W_m.x() = 20e-3, fillet.max_W_m.x() = 27e-3;
  fillet.tolerance_m = 5e-6;
  land.type = "plane";
  land.min_W_m.x() = 30e-3, land.max_W_m.x() = 40e-3;
  land.tolerance_m = 50e-6;
  part.design_patches = {floor, fillet, land};
  app::SurfaceView zmap;
  const double margin_m = 0.1e-3, part_tolerance_m = 10e-6;
  auto on = [&](const app::SurfaceView& view, double x_mm) {
    return app::design_patch_of_mark(part, view, Eigen::Vector3d(x_mm * 1e-3, 0, 0.01), margin_m, part_tolerance_m);
  };
  EXPECT_EQ(on(zmap, 0.0), std::optional<std::size_t>(0));
  EXPECT_EQ(on(zmap, 23.0), std::optional<std::size_t>(1));
  // At the border of the floor (the part's 10 um) and the fillet (5 um): the fillet's.
  EXPECT_EQ(on(zmap, 20.05), std::optional<std::size_t>(1));
  EXPECT_EQ(on(zmap, -20.05), std::optional<std::size_t>(0));
  EXPECT_EQ(on(zmap, -20.2), std::nullopt);  // beyond the margin
  EXPECT_EQ(on(zmap, 35.0), std::optional<std::size_t>(2));
  EXPECT_EQ(on(zmap, 28.0), std::nullopt);
  // Without the part's tolerance the floor has none: the land's 50 um is tighter there.
  part.design_patches[2].min_W_m.x() = -1e-3;
  EXPECT_EQ(app::design_patch_of_mark(part, zmap, Eigen::Vector3d(0, 0, 0.01), margin_m, 0.0),
            std::optional<std::size_t>(2));
  EXPECT_EQ(app::design_patch_of_mark(part, zmap, Eigen::Vector3d(0, 0, 0.01), margin_m, part_tolerance_m),
            std::optional<std::size_t>(0));
  // A cylinder view: its own patch, wherever the point.
  app::SurfaceView cylinder;
  cylinder.zmap = false;
  cylinder.design_patch = 1;
  EXPECT_EQ(on(cylinder, 0.0), std::optional<std::size_t>(1));
  // surface_views gives each view its patch: sample part 1's fillet is its third patch.
  const app::PartDescription part1 = app::load_part(std::string(VMSIM_SOURCE_DIR) + "/samples/parts/part1_tangency/part.yaml");
  ASSERT_EQ(part1.design_cylinders.size(), 1u);
  EXPECT_EQ(part1.design_patches.at(part1.design_cylinders[0].patch_index).type, "cylinder");
  const auto views = app::surface_views(fillet_part(), kStock, 0.2e-3, pass_tips(0.0), 10e-3);
  ASSERT_EQ(views.size(), 2u);
  EXPECT_EQ(views[0].design_patch, -1);
  EXPECT_EQ(views[1].design_patch, 0);
}

}  // namespace
}  // namespace vmsim

namespace vmsim {
namespace {

// The close-up of a mark (simulate_part's render_mark) against its bounding box, checked here by
// hand: a synthetic mark much wider than the margin (the mould's mark 1: a strip 30 mm long) is
// shown whole, with the margin round it where the grid has room, and clipped at the grid's edge.
TEST(MarkCloseUp, WindowHoldsTheMarksWholeBoundingBox) {
  const double spacing_m = 40e-6, margin_m = 2e-3;  // 50 lines of margin
  // A strip of 750 x 58 lines (30 mm x 2.3 mm) in the middle of a 2000 x 1000 grid.
  const app::LineWindow strip = app::mark_close_up_window(600, 1349, 400, 457, 2000, 1000, spacing_m, margin_m);
  EXPECT_EQ(strip.iu_first, 550);
  EXPECT_EQ(strip.iu_last, 1399);
  EXPECT_EQ(strip.iv_first, 350);
  EXPECT_EQ(strip.iv_last, 507);
  // Random boxes: the window always holds the box, stays in the grid, and is no wider than the
  // box plus two margins.
  for (int k = 0; k < 200; ++k) {
    const int nu = 100 + (k * 37) % 900, nv = 100 + (k * 53) % 700;
    const int iu_min = (k * 13) % nu, iv_min = (k * 7) % nv;
    const int iu_max = std::min(nu - 1, iu_min + (k * 29) % 400), iv_max = std::min(nv - 1, iv_min + (k * 17) % 300);
    const app::LineWindow window = app::mark_close_up_window(iu_min, iu_max, iv_min, iv_max, nu, nv, spacing_m, margin_m);
    EXPECT_LE(window.iu_first, iu_min);
    EXPECT_GE(window.iu_last, iu_max);
    EXPECT_LE(window.iv_first, iv_min);
    EXPECT_GE(window.iv_last, iv_max);
    EXPECT_GE(window.iu_first, 0);
    EXPECT_GE(window.iv_first, 0);
    EXPECT_LT(window.iu_last, nu);
    EXPECT_LT(window.iv_last, nv);
    EXPECT_EQ(window.iu_first, std::max(0, iu_min - 50));
    EXPECT_EQ(window.iv_last, std::min(nv - 1, iv_max + 50));
  }
}

TEST(MarkCloseUp, ABoxOutsideTheGridIsAnInputError) {
  EXPECT_THROW(app::mark_close_up_window(10, 120, 0, 5, 100, 100, 40e-6, 2e-3), InputError);
  EXPECT_THROW(app::mark_close_up_window(10, 5, 0, 5, 100, 100, 40e-6, 2e-3), InputError);
  EXPECT_THROW(app::mark_close_up_window(0, 5, 0, 5, 100, 100, 0.0, 2e-3), InputError);
}

}  // namespace
}  // namespace vmsim

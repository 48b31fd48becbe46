// Image tests: small fixed renders compared with the baselines in tests/viz/baselines/ through
// vtkImageDifference (compare_png_files). Run under xvfb-run (ctest does). To regenerate the
// baselines after an intended change of the look, run with VMSIM_UPDATE_BASELINES=1, look at
// the images, and commit them.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <numbers>
#include <string>

#include "vmsim/common/errors.hpp"
#include "vmsim/viz/image_compare.hpp"
#include "vmsim/viz/plot.hpp"
#include "vmsim/viz/surface.hpp"
#include "../temp_folder.hpp"

namespace vmsim::viz {
namespace {

const std::filesystem::path kBaselines = std::filesystem::path(VMSIM_SOURCE_DIR) / "tests/viz/baselines";

// vtkImageDifference's thresholded error allowed between a render and its baseline: VTK 9.1's
// own regression-test default. The same machine gives 0; the margin is for another Mesa or
// FreeType build rasterising a few edge pixels differently. The ...Differs... tests check that
// a real change is far above it (a sine shifted by 0.6 rad: about 1500; the surface's colours
// inverted: about 3100).
constexpr double kTolerance = 10.0;

std::filesystem::path output_folder() {
  static const auto folder = test::fresh_temp_folder("viz_images");
  return folder;
}

bool updating_baselines() {
  const char* value = std::getenv("VMSIM_UPDATE_BASELINES");
  return value != nullptr && std::string(value) == "1";
}

// Compares the render at `png` with the baseline `name`; in update mode copies it there first.
void expect_matches_baseline(const std::filesystem::path& png, const std::string& name) {
  const auto baseline = kBaselines / name;
  if (updating_baselines()) {
    std::filesystem::copy_file(png, baseline, std::filesystem::copy_options::overwrite_existing);
  }
  ASSERT_TRUE(std::filesystem::exists(baseline)) << baseline;
  const ImageDifference difference = compare_png_files(png.string(), baseline.string());
  ASSERT_TRUE(difference.same_size) << png << " is " << difference.width_px << "x"
                                    << difference.height_px << ", not the baseline's size";
  ::testing::Test::RecordProperty("thresholded_error", std::to_string(difference.thresholded_error));
  EXPECT_LE(difference.thresholded_error, kTolerance)
      << "render " << png << " differs from " << baseline << ": error " << difference.error;
}

LinePlot two_sines(double phase_rad) {
  LinePlot plot;
  plot.title = "Two sine series";
  plot.x_title = "angle [rad]";
  plot.y_title = "value [1]";
  Series sine{.name = "sin(x)"};
  Series cosine{.name = "0.5 cos(2x)", .style = LineStyle::dashed};
  for (int i = 0; i <= 200; ++i) {
    const double x = 2.0 * std::numbers::pi * i / 200.0;
    sine.x.push_back(x);
    sine.y.push_back(std::sin(x + phase_rad));
    cosine.x.push_back(x);
    cosine.y.push_back(0.5 * std::cos(2.0 * x));
  }
  plot.series = {sine, cosine};
  return plot;
}

// A flat 30 mm x 20 mm patch with a Gaussian dent of 20 um depth and 3 mm sigma at (12, 10) mm;
// the deviation is the dent itself.
HeightField gaussian_dent() {
  HeightField field;
  field.spacing_x_m = 0.5e-3;
  field.spacing_y_m = 0.5e-3;
  field.nx = 61;
  field.ny = 41;
  for (int j = 0; j < field.ny; ++j) {
    for (int i = 0; i < field.nx; ++i) {
      const double dx = i * field.spacing_x_m - 12e-3, dy = j * field.spacing_y_m - 10e-3;
      const double dent = -20e-6 * std::exp(-(dx * dx + dy * dy) / (2.0 * 3e-3 * 3e-3));
      field.height_m.push_back(dent);
      field.deviation_m.push_back(dent);
    }
  }
  return field;
}

// The nodes deeper than 5 um: the marked region.
std::vector<std::uint8_t> deep_nodes(const HeightField& field) {
  std::vector<std::uint8_t> mask;
  for (double d : field.deviation_m) mask.push_back(d < -5e-6 ? 1 : 0);
  return mask;
}

TEST(ImageCompare, ImageEqualsItselfAndSizesAreChecked) {
  const auto a = kBaselines / "plot_two_sines.png";
  const ImageDifference same = compare_png_files(a.string(), a.string());
  EXPECT_TRUE(same.same_size);
  EXPECT_EQ(same.width_px, 640);
  EXPECT_EQ(same.height_px, 400);
  EXPECT_EQ(same.thresholded_error, 0.0);
  const auto b = kBaselines / "surface_dent_overall.png";
  EXPECT_FALSE(compare_png_files(a.string(), b.string()).same_size);
  EXPECT_THROW(compare_png_files((kBaselines / "absent.png").string(), a.string()), InputError);
}

TEST(LinePlotImage, TwoSineSeriesMatchBaseline) {
  const auto png = output_folder() / "plot_two_sines.png";
  write_line_plot_png(png.string(), two_sines(0.0), {640, 400});
  expect_matches_baseline(png, "plot_two_sines.png");
}

TEST(LinePlotImage, ShiftedSeriesDiffersFromBaseline) {
  const auto png = output_folder() / "plot_two_sines_shifted.png";
  write_line_plot_png(png.string(), two_sines(0.6), {640, 400});
  const ImageDifference difference =
      compare_png_files(png.string(), (kBaselines / "plot_two_sines.png").string());
  ASSERT_TRUE(difference.same_size);
  RecordProperty("thresholded_error", std::to_string(difference.thresholded_error));
  EXPECT_GT(difference.thresholded_error, 10.0 * kTolerance);
}

TEST(LinePlotImage, ImageHasTheRequestedSize) {
  const auto png = output_folder() / "plot_size.png";
  write_line_plot_png(png.string(), two_sines(0.0), {321, 123});
  const ImageDifference self = compare_png_files(png.string(), png.string());
  EXPECT_EQ(self.width_px, 321);
  EXPECT_EQ(self.height_px, 123);
}

TEST(HistogramImage, DeviationHistogramMatchesBaseline) {
  // A fixed, symmetric set of deviations: a triangle-shaped distribution in [-10, 10] um.
  std::vector<double> deviation_m;
  for (int i = -10; i <= 10; ++i) {
    for (int k = 0; k < 11 - std::abs(i); ++k) deviation_m.push_back(i * 1e-6 + 0.25e-6);
  }
  const auto png = output_folder() / "histogram_deviation.png";
  plot_deviation_histogram(png.string(), deviation_m, 21, "Deviation histogram", {640, 400});
  expect_matches_baseline(png, "histogram_deviation.png");
}

TEST(SurfaceImage, GaussianDentWithMaskOutlineMatchesBaseline) {
  const HeightField field = gaussian_dent();
  SurfaceRenderOptions options;
  options.title = "Gaussian dent, 20 um deep";
  options.size = {800, 600};
  options.region_mask = deep_nodes(field);
  options.height_scale = 200.0;
  const auto png = output_folder() / "surface_dent_overall.png";
  render_surface_png(png.string(), field, options);
  expect_matches_baseline(png, "surface_dent_overall.png");
}

// Labels in a real render (no baseline: the layout is label_placement's, tested apart): twelve
// labels at one point all find room; a label whose point lies out of the image is left out and
// reported, not drawn at the border.
TEST(SurfaceImage, LabelsCrowdedAtOnePointAreAllPlacedAndOneOutOfViewIsLeftOut) {
  const HeightField field = gaussian_dent();
  SurfaceRenderOptions options;
  options.size = {800, 600};
  options.camera = CameraPreset::top;
  options.height_scale = 200.0;
  for (int n = 1; n <= 12; ++n) options.labels.push_back({12e-3, 10e-3, std::to_string(n)});
  options.labels.push_back({1.0, 1.0, "far"});  // 1 m away from a 24 mm surface
  const auto png = output_folder() / "surface_labels.png";
  const SurfaceRenderResult result = render_surface_png(png.string(), field, options);
  ASSERT_EQ(result.labels_left_out.size(), 1u);
  EXPECT_EQ(result.labels_left_out[0], 12u);
  EXPECT_TRUE(std::filesystem::exists(png));
}

TEST(SurfaceImage, CloseUpWithPolylineOutlineMatchesBaseline) {
  const HeightField field = gaussian_dent();
  SurfaceRenderOptions options;
  options.title = "Close-up";
  options.size = {600, 500};
  Outline circle;
  for (int k = 0; k < 48; ++k) {
    const double angle = 2.0 * std::numbers::pi * k / 48.0;
    circle.x_m.push_back(12e-3 + 4e-3 * std::cos(angle));
    circle.y_m.push_back(10e-3 + 4e-3 * std::sin(angle));
  }
  options.outlines = {circle};
  options.outline_colour = {0.0, 0.6, 0.0};
  options.camera = CameraPreset::close_up;
  options.close_up_box = BoxXY{6e-3, 18e-3, 4e-3, 16e-3};
  options.colour_range_m = Range{-20e-6, 20e-6};
  options.height_scale = 200.0;
  const auto png = output_folder() / "surface_dent_closeup.png";
  render_surface_png(png.string(), field, options);
  expect_matches_baseline(png, "surface_dent_closeup.png");
}

TEST(SurfaceImage, InvertedDeviationDiffersFromBaseline) {
  HeightField field = gaussian_dent();
  for (double& d : field.deviation_m) d *= -1.0;  // a bump in colour: red instead of blue
  SurfaceRenderOptions options;
  options.title = "Gaussian dent, 20 um deep";
  options.size = {800, 600};
  options.region_mask = deep_nodes(gaussian_dent());
  options.height_scale = 200.0;
  const auto png = output_folder() / "surface_dent_inverted_colour.png";
  render_surface_png(png.string(), field, options);
  const ImageDifference difference =
      compare_png_files(png.string(), (kBaselines / "surface_dent_overall.png").string());
  ASSERT_TRUE(difference.same_size);
  RecordProperty("thresholded_error", std::to_string(difference.thresholded_error));
  EXPECT_GT(difference.thresholded_error, 10.0 * kTolerance);
}

// A thumbnail as narrow as the marks' (480 px): the colour bar's title is wholly in the image
// (it was cut at the right edge: "deviation [um"). No dark pixel in the last columns, and the
// title is there, in the top right.
TEST(SurfaceImage, ColourBarTitleFitsANarrowImage) {
  SurfaceRenderOptions options;
  options.title = "Mark 1: 20 um";
  options.size = {480, 360};
  const auto png = output_folder() / "surface_narrow_bar_title.png";
  render_surface_png(png.string(), gaussian_dent(), options);
  const RgbImage image = read_png_rgb(png.string());
  ASSERT_EQ(image.width_px, 480);
  auto dark = [&](int x, int y) {
    const std::uint8_t* p = image.at(x, y);
    return p[0] < 110 && p[1] < 110 && p[2] < 110;
  };
  int dark_at_edge = 0, dark_title = 0;
  for (int y = 0; y < image.height_px; ++y) {
    for (int x = image.width_px - 3; x < image.width_px; ++x) dark_at_edge += dark(x, y) ? 1 : 0;
  }
  for (int y = 0; y < image.height_px / 5; ++y) {
    for (int x = image.width_px * 7 / 10; x < image.width_px; ++x) dark_title += dark(x, y) ? 1 : 0;
  }
  EXPECT_EQ(dark_at_edge, 0) << png;
  EXPECT_GT(dark_title, 100) << png << ": the colour bar's title is not in the top right";
}

// A view three times taller than wide seen from the top (a cylinder's unrolled view) lies wholly
// below the title and left of the colour bar, large, and a label at its far corner is placed
// (the view used to overflow under the title, its corner out of the picture).
TEST(SurfaceImage, TallTopViewFitsBelowTheTitleAndLeftOfTheBar) {
  HeightField field;
  field.spacing_x_m = field.spacing_y_m = 0.5e-3;
  field.nx = 41;   // 20 mm
  field.ny = 161;  // 80 mm
  field.height_m.assign(field.node_count(), 0.0);
  field.deviation_m.assign(field.node_count(), 10e-6);  // all red: at the top of the colour map
  SurfaceRenderOptions options;
  options.title = "A tall view";
  options.camera = CameraPreset::top;
  options.labels.push_back({20e-3, 80e-3, "1"});
  const auto png = output_folder() / "surface_tall_top.png";
  const SurfaceRenderResult result = render_surface_png(png.string(), field, options);
  EXPECT_TRUE(result.labels_left_out.empty()) << png;
  const RgbImage image = read_png_rgb(png.string());
  int top = image.height_px, bottom = -1, right = -1, red_under_title = 0;
  // Left of the colour bar (at 0.83 of the width at the most).
  for (int y = 0; y < image.height_px; ++y) {
    for (int x = 0; x < image.width_px * 8 / 10; ++x) {
      const std::uint8_t* p = image.at(x, y);
      if (!(p[0] > p[1] + 80 && p[0] > p[2] + 60)) continue;
      top = std::min(top, y), bottom = std::max(bottom, y), right = std::max(right, x);
      if (y < image.height_px * 12 / 100) ++red_under_title;
    }
  }
  EXPECT_EQ(red_under_title, 0) << png << ": the surface runs under the title (top at " << top << " px)";
  EXPECT_LT(bottom, image.height_px - 2) << png;
  EXPECT_LT(right, image.width_px * 8 / 10 - 2) << png;
  EXPECT_GT(bottom - top, image.height_px * 6 / 10) << png << ": the surface is drawn too small";
}

TEST(SurfaceImage, HeightColouredTopViewRendersAtTheRequestedSize) {
  HeightField field = gaussian_dent();
  field.deviation_m.clear();
  SurfaceRenderOptions options;
  options.camera = CameraPreset::top;
  options.size = {300, 200};
  const auto png = output_folder() / "surface_top_height.png";
  render_surface_png(png.string(), field, options);
  const ImageDifference self = compare_png_files(png.string(), png.string());
  EXPECT_EQ(self.width_px, 300);
  EXPECT_EQ(self.height_px, 200);
}

TEST(ChainPlots, FeedrateFollowingErrorAndResidualPlotsAreWritten) {
  const auto folder = output_folder();
  FeedratePlotInput feed;
  for (int i = 0; i <= 100; ++i) {
    const double s = 1e-3 * i;
    feed.programmed.x.push_back(s);
    feed.programmed.y.push_back(0.1);
    feed.limit.x.push_back(s);
    feed.limit.y.push_back(0.12 - 0.05 * std::exp(-std::pow((s - 0.05) / 0.01, 2)));
    feed.planned.x.push_back(s);
    feed.planned.y.push_back(std::min(0.1, feed.limit.y.back()));
  }
  feed.actual = feed.planned;
  const auto feed_png = folder / "chain_feedrate.png";
  plot_feedrate(feed_png.string(), feed);
  EXPECT_TRUE(std::filesystem::exists(feed_png));

  std::vector<AxisErrorSeries> axes(2);
  axes[0] = {"X", false, {}, {}};
  axes[1] = {"A", true, {}, {}};
  for (int i = 0; i <= 100; ++i) {
    for (auto& axis : axes) {
      axis.t_s.push_back(0.01 * i);
      axis.error.push_back((axis.rotary ? 1e-5 : 5e-6) * std::sin(0.3 * i));
    }
  }
  const auto error_png = folder / "chain_following_error.png";
  plot_following_error(error_png.string(), axes);
  EXPECT_TRUE(std::filesystem::exists(error_png));

  ResidualPlotInput residual{"Residual", "sample [1]", "torque [N m]", {}, {}, {}};
  for (int i = 0; i < 50; ++i) {
    residual.x.push_back(i);
    residual.before.push_back(std::sin(0.2 * i));
    residual.after.push_back(0.1 * std::sin(0.2 * i));
  }
  const auto residual_png = folder / "chain_residual.png";
  plot_residuals(residual_png.string(), residual);
  EXPECT_TRUE(std::filesystem::exists(residual_png));
}

}  // namespace
}  // namespace vmsim::viz

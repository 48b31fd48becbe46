// The display check: without an X display every render throws NoDisplayError (the process does
// not abort); with one (ctest runs this program under xvfb-run) the check passes.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>

#include "vmsim/common/errors.hpp"
#include "vmsim/viz/display.hpp"
#include "vmsim/viz/plot.hpp"
#include "vmsim/viz/surface.hpp"
#include "../temp_folder.hpp"

namespace vmsim::viz {
namespace {

// Sets (or unsets, with nullopt) DISPLAY for the scope, then restores it.
class ScopedDisplay {
 public:
  explicit ScopedDisplay(const std::optional<std::string>& value) {
    if (const char* old = std::getenv("DISPLAY")) saved_ = old;
    if (value) {
      setenv("DISPLAY", value->c_str(), 1);
    } else {
      unsetenv("DISPLAY");
    }
  }
  ~ScopedDisplay() {
    if (saved_) {
      setenv("DISPLAY", saved_->c_str(), 1);
    } else {
      unsetenv("DISPLAY");
    }
  }
  ScopedDisplay(const ScopedDisplay&) = delete;
  ScopedDisplay& operator=(const ScopedDisplay&) = delete;

 private:
  std::optional<std::string> saved_;
};

HeightField small_field() {
  HeightField field;
  field.nx = 3;
  field.ny = 2;
  field.height_m = {0, 1e-6, 0, 0, -1e-6, 0};
  field.deviation_m = {0, 1e-6, 0, 0, -1e-6, 0};
  return field;
}

LinePlot small_plot() {
  LinePlot plot;
  plot.series.push_back({.name = "a", .x = {0.0, 1.0}, .y = {0.0, 1.0}});
  return plot;
}

// Every render function, with valid data, writing into `folder`.
void expect_every_render_throws_no_display(const std::filesystem::path& folder) {
  const std::string png = (folder / "out.png").string();
  EXPECT_THROW(write_line_plot_png(png, small_plot()), NoDisplayError);
  HistogramPlot histogram;
  histogram.histogram = make_histogram({1.0, 2.0, 2.5}, 3);
  EXPECT_THROW(write_histogram_png(png, histogram), NoDisplayError);
  FeedratePlotInput feed;
  feed.planned = {{0.0, 0.01}, {0.1, 0.1}};
  EXPECT_THROW(plot_feedrate(png, feed), NoDisplayError);
  EXPECT_THROW(plot_following_error(png, {{"X", false, {0.0, 1.0}, {0.0, 1e-6}}}), NoDisplayError);
  ResidualPlotInput residual{"r", "x", "y", {0.0, 1.0}, {1.0, 2.0}, {0.1, 0.2}};
  EXPECT_THROW(plot_residuals(png, residual), NoDisplayError);
  EXPECT_THROW(plot_deviation_histogram(png, {1e-6, -2e-6, 0.0}), NoDisplayError);
  EXPECT_THROW(render_surface_png(png, small_field()), NoDisplayError);
  EXPECT_FALSE(std::filesystem::exists(png)) << "a failed render must leave no file";
}

TEST(NoDisplay, UnsetDisplayIsReportedWithTheRemedy) {
  ScopedDisplay no_display(std::nullopt);
  std::string why_not;
  EXPECT_FALSE(display_available(why_not));
  EXPECT_NE(why_not.find("DISPLAY is not set"), std::string::npos) << why_not;
  EXPECT_NE(why_not.find("xvfb-run -a"), std::string::npos) << why_not;
}

TEST(NoDisplay, EmptyDisplayIsReportedAsUnset) {
  ScopedDisplay empty_display(std::string{});
  std::string why_not;
  EXPECT_FALSE(display_available(why_not));
  EXPECT_NE(why_not.find("DISPLAY is not set"), std::string::npos) << why_not;
}

TEST(NoDisplay, DisplayThatCannotBeOpenedIsReportedByName) {
  // No X server listens on display 987 (Xvfb's -a starts at 99 and counts up).
  ScopedDisplay bad_display(std::string(":987"));
  std::string why_not;
  EXPECT_FALSE(display_available(why_not));
  EXPECT_NE(why_not.find("cannot open DISPLAY=:987"), std::string::npos) << why_not;
  EXPECT_NE(why_not.find("xvfb-run -a"), std::string::npos) << why_not;
}

TEST(NoDisplay, EveryRenderThrowsNoDisplayErrorInsteadOfAborting) {
  const auto folder = test::fresh_temp_folder("viz_no_display");
  {
    ScopedDisplay no_display(std::nullopt);
    expect_every_render_throws_no_display(folder);
    EXPECT_THROW(require_display(), NoDisplayError);
  }
  {
    ScopedDisplay bad_display(std::string(":987"));
    expect_every_render_throws_no_display(folder);
  }
}

TEST(NoDisplay, BadDataIsReportedBeforeTheDisplayIsLookedFor) {
  ScopedDisplay no_display(std::nullopt);
  LinePlot plot = small_plot();
  plot.series[0].y.pop_back();
  EXPECT_THROW(write_line_plot_png("unused.png", plot), InputError);
}

TEST(NoDisplay, SurfaceFilesNeedNoDisplay) {
  ScopedDisplay no_display(std::nullopt);
  const auto folder = test::fresh_temp_folder("viz_files_no_display");
  EXPECT_NO_THROW(write_surface_vtp((folder / "s.vtp").string(), small_field()));
  EXPECT_NO_THROW(write_surface_stl((folder / "s.stl").string(), small_field()));
  EXPECT_TRUE(std::filesystem::exists(folder / "s.vtp"));
  EXPECT_TRUE(std::filesystem::exists(folder / "s.stl"));
}

// Runs only in the ctest entry under xvfb-run: fails when the display check rejects Xvfb.
TEST(Display, XvfbDisplayIsAccepted) {
  std::string why_not = "not cleared";
  EXPECT_TRUE(display_available(why_not)) << why_not;
  EXPECT_TRUE(why_not.empty());
  EXPECT_NO_THROW(require_display());
}

}  // namespace
}  // namespace vmsim::viz

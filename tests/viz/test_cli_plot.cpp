// `vmsim plot` end to end: a PNG from CSV columns (under Xvfb), exit 5 and no file without a
// display, exit 3 naming the file and line for bad input.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "../app/cli_runner.hpp"
#include "vmsim/viz/image_compare.hpp"

namespace vmsim {
namespace {

const char* kCsv =
    "# a comment line before the header\n"
    "t_s, x_mm, y_mm\n"
    "0, 0, 1\n"
    "# a comment between rows\n"
    "0.5, 1, 0.5\n"
    "1.0, 4, 0.25\n"
    "\n"
    "1.5, 9, 0.125\n";

std::filesystem::path csv_in(const std::filesystem::path& folder, const std::string& text) {
  const auto path = folder / "data.csv";
  std::ofstream(path) << text;
  return path;
}

TEST(CliPlot, WritesAPngOfTheRequestedSize) {
  const auto folder = test::fresh_folder("viz_cli_plot");
  const auto csv = csv_in(folder, kCsv);
  const auto out = folder / "plot.png";
  const test::RunResult run =
      test::run_vmsim("plot --csv " + csv.string() + " --x t_s --y x_mm,y_mm --out " +
                      out.string() + " --title 'CSV columns' --width-px 500 --height-px 300");
  ASSERT_EQ(run.exit_code, 0) << run.output;
  EXPECT_NE(run.output.find("2 series, 4 points each"), std::string::npos) << run.output;
  const viz::ImageDifference self = viz::compare_png_files(out.string(), out.string());
  EXPECT_EQ(self.width_px, 500);
  EXPECT_EQ(self.height_px, 300);
}

TEST(CliPlotInput, NoDisplayExitsWith5WithTheRemedyAndWritesNothing) {
  const auto folder = test::fresh_folder("viz_cli_no_display");
  const auto csv = csv_in(folder, kCsv);
  const auto out = folder / "plot.png";
  const test::RunResult run = test::run_vmsim_with_env(
      "env -u DISPLAY", "plot --csv " + csv.string() + " --x t_s --y x_mm --out " + out.string());
  EXPECT_EQ(run.exit_code, 5) << run.output;
  EXPECT_NE(run.output.find("xvfb-run -a"), std::string::npos) << run.output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(CliPlotInput, UnknownColumnExitsWith3ListingTheColumns) {
  const auto folder = test::fresh_folder("viz_cli_bad_column");
  const auto csv = csv_in(folder, kCsv);
  const auto out = folder / "plot.png";
  const test::RunResult run =
      test::run_vmsim("plot --csv " + csv.string() + " --x t_s --y z_mm --out " + out.string());
  EXPECT_EQ(run.exit_code, 3) << run.output;
  EXPECT_NE(run.output.find("no column 'z_mm' (columns: t_s, x_mm, y_mm)"), std::string::npos)
      << run.output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(CliPlotInput, BadNumberExitsWith3NamingFileAndLine) {
  const auto folder = test::fresh_folder("viz_cli_bad_number");
  const auto csv = csv_in(folder, "t_s,x_mm\n0,1\n1,two\n");
  const auto out = folder / "plot.png";
  const test::RunResult run =
      test::run_vmsim("plot --csv " + csv.string() + " --x t_s --y x_mm --out " + out.string());
  EXPECT_EQ(run.exit_code, 3) << run.output;
  EXPECT_NE(run.output.find(csv.string() + ":3"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("'two' is not a number"), std::string::npos) << run.output;
  EXPECT_FALSE(std::filesystem::exists(out));
}

TEST(CliPlotInput, RowWithTooFewFieldsExitsWith3) {
  const auto folder = test::fresh_folder("viz_cli_short_row");
  const auto csv = csv_in(folder, "t_s,x_mm\n0,1\n1\n");
  const test::RunResult run = test::run_vmsim("plot --csv " + csv.string() +
                                              " --x t_s --y x_mm --out " +
                                              (folder / "plot.png").string());
  EXPECT_EQ(run.exit_code, 3) << run.output;
  EXPECT_NE(run.output.find("1 fields, the header has 2"), std::string::npos) << run.output;
}

TEST(CliPlotInput, MissingOptionIsAUsageError) {
  const test::RunResult run = test::run_vmsim("plot --x t_s --y x_mm --out p.png");
  EXPECT_EQ(run.exit_code, 2) << run.output;
}

}  // namespace
}  // namespace vmsim

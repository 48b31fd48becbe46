// The report's marks, verdict, CSV and page (app/report_marks.hpp, app/report_html.hpp), on
// marks written here by hand.
#include <gtest/gtest.h>

#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "report_html.hpp"
#include "report_marks.hpp"

namespace vmsim::app {
namespace {

using Json = nlohmann::json;

Json mark(double depth_um, double area_mm2, int line, const std::string& place = "corner",
          const std::string& axis = "X") {
  return {{"depth_um", depth_um},
          {"area_mm2", area_mm2},
          {"lines", static_cast<int>(area_mm2 / 0.0004)},
          {"kind", "gouge"},
          {"view", "zmap"},
          {"deepest_point_mm", {1.5, -2.25, 20.0}},
          {"s_mm", 12.5},
          {"line", line},
          {"block", "toolpath.nc:" + std::to_string(line)},
          {"block_text", "G1 X1.5 Y-2.25, F1000"},
          {"excerpt", {{{"line", line - 1}, {"text", "G1 X1"}}, {{"line", line}, {"text", "G1 X1.5 Y-2.25, F1000"}}}},
          {"place", {place}},
          {"responsible_axes", {axis}}};
}

TEST(ReportMarks, MinimumAreaFollowsTheToolAndTheGrid) {
  // (D / 20)^2 for a D10 tool: 0.25 mm^2; 5 x 5 lines at a coarse grid of 200 um: 1 mm^2.
  EXPECT_DOUBLE_EQ(min_mark_area_mm2(20.0, 10.0), 0.25);
  EXPECT_DOUBLE_EQ(min_mark_area_mm2(200.0, 10.0), 1.0);
  EXPECT_DOUBLE_EQ(min_mark_area_mm2(20.0, 2.0), 0.01);
}

TEST(ReportMarks, SpecksAreCountedApartAndMarksSortedDeepestFirst) {
  const Json raw = {mark(3.0, 2.0, 10), mark(50.0, 0.01, 11), mark(8.0, 0.5, 12), mark(4.0, 0.2, 13)};
  const Json curated = curate_marks(raw, 0.25);
  ASSERT_EQ(curated["marks"].size(), 2u);
  EXPECT_EQ(curated["marks"][0]["depth_um"], 8.0);
  EXPECT_EQ(curated["marks"][0]["rank"], 1);
  EXPECT_EQ(curated["marks"][1]["depth_um"], 3.0);
  EXPECT_EQ(curated["specks"]["count"], 2u);
  EXPECT_EQ(curated["specks"]["deepest_um"], 50.0);
  EXPECT_EQ(curated["specks"]["largest_area_mm2"], 0.2);
  EXPECT_EQ(curated["specks"]["list"].size(), 2u);
}

TEST(ReportMarks, VerdictAgainstTheTolerance) {
  const Json curated = curate_marks({mark(12.0, 1.0, 40, "corner", "X"), mark(6.0, 1.0, 41, "reversal_of_Y", "Y"),
                                     mark(30.0, 0.01, 42)},
                                    0.25);
  const Json checks = Json::array({{{"check", "set points on the programmed path"}, {"status", "ok"}}});

  const Json within = make_verdict(curated, checks, {20.0, "part file"});
  EXPECT_EQ(within["status"], "within");
  EXPECT_EQ(within["marks_beyond_tolerance"], 0u);
  EXPECT_EQ(within["specks_beyond_tolerance"], 1u);  // the 30 um speck: said, not hidden
  EXPECT_NE(within["summary"].get<std::string>().find("1 of them exceed the tolerance"), std::string::npos)
      << within["summary"];
  EXPECT_NE(within["headline"].get<std::string>().find("Within tolerance (20 um)"), std::string::npos);

  const Json beyond = make_verdict(curated, checks, {10.0, "--tolerance-um"});
  EXPECT_EQ(beyond["status"], "not_within");
  EXPECT_EQ(beyond["marks_beyond_tolerance"], 1u);
  EXPECT_EQ(beyond["worst_mark"]["line"], 40);
  const std::string summary = beyond["summary"].get<std::string>();
  EXPECT_NE(summary.find("program line 40"), std::string::npos) << summary;
  EXPECT_NE(summary.find("(1.500, -2.250, 20.000) mm"), std::string::npos) << summary;
  // The surface by its name where the mark has one, not the view's file id.
  EXPECT_NE(summary.find("on the zmap view"), std::string::npos) << summary;
  EXPECT_NE(summary.find("reversal of Y (1)"), std::string::npos) << summary;
  EXPECT_EQ(summary.find("reversal_of_Y"), std::string::npos) << summary;

  const Json none = make_verdict(curated, checks, {});
  EXPECT_EQ(none["status"], "no_tolerance");
  EXPECT_TRUE(none["tolerance_um"].is_null());
  EXPECT_NE(none["headline"].get<std::string>().find("12 um"), std::string::npos);
}

TEST(ReportMarks, TheSummaryNamesTheMarksSurfaceInWords) {
  Json named = mark(12.0, 1.0, 40, "corner", "X");
  named["view"] = "cylinder1";
  named["surface"] = "cylinder 1";
  const Json verdict = make_verdict(curate_marks(Json::array({named}), 0.25), Json::array(), {10.0, "part file"});
  const std::string summary = verdict["summary"].get<std::string>();
  EXPECT_NE(summary.find("(1.500, -2.250, 20.000) mm on the cylinder 1,"), std::string::npos) << summary;
  EXPECT_EQ(summary.find("cylinder1"), std::string::npos) << summary;
}

TEST(ReportMarks, AFailedOrWarningCheckIsInTheSummary) {
  const Json curated = curate_marks(Json::array(), 0.25);
  const Json checks = Json::array({{{"check", "actual axis positions within the travel"},
                                    {"status", "WARNING"},
                                    {"detail", "Z by 0.2 mm"}}});
  const Json verdict = make_verdict(curated, checks, {5.0, "part file"});
  EXPECT_EQ(verdict["status"], "within");
  // In words, the label not run into the text: "Warning, validity check: <what> (<detail>)."
  EXPECT_NE(verdict["summary"].get<std::string>().find(
                "Warning, validity check: actual axis positions within the travel (Z by 0.2 mm)."),
            std::string::npos)
      << verdict["summary"];
  EXPECT_EQ(verdict["summary"].get<std::string>().find(": WARNING"), std::string::npos) << verdict["summary"];
}


// Each mark against its design surface's own tolerance where it has one, the part's elsewhere;
// the headline and report.json's "surfaces" name the surface.
TEST(ReportMarks, EachMarkIsJudgedByItsSurfacesTolerance) {
  Json on_seal = mark(8.0, 1.0, 40, "corner", "X");
  on_seal["design_surface"] = "sealing face";
  on_seal["tolerance_um"] = 5.0;
  Json on_floor = mark(9.0, 1.0, 41, "corner", "Y");
  on_floor["design_surface"] = "floor";
  const Json curated = curate_marks({on_seal, on_floor}, 0.25);
  // The part's 10 um holds the floor's 9 um mark; the sealing face's 5 um does not hold its 8 um.
  const Json beyond = make_verdict(curated, Json::array(), {10.0, "part file"});
  EXPECT_EQ(beyond["status"], "not_within") << beyond.dump(2);
  EXPECT_EQ(beyond["marks_beyond_tolerance"], 1u);
  const std::string headline = beyond["headline"].get<std::string>();
  EXPECT_NE(headline.find("10 um; 5 um on sealing face"), std::string::npos) << headline;
  EXPECT_NE(headline.find("the deepest 8 um on sealing face (tolerance 5 um)"), std::string::npos) << headline;
  ASSERT_EQ(beyond["surfaces"].size(), 2u);
  EXPECT_EQ(beyond["surfaces"][0]["surface"], "floor");  // the deepest mark's surface first
  EXPECT_EQ(beyond["surfaces"][0]["tolerance_um"], 10.0);
  EXPECT_EQ(beyond["surfaces"][0]["marks_beyond_tolerance"], 0);
  EXPECT_EQ(beyond["surfaces"][1]["tolerance_source"], "design surface");
  EXPECT_EQ(beyond["surfaces"][1]["marks_beyond_tolerance"], 1);
  // A looser surface tolerance holds where the part's would not.
  on_seal["tolerance_um"] = 8.5;
  const Json within = make_verdict(curate_marks({on_seal, on_floor}, 0.25), Json::array(), {7.0, "--tolerance-um"});
  EXPECT_EQ(within["status"], "not_within");  // the floor's 9 um against 7 um
  on_floor["tolerance_um"] = 9.5;
  const Json all_own = make_verdict(curate_marks({on_seal, on_floor}, 0.25), Json::array(), {7.0, "--tolerance-um"});
  EXPECT_EQ(all_own["status"], "within") << all_own.dump(2);
  // No part tolerance: a mark on a surface without one is not judged, so no "within".
  on_floor.erase("tolerance_um");
  const Json partial = make_verdict(curate_marks({on_seal, on_floor}, 0.25), Json::array(), {});
  EXPECT_EQ(partial["status"], "no_tolerance");
  EXPECT_EQ(partial["marks_without_tolerance"], 1u);
  on_seal["tolerance_um"] = 5.0;
  const Json partial_beyond = make_verdict(curate_marks({on_seal, on_floor}, 0.25), Json::array(), {});
  EXPECT_EQ(partial_beyond["status"], "not_within");
  // The page lists the surfaces, each with its tolerance, and marks the row beyond its own.
  Json report;
  report["part"] = {{"name", "plate"}, {"description", "a plate"}};
  report["surface"] = {{"mark_threshold_um", 1.0}, {"views", Json::array()}};
  const Json both = curate_marks({on_seal, on_floor}, 0.25);
  report["marks"] = both["marks"];
  report["specks"] = both["specks"];
  report["verdict"] = make_verdict(both, Json::array(), {10.0, "part file"});
  report["runs"] = Json::object();
  const std::string html = html_report(report, {});
  // The sealing face's row (rank 2, 8 um) is beyond its 5 um; the floor's (rank 1, 9 um) is not.
  EXPECT_NE(html.find("<tr class=\"beyond\"><td>2"), std::string::npos);
  EXPECT_EQ(html.find("<tr class=\"beyond\"><td>1"), std::string::npos);
  EXPECT_NE(html.find("<li><b>sealing face</b>: tolerance 5 um (its own, part file), 1 mark, the deepest 8 um: 1 beyond it</li>"),
            std::string::npos)
      << html.substr(0, 3000);
  EXPECT_NE(html.find("<li><b>floor</b>: tolerance 10 um (part file), 1 mark, the deepest 9 um: within it</li>"),
            std::string::npos);
}

TEST(ReportMarks, CsvQuotesFieldsAndListsSpecksLast) {
  const Json curated = curate_marks({mark(12.0, 1.0, 40), mark(30.0, 0.01, 42)}, 0.25);
  const std::string csv = marks_csv(curated);
  std::istringstream lines(csv);
  std::string header, first, second, extra;
  std::getline(lines, header);
  std::getline(lines, first);
  std::getline(lines, second);
  EXPECT_FALSE(std::getline(lines, extra));
  EXPECT_EQ(header.substr(0, 25), "rank,speck,kind,depth_um,");
  EXPECT_EQ(first.substr(0, 19), "1,no,gouge,12.0000,");
  EXPECT_EQ(second.substr(0, 20), "1,yes,gouge,30.0000,");
  // The block text holds a comma: quoted as RFC 4180 says.
  EXPECT_NE(first.find("\"G1 X1.5 Y-2.25, F1000\""), std::string::npos) << first;
}

TEST(ReportHtml, VerdictFirstMarksLinkedToTheProgramNoIdentifiers) {
  Json report;
  report["part"] = {{"name", "plate <1>"}, {"description", "a plate"}};
  report["surface"] = {{"mark_threshold_um", 2.0}, {"views", Json::array()}};
  const Json curated = curate_marks(Json::array({mark(12.0, 1.0, 40, "tangency_or_curvature_change")}), 0.25);
  report["marks"] = curated["marks"];
  report["specks"] = curated["specks"];
  report["verdict"] = make_verdict(curated, Json::array(), {10.0, "part file"});
  report["runs"] = Json::object();
  const std::string html = html_report(report, {"surface_deviation.png"});
  EXPECT_LT(html.find("Not within tolerance"), html.find("<h2>Marks</h2>"));
  EXPECT_NE(html.find("plate &lt;1&gt;"), std::string::npos);
  EXPECT_NE(html.find("href=\"#line-40\""), std::string::npos);
  EXPECT_NE(html.find("id=\"line-40\""), std::string::npos);
  EXPECT_NE(html.find("id=\"line-39\""), std::string::npos);
  EXPECT_NE(html.find("(1.5, -2.25, 20)"), std::string::npos);
  EXPECT_NE(html.find("tangency or change of curvature"), std::string::npos);
  EXPECT_EQ(html.find("tangency_or_curvature_change"), std::string::npos);
  EXPECT_NE(html.find("<figcaption>Production surface"), std::string::npos);
}

TEST(ReportHtml, OnlyTheFirstMarksAreListed) {
  Json raw = Json::array();
  for (int i = 0; i < 40; ++i) raw.push_back(mark(100.0 - i, 1.0, 100 + i));
  const Json curated = curate_marks(raw, 0.25);
  Json report;
  report["part"] = {{"name", "p"}, {"description", ""}};
  report["surface"] = {{"mark_threshold_um", 2.0}, {"views", Json::array()}};
  report["marks"] = curated["marks"];
  report["runs"] = Json::object();
  const std::string html = html_report(report, {});
  std::size_t rows = 0;
  for (std::size_t at = html.find("href=\"#line-"); at != std::string::npos; at = html.find("href=\"#line-", at + 1)) {
    ++rows;
  }
  EXPECT_EQ(rows, kHtmlMarkRows);
  EXPECT_NE(html.find("15 shallower marks are not listed here"), std::string::npos);
}

}  // namespace
}  // namespace vmsim::app

#pragma once
// What simulate-part's report says about the marks (issue: "a report an engineer can forward"):
// which of the raw marks a machinist would act on, the verdict against a tolerance and the
// one-paragraph summary of its cause, and the marks as CSV.
//
// The raw marks are report.json's mark entries (simulate_part.cpp, relate_mark): depth_um,
// area_mm2, lines, kind (gouge | excess), view, deepest_point_mm, s_mm, block, line, block_text,
// place (list of place kinds), responsible_axes.
#include <cstddef>
#include <optional>
#include <string>

#include <nlohmann/json.hpp>

namespace vmsim::app {

/// The smallest mark a machinist would see as one, in mm^2 of surface: a patch of at least
/// 5 x 5 grid lines and at least (tool diameter / 20)^2 (0.25 mm^2 for a D10 tool), since a
/// cutter cannot leave a real mark much narrower than a small fraction of itself; smaller
/// regions (specks of a few lines on steep walls, the ends of lines grazed by the tool) are
/// counted apart.
double min_mark_area_mm2(double grid_um, double tool_diameter_mm);

/// The raw marks split into marks (area >= min_area_mm2, deepest first) and specks: returns
/// {"marks": [...], "specks": {"count", "deepest_um", "largest_area_mm2", "min_area_mm2"}}.
/// Every entry keeps its fields; marks and specks each get "rank" (1 = deepest).
nlohmann::json curate_marks(const nlohmann::json& raw_marks, double min_area_mm2);

/// Where the tolerance came from.
struct Tolerance {
  std::optional<double> um;  ///< nullopt: none given
  std::string source;        ///< "--tolerance-um", "part file", or "" when none
};

/// A mark's tolerance [um]: its own "tolerance_um" (that of the design surface it lies on, where
/// the part file gives that surface one), else `tolerance` (the part's or --tolerance-um).
std::optional<double> mark_tolerance_um(const nlohmann::json& mark, const Tolerance& tolerance);

/// The verdict at the top of the report: {"tolerance_um" (or null), "tolerance_source",
/// "status": "within" | "not_within" | "no_tolerance", "headline", "summary",
/// "worst_mark" (or null), "marks_beyond_tolerance", "specks_beyond_tolerance",
/// "marks_without_tolerance", "surfaces"}. Each mark is judged against mark_tolerance_um; a
/// mark's surface is its "design_surface" (or "surface", or "view"). "surfaces": per surface,
/// in the order of its deepest mark, {"surface", "tolerance_um" (or null), "tolerance_source"
/// ("design surface" where its own), "marks", "marks_beyond_tolerance", "deepest_um"}.
/// "within" needs every mark judged: marks with no tolerance at all give "no_tolerance" unless
/// another mark exceeds its own ("not_within").
/// `checks` is report.json's validity_checks: a check that warned is named in the summary.
nlohmann::json make_verdict(const nlohmann::json& curated, const nlohmann::json& checks,
                            const Tolerance& tolerance);

/// Every mark (specks after the marks, flagged in the column "speck") as CSV, one row per
/// mark, RFC 4180 quoting, lengths in um / mm / mm^2 as the header says.
std::string marks_csv(const nlohmann::json& curated);

/// A place kind from relate_mark in words ("tangency_or_curvature_change" -> "tangency or change
/// of curvature").
std::string place_in_words(const std::string& place);

/// A list of texts (a mark's "place" or "responsible_axes") joined by `separator`, each place
/// kind in words when `in_words`.
std::string joined(const nlohmann::json& list, const char* separator, bool in_words);

}  // namespace vmsim::app

#include "report_html.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <set>
#include <sstream>

#include "report_marks.hpp"

namespace vmsim::app {
namespace {

using Json = nlohmann::json;

/// A number with at most `decimals` decimals, no trailing zeros.
std::string fixed(double value, int decimals) {
  char text[64];
  std::snprintf(text, sizeof text, "%.*f", decimals, value);
  std::string s = text;
  if (s.find('.') != std::string::npos) {
    while (!s.empty() && s.back() == '0') s.pop_back();
    if (!s.empty() && s.back() == '.') s.pop_back();
  }
  return s == "-0" ? "0" : s;
}

std::string text_of(const Json& object, const char* key) {
  if (!object.is_object() || !object.contains(key)) return "";
  const Json& value = object[key];
  if (value.is_string()) return value.get<std::string>();
  if (value.is_number()) return fixed(value.get<double>(), 4);
  return "";
}

std::string point_text(const Json& point_mm) {
  if (!point_mm.is_array() || point_mm.size() != 3) return "";
  return "(" + fixed(point_mm[0].get<double>(), 3) + ", " + fixed(point_mm[1].get<double>(), 3) + ", " +
         fixed(point_mm[2].get<double>(), 3) + ")";
}

/// What each image shows (images are written by simulate_part.cpp's write_renders).
std::string caption_of(const std::string& image) {
  if (image == "surface_deviation.png") {
    return "Production surface seen from above (the Z-map), coloured by its deviation from the reference "
           "surface (production minus reference: negative = gouge, material removed that the reference "
           "keeps; positive = excess material); marks outlined.";
  }
  if (image.rfind("surface_deviation_", 0) == 0) {
    return "The same deviation on the surface view '" + image.substr(18, image.size() - 22) +
           "' (lines along the surface's normals), marks outlined.";
  }
  if (image == "worst_mark.png") return "Close-up of the deepest mark (same colours).";
  if (image == "feedrate.png") {
    return "Tool-tip feed along the whole path (production run): programmed, the limit the drives allow, "
           "planned, and actual (from the simulated axes).";
  }
  if (image.rfind("feedrate_mark_", 0) == 0) {
    return "The same feeds within 30 mm of path around mark " + image.substr(14, image.size() - 18) + ".";
  }
  if (image == "following_error.png") {
    return "Each axis's following error (commanded minus actual) along the path, cutting moves only; dotted "
           "lines: where the marks were made.";
  }
  if (image == "deviation_along_path.png") {
    return "Production minus reference surface under the tool tip (Z-map) along the path; dotted lines: marks.";
  }
  if (image == "deviation_histogram.png") {
    return "How the machined lines' deviations are distributed (logarithmic counts: the few lines of the marks "
           "stay visible).";
  }
  return image;
}

void verdict_section(std::ostringstream& html, const Json& report) {
  if (!report.contains("verdict")) return;
  const Json& verdict = report["verdict"];
  const std::string status = verdict.value("status", "");
  const char* colour = status == "within" ? "#e6f4e6" : status == "not_within" ? "#fbe3e3" : "#eeeeee";
  const char* border = status == "within" ? "#060" : status == "not_within" ? "#b00" : "#666";
  html << "<div class=\"verdict\" style=\"background:" << colour << ";border-color:" << border << "\"><h2>"
       << html_escape(verdict.value("headline", "")) << "</h2>";
  // One line a surface where the tolerance differs between them (a design surface's own).
  bool own = false;
  for (const auto& surface : verdict.value("surfaces", Json::array())) {
    own = own || surface.value("tolerance_source", "") == "design surface";
  }
  if (own) {
    html << "<ul class=\"verdict-surfaces\">";
    for (const auto& surface : verdict["surfaces"]) {
      const int count = surface.value("marks", 0), beyond = surface.value("marks_beyond_tolerance", 0);
      const std::string source = surface.value("tolerance_source", "");
      html << "<li><b>" << html_escape(surface.value("surface", "")) << "</b>: ";
      if (surface["tolerance_um"].is_number()) {
        html << "tolerance " << fixed(surface["tolerance_um"].get<double>(), 1) << " um ("
             << (source == "design surface" ? "its own, part file" : html_escape(source)) << "), ";
      } else {
        html << "no tolerance, ";
      }
      html << count << (count == 1 ? " mark" : " marks") << ", the deepest " << fixed(surface.value("deepest_um", 0.0), 2)
           << " um: "
           << (surface["tolerance_um"].is_number()
                   ? (beyond == 0 ? std::string("within it") : std::to_string(beyond) + " beyond it")
                   : std::string("not judged"))
           << "</li>";
    }
    html << "</ul>";
  }
  html << "<p>" << html_escape(verdict.value("summary", "")) << "</p></div>\n";
}

void context_section(std::ostringstream& html, const Json& report) {
  if (!report.contains("context")) return;
  const Json& context = report["context"];
  html << "<h2>Context</h2><table class=\"context\">\n";
  const auto row = [&html](const std::string& name, const std::string& value) {
    if (!value.empty()) html << "<tr><th>" << html_escape(name) << "</th><td>" << html_escape(value) << "</td></tr>\n";
  };
  row("Part file", text_of(context, "part_file"));
  row("Machine", text_of(context, "machine"));
  row("Tool path", text_of(context, "toolpath"));
  row("Tool", text_of(context, "tool"));
  row("Stock", text_of(context, "stock"));
  row("Production feed", text_of(context, "production_feed"));
  row("Reference feed", text_of(context, "reference_feed"));
  row("Feedrate planning", text_of(context, "planning"));
  row("Corners", text_of(context, "corners"));
  row("Tool roll", report.contains("tool_roll") ? report["tool_roll"].get<std::string>() : "");
  if (context.contains("nc_modes")) {
    // What the program asks, what the run applied, and what the command line overrode.
    std::string modes;
    for (const auto& line : context["nc_modes"]) modes += (modes.empty() ? "" : "\n") + line.get<std::string>();
    html << "<tr><th>NC modes</th><td style=\"white-space:pre-line\">" << html_escape(modes) << "</td></tr>\n";
  }
  row("Surface grid", text_of(context, "grid"));
  row("Date", text_of(context, "date_utc"));
  row("vmsim", text_of(context, "vmsim_version"));
  row("Command line", text_of(context, "command_line"));
  html << "</table>\n";
}

void checks_section(std::ostringstream& html, const Json& report) {
  if (!report.contains("validity_checks")) return;
  // Whether the figures below can be trusted.
  html << "<h2>Validity checks</h2><table><tr><th>check</th><th>found</th><th>limit</th><th>result</th>"
          "<th>where</th></tr>\n";
  for (const auto& check : report["validity_checks"]) {
    const std::string status = check.value("status", "");
    const char* colour = status == "ok" ? "#060" : status == "not done" ? "#666" : "#b00";
    html << "<tr><td>" << html_escape(check.value("check", "")) << "</td><td>";
    if (check.contains("value")) {
      html << (check["value"].is_number() ? fixed(check["value"].get<double>(), 3)
                                          : html_escape(check["value"].get<std::string>()))
           << " " << html_escape(check.value("unit", "")) << "</td><td>" << fixed(check.value("limit", 0.0), 3);
    } else {
      html << "-</td><td>-";
    }
    html << "</td><td style=\"color:" << colour << ";font-weight:bold\">" << html_escape(status) << "</td><td>"
         << html_escape(check.value("detail", "")) << "</td></tr>\n";
  }
  html << "</table>\n";
  if (report.contains("reference")) {
    // Which surface the marks are measured against, and how far it may be from the other.
    const Json& reference = report["reference"];
    const bool commanded = reference.value("used", "") == "commanded";
    html << "<p><b>Reference surface:</b> "
         << (commanded ? "the planned tool path's own surface (the reference run's servo simulated to bound "
                         "it, its surface not cut)"
                       : "the reference run's simulated surface")
         << " (" << html_escape(reference.value("why", "")) << "). The reference run's tool stays within "
         << fixed(reference.value("path_deviation_um", 0.0), 3)
         << " um of the planned tool path, so the two surfaces' line heights differ by at most "
         << fixed(reference.value("surface_bound_um", 0.0), 3) << " um (x "
         << fixed(reference.value("steep_factor", 0.0), 3) << ", on lines that are not steep).</p>\n";
  }
}

std::string anchor_of(int line) { return "line-" + std::to_string(line); }

bool has_view_3d(const Json& report) {
  return report.contains("view_3d") && report["view_3d"].value("available", false);
}

void marks_section(std::ostringstream& html, const Json& report) {
  const bool with_3d = has_view_3d(report);
  html << "<h2>Marks</h2>\n";
  const Json& marks = report["marks"];
  const double tolerance = report.contains("verdict") && report["verdict"]["tolerance_um"].is_number()
                               ? report["verdict"]["tolerance_um"].get<double>()
                               : -1.0;
  html << "<p>A mark is a connected region of the surface where the production run leaves the surface of the "
          "reference run (the same program at a low feed) by more than "
       << fixed(report["surface"].value("mark_threshold_um", 0.0), 3)
       << " um. Depth is measured along the view's lines; gouge = production cut deeper than the reference, "
          "excess = it left material.</p>\n";
  if (marks.empty()) {
    html << "<p>No mark.</p>\n";
  } else {
    html << "<table class=\"marks\"><tr><th>#</th><th>depth [um]</th><th>kind</th><th>area [mm2]</th>"
            "<th>deepest point (x, y, z) [mm]</th><th>program line</th><th>place</th><th>axes</th>"
            "<th>close-up</th></tr>\n";
    std::size_t shown = 0;
    for (const auto& mark : marks) {
      if (shown++ == kHtmlMarkRows) break;
      const double depth = mark.value("depth_um", 0.0);
      // Against the tolerance of the mark's design surface where it has its own.
      const double limit = mark.contains("tolerance_um") && mark["tolerance_um"].is_number()
                               ? mark["tolerance_um"].get<double>()
                               : tolerance;
      const bool beyond = limit >= 0 && depth > limit;
      html << "<tr" << (beyond ? " class=\"beyond\"" : "") << "><td>" << mark.value("rank", 0);
      if (with_3d) {
        html << " <a class=\"show-in-3d\" href=\"#view-3d\" data-rank=\"" << mark.value("rank", 0)
             << "\" title=\"show this mark in the 3-D view\">3-D</a>";
      }
      html << "</td><td>"
           << fixed(depth, 2) << "</td><td>" << html_escape(mark.value("kind", "")) << "</td><td>"
           << fixed(mark.value("area_mm2", 0.0), 3) << "</td><td>"
           << point_text(mark.value("deepest_point_mm", Json())) << " (" << html_escape(mark.value("view", ""))
           << " view)</td><td>";
      const int line = mark.value("line", 0);
      if (line > 0) {
        html << "<a href=\"#" << anchor_of(line) << "\">" << line << "</a> <code>"
             << html_escape(mark.value("block_text", "")) << "</code>";
      }
      html << "</td><td>";
      html << html_escape(joined(mark.value("place", Json::array()), ", ", true)) << "</td><td>"
           << html_escape(joined(mark.value("responsible_axes", Json::array()), ", ", false)) << "</td><td>";
      if (mark.contains("thumbnail")) {
        const std::string image = html_escape(mark["thumbnail"].get<std::string>());
        html << "<a href=\"" << image << "\"><img class=\"thumbnail\" src=\"" << image << "\" alt=\"close-up of mark "
             << mark.value("rank", 0) << "\"></a>";
      }
      html << "</td></tr>\n";
    }
    html << "</table>\n";
    if (marks.size() > kHtmlMarkRows) {
      html << "<p>" << marks.size() - kHtmlMarkRows
           << " shallower marks are not listed here: report.json and <a href=\"marks.csv\">marks.csv</a> have "
              "all of them.</p>\n";
    }
  }
  if (report.contains("specks") && report["specks"].value("count", 0) > 0) {
    const Json& specks = report["specks"];
    html << "<p>" << specks.value("count", 0) << " smaller deviations (each under "
         << fixed(specks.value("min_area_mm2", 0.0), 3) << " mm2, the deepest "
         << fixed(specks.value("deepest_um", 0.0), 2)
         << " um) are too small for a mark a cutter leaves (specks on steep walls, lines grazed at their "
            "ends); <a href=\"marks.csv\">marks.csv</a> lists them.</p>\n";
  }
}

/// The interactive view (app/report_3d.hpp): vtk.js and the data in the folder's 3d/, loaded
/// by relative paths (no network); without them, what to do to get it.
void view_3d_section(std::ostringstream& html, const Json& report) {
  if (!report.contains("view_3d")) return;
  const Json& view = report["view_3d"];
  html << "<h2 id=\"view-3d\">3-D view</h2>\n";
  if (!view.value("available", false)) {
    html << "<p class=\"view3d-missing\"><b>No 3-D view in this report:</b> " << html_escape(view.value("reason", ""))
         << ".</p>\n";
    return;
  }
  std::size_t lines = 0;
  int cell_lines = 1;
  for (const auto& entry : view.value("views", Json::array())) {
    lines += entry.value("lines", std::size_t{0});
    cell_lines = std::max(cell_lines, entry.value("cell_lines", 1));
  }
  html << "<p>The production surface, coloured by its deviation from the reference surface (production minus "
          "reference, in um: <span style=\"color:#3b4cc0\"><b>blue, negative: gouge</b></span>, the production run "
          "cut deeper; <span style=\"color:#b40426\"><b>red, positive: excess material</b></span>; grey: none). "
          "Drag to rotate, scroll to zoom, shift + drag to pan; click a point to read its deviation, position and "
          "program line (of its mark, and of the nearest programmed path). The 3-D links in the marks table "
          "centre the view on a mark. Coordinates in mm, in the workpiece frame.</p>\n"
          "<p class=\"view3d-size\">Decimated for size: "
       << view.value("vertices", std::size_t{0}) << " points of " << lines
       << " surface lines (cells of up to " << cell_lines << " x " << cell_lines
       << " lines, each keeping its line of largest deviation, so no mark is lost); data "
       << fixed(view.value("data_bytes", 0.0) / 1e6, 2) << " MB, viewer library (vtk.js) "
       << fixed(view.value("library_bytes", 0.0) / 1e6, 2) << " MB, all in the folder 3d/: it works offline.</p>\n";
  html << "<div class=\"view3d-controls\"><label>Surface view <select id=\"view3d-view\"></select></label> "
          "<button type=\"button\" id=\"view3d-reset\">Whole surface</button></div>\n"
          "<div id=\"view3d\"></div>\n<div id=\"view3d-pick\">Click the surface to read a point.</div>\n"
          "<noscript><p>The 3-D view needs JavaScript.</p></noscript>\n";
  const Json& files = view["files"];
  for (const char* key : {"library", "data", "viewer"}) {
    html << "<script src=\"" << html_escape(files.value(key, "")) << "\"></script>\n";
  }
}

void following_error_section(std::ostringstream& html, const Json& report) {
  html << "<h2>Runs and following errors</h2>\n<p>Following error = commanded minus actual axis position. "
          "Peaks and RMS while cutting (rapids excluded: they run at the axes' own limits, alike in both "
          "runs); the peak over all moves, rapids included, in the last column.</p>\n";
  html << "<table><tr><th>run</th><th>feed [mm/min]</th><th>duration [s]</th><th>axis</th>"
          "<th>peak while cutting</th><th>RMS while cutting</th><th>at path length [mm]</th>"
          "<th>peak, all moves</th></tr>\n";
  for (const char* name : {"production", "reference"}) {
    if (!report["runs"].contains(name)) continue;
    const Json& run = report["runs"][name];
    const Json& cutting = run.value("axes_while_cutting", Json::array());
    const Json& all = run.value("axes", Json::array());
    for (std::size_t j = 0; j < cutting.size(); ++j) {
      const Json& axis = cutting[j];
      html << "<tr>";
      if (j == 0) {
        html << "<td rowspan=\"" << cutting.size() << "\">" << name << "</td><td rowspan=\"" << cutting.size()
             << "\">" << fixed(run.value("feed_mm_per_min", 0.0), 1) << "</td><td rowspan=\"" << cutting.size()
             << "\">" << fixed(run.value("duration_s", 0.0), 3) << "</td>";
      }
      html << "<td>" << html_escape(axis.value("axis", "")) << "</td>";
      if (axis.contains("following_error_peak_um")) {
        html << "<td>" << fixed(axis["following_error_peak_um"].get<double>(), 2) << " um</td><td>"
             << fixed(axis.value("following_error_rms_um", 0.0), 2) << " um</td>";
      } else {
        html << "<td>" << fixed(axis.value("following_error_peak_deg", 0.0) * 1e3, 3) << " mdeg</td><td>"
             << fixed(axis.value("following_error_rms_deg", 0.0) * 1e3, 3) << " mdeg</td>";
      }
      html << "<td>" << fixed(axis.value("at_s_mm", 0.0), 2) << "</td><td>";
      if (j < all.size()) {
        if (all[j].contains("following_error_peak_um")) {
          html << fixed(all[j]["following_error_peak_um"].get<double>(), 2) << " um";
        } else {
          html << fixed(all[j].value("following_error_peak_mdeg", 0.0), 3) << " mdeg";
        }
      }
      html << "</td></tr>\n";
    }
  }
  html << "</table>\n";
  // The tool tip in Cartesian terms (robots: what the joints' errors and elastic deflection do).
  for (const char* name : {"production", "reference"}) {
    if (!report["runs"].contains(name) || !report["runs"][name].contains("tool_tip_while_cutting")) continue;
    const Json& tip = report["runs"][name]["tool_tip_while_cutting"];
    html << "<p>" << name << ": the tool tip lies off the commanded path by up to "
         << fixed(tip.value("contour_error_peak_um", 0.0), 1) << " um while cutting (RMS "
         << fixed(tip.value("contour_error_rms_um", 0.0), 1) << " um, peak at s = " << fixed(tip.value("at_s_mm", 0.0), 1)
         << " mm)";
    if (tip.contains("joint_deflection_peak_um")) {
      html << "; the joints' elastic deflection alone moves it by up to "
           << fixed(tip["joint_deflection_peak_um"].get<double>(), 1) << " um (at s = "
           << fixed(tip.value("joint_deflection_at_s_mm", 0.0), 1) << " mm)";
    }
    html << ".</p>\n";
  }
}

void method_section(std::ostringstream& html, const Json& report) {
  if (!report.contains("method_comparison")) return;
  html << "<h2>Planning methods side by side (production feed)</h2><table><tr><th>method</th>"
          "<th>duration [s]</th><th>lower bound [s]</th><th>marks</th><th>deepest [um]</th>"
          "<th>at path length [mm]</th><th>place</th></tr>\n";
  for (const auto& method : report["method_comparison"]) {
    html << "<tr><td>" << html_escape(method.value("method", "")) << "</td><td>"
         << fixed(method.value("duration_s", 0.0), 3) << "</td><td>" << fixed(method.value("lower_bound_s", 0.0), 3)
         << "</td><td>" << method.value("marks", 0) << "</td><td>";
    if (method.contains("deepest_mark")) {
      const Json& deepest = method["deepest_mark"];
      html << fixed(deepest.value("depth_um", 0.0), 2) << "</td><td>" << fixed(deepest.value("s_mm", 0.0), 2)
           << "</td><td>";
      html << html_escape(joined(deepest.value("place", Json::array()), ", ", true));
    } else {
      html << "-</td><td>-</td><td>";
    }
    html << "</td></tr>\n";
  }
  html << "</table>\n";
}

void views_section(std::ostringstream& html, const Json& report) {
  html << "<h2>Surface views</h2><table><tr><th>view</th><th>lines</th><th>marks and specks</th>"
          "<th>deviation min / max / RMS [um]</th><th>steep lines not assessed</th></tr>\n";
  for (const auto& view : report["surface"]["views"]) {
    html << "<tr><td>" << html_escape(view.value("title", "")) << "</td><td>" << view.value("lines", 0)
         << "</td><td>" << view.value("marks", 0) << "</td><td>" << fixed(view.value("deviation_min_um", 0.0), 2)
         << " / " << fixed(view.value("deviation_max_um", 0.0), 2) << " / "
         << fixed(view.value("deviation_rms_um", 0.0), 3) << "</td><td>" << view.value("steep_lines_not_assessed", 0)
         << "</td></tr>\n";
  }
  html << "</table>\n";
}

void images_section(std::ostringstream& html, const Json& report, const std::vector<std::string>& images) {
  if (report.contains("renders") && report["renders"].contains("skipped")) {
    html << "<p><b>No images:</b> " << html_escape(report["renders"].value("skipped", "")) << "</p>\n";
  }
  if (images.empty()) return;
  html << "<h2>Images</h2>\n";
  for (const std::string& image : images) {
    std::string caption = caption_of(image);
    // The marks' numbers in a view (simulate_part.cpp's render_view_surfaces): those without room.
    if (report.contains("renders") && report["renders"].contains("view_labels") &&
        report["renders"]["view_labels"].contains(image)) {
      const Json& labels = report["renders"]["view_labels"][image];
      caption += " Numbers: the marks' ranks in the marks table.";
      if (!labels["left_out"].empty()) {
        std::string ranks;
        for (const Json& rank : labels["left_out"]) ranks += (ranks.empty() ? "" : ", ") + std::to_string(rank.get<int>());
        caption += " Not labelled (no room beside the others, or out of the picture): mark" +
                   std::string(labels["left_out"].size() > 1 ? "s " : " ") + ranks + ".";
      }
    }
    html << "<figure><img src=\"" << html_escape(image) << "\" alt=\"" << html_escape(caption)
         << "\"><figcaption>" << html_escape(caption) << "</figcaption></figure>\n";
  }
}

/// The blocks around each listed mark's line, each line once, with an anchor per line.
void program_section(std::ostringstream& html, const Json& report) {
  std::map<int, std::string> lines;
  std::set<int> marked;
  std::size_t shown = 0;
  for (const auto& mark : report["marks"]) {
    if (shown++ == kHtmlMarkRows) break;
    if (mark.value("line", 0) > 0) marked.insert(mark.value("line", 0));
    for (const auto& entry : mark.value("excerpt", Json::array())) {
      lines[entry.value("line", 0)] = entry.value("text", "");
    }
  }
  if (lines.empty()) return;
  html << "<h2>Program excerpts</h2>\n<p>The blocks around each mark's line in "
       << html_escape(report.contains("context") ? text_of(report["context"], "toolpath") : std::string())
       << " (marked lines in bold).</p>\n<pre class=\"program\">";
  int previous = -1;
  for (const auto& [line, text] : lines) {
    if (previous >= 0 && line > previous + 1) html << "   ...\n";
    const bool is_marked = marked.count(line) > 0;
    html << "<span id=\"" << anchor_of(line) << "\"" << (is_marked ? " class=\"marked\"" : "") << ">";
    char number[16];
    std::snprintf(number, sizeof number, "%6d  ", line);
    html << number << html_escape(text) << "</span>\n";
    previous = line;
  }
  html << "</pre>\n";
}

/// A stage's key in words ("load_and_inverse_kinematics" -> "load and inverse kinematics").
std::string stage_in_words(std::string stage) {
  std::replace(stage.begin(), stage.end(), '_', ' ');
  return stage;
}

void times_section(std::ostringstream& html, const Json& report) {
  if (!report.contains("stage_seconds")) return;
  html << "<h2>Computing time</h2><table><tr><th>stage</th><th>seconds</th></tr>\n";
  for (const auto& [stage, value] : report["stage_seconds"].items()) {
    if (value.is_number()) {
      html << "<tr><td>" << html_escape(stage_in_words(stage)) << "</td><td>" << fixed(value.get<double>(), 2)
           << "</td></tr>\n";
    } else if (value.is_object()) {
      double total = 0.0;
      std::string parts;
      for (const auto& [part, seconds] : value.items()) {
        if (!seconds.is_number()) continue;
        total += seconds.get<double>();
        parts += (parts.empty() ? "" : ", ") + stage_in_words(part) + " " + fixed(seconds.get<double>(), 2);
      }
      html << "<tr><td>" << html_escape(stage_in_words(stage)) << " run</td><td>" << fixed(total, 2) << " (" << html_escape(parts)
           << ")</td></tr>\n";
    }
  }
  html << "</table>\n";
}

}  // namespace

std::string html_escape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&': out += "&amp;"; break;
      case '<': out += "&lt;"; break;
      case '>': out += "&gt;"; break;
      case '"': out += "&quot;"; break;
      case '\'': out += "&#39;"; break;
      default: out += c;
    }
  }
  return out;
}

std::string html_report(const Json& report, const std::vector<std::string>& images) {
  std::ostringstream html;
  const std::string name = report["part"].value("name", "");
  html << "<!doctype html><html lang=\"en\"><head><meta charset=\"utf-8\">"
          "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"><title>vmsim: "
       << html_escape(name)
       << "</title><style>"
          "body{font-family:sans-serif;max-width:1100px;margin:auto;padding:0 12px;line-height:1.35}"
          "table{border-collapse:collapse;margin:6px 0;max-width:100%}"
          "td,th{border:1px solid #999;padding:3px 7px;vertical-align:top;text-align:left}"
          "table.marks td:nth-child(6){max-width:340px;overflow-wrap:anywhere}"
          "table.context th{background:#f2f2f2;width:170px}"
          "tr.beyond td{background:#fbe3e3}"
          "code,pre{font-family:monospace;font-size:90%}"
          "pre.program{background:#f7f7f7;padding:6px;overflow-x:auto}"
          "pre.program span.marked{font-weight:bold;background:#fff3b0}"
          ".verdict{border:2px solid;padding:4px 14px;margin:10px 0}"
          "#view3d{position:relative;width:100%;height:540px;border:1px solid #999;margin:6px 0}"
          // A view's title can be long (a cylinder's axis and angles): the select stays on the line.
          ".view3d-controls select{max-width:640px;margin:0 8px}"
          "#view3d-pick{min-height:3em}#view3d-pick th{background:#f2f2f2}"
          ".view3d-failed{padding:12px;color:#b00}"
          "img{max-width:100%}img.thumbnail{width:160px}figure{margin:14px 0}figcaption{color:#333;font-size:92%}"
          "</style></head><body>\n";
  html << "<h1>" << html_escape(name) << "</h1>\n<p>" << html_escape(report["part"].value("description", ""))
       << "</p>\n";
  verdict_section(html, report);
  context_section(html, report);
  checks_section(html, report);
  marks_section(html, report);
  view_3d_section(html, report);
  following_error_section(html, report);
  method_section(html, report);
  views_section(html, report);
  images_section(html, report, images);
  program_section(html, report);
  times_section(html, report);
  html << "</body></html>\n";
  return html.str();
}

}  // namespace vmsim::app

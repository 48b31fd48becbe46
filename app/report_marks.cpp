#include "report_marks.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <optional>
#include <sstream>
#include <utility>
#include <vector>

namespace vmsim::app {
namespace {

using Json = nlohmann::json;

/// A length for a sentence: 3 significant digits at most, no trailing zeros.
std::string figure(double value) {
  char text[32];
  std::snprintf(text, sizeof text, "%.3g", value);
  return text;
}

double depth_of(const Json& mark) { return mark.value("depth_um", 0.0); }

std::string point_text(const Json& point_mm) {
  if (!point_mm.is_array() || point_mm.size() != 3) return "";
  char text[96];
  std::snprintf(text, sizeof text, "(%.3f, %.3f, %.3f) mm", point_mm[0].get<double>(),
                point_mm[1].get<double>(), point_mm[2].get<double>());
  return text;
}

/// "corners (3), reversals of Y (1)": the kinds counted over the marks, most frequent first.
std::string counted(const std::map<std::string, int>& counts) {
  std::vector<std::pair<int, std::string>> sorted;
  for (const auto& [name, count] : counts) sorted.emplace_back(count, name);
  std::stable_sort(sorted.begin(), sorted.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::string text;
  for (const auto& [count, name] : sorted) {
    text += (text.empty() ? "" : ", ") + name + " (" + std::to_string(count) + ")";
  }
  return text;
}

std::string csv_field(const std::string& text) {
  if (text.find_first_of(",\"\n\r") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  return quoted + "\"";
}


}  // namespace

double min_mark_area_mm2(double grid_um, double tool_diameter_mm) {
  const double grid_mm = grid_um * 1e-3;
  return std::max(25.0 * grid_mm * grid_mm, std::pow(tool_diameter_mm / 20.0, 2));
}

std::string joined(const Json& list, const char* separator, bool in_words) {
  std::string text;
  if (!list.is_array()) return text;
  for (const auto& item : list) {
    const std::string word = in_words ? place_in_words(item.get<std::string>()) : item.get<std::string>();
    text += (text.empty() ? "" : separator) + word;
  }
  return text;
}

std::string place_in_words(const std::string& place) {
  if (place == "tangency_or_curvature_change") return "tangency or change of curvature";
  std::string words = place;
  std::replace(words.begin(), words.end(), '_', ' ');
  return words;
}

Json curate_marks(const Json& raw_marks, double min_area_mm2) {
  std::vector<Json> marks, specks;
  for (const auto& mark : raw_marks) {
    (mark.value("area_mm2", 0.0) >= min_area_mm2 ? marks : specks).push_back(mark);
  }
  const auto deepest_first = [](const Json& a, const Json& b) { return depth_of(a) > depth_of(b); };
  std::stable_sort(marks.begin(), marks.end(), deepest_first);
  std::stable_sort(specks.begin(), specks.end(), deepest_first);
  Json result;
  result["marks"] = Json::array();
  result["specks"] = {{"count", specks.size()},
                      {"deepest_um", 0.0},
                      {"largest_area_mm2", 0.0},
                      {"min_area_mm2", min_area_mm2},
                      {"list", Json::array()}};
  int rank = 1;
  for (Json& mark : marks) {
    mark["rank"] = rank++;
    result["marks"].push_back(std::move(mark));
  }
  rank = 1;
  double largest_area = 0.0;
  for (Json& speck : specks) {
    largest_area = std::max(largest_area, speck.value("area_mm2", 0.0));
    speck["rank"] = rank++;
    result["specks"]["list"].push_back(std::move(speck));
  }
  if (!specks.empty()) result["specks"]["deepest_um"] = depth_of(result["specks"]["list"][0]);
  result["specks"]["largest_area_mm2"] = largest_area;
  return result;
}

std::optional<double> mark_tolerance_um(const Json& mark, const Tolerance& tolerance) {
  if (mark.contains("tolerance_um") && mark["tolerance_um"].is_number()) return mark["tolerance_um"].get<double>();
  return tolerance.um;
}

Json make_verdict(const Json& curated, const Json& checks, const Tolerance& tolerance) {
  const Json& marks = curated["marks"];
  const Json& specks = curated["specks"];
  Json verdict;
  verdict["tolerance_um"] = tolerance.um ? Json(*tolerance.um) : Json(nullptr);
  verdict["tolerance_source"] = tolerance.source;
  verdict["worst_mark"] = marks.empty() ? Json(nullptr) : marks[0];
  const auto exceeds = [&tolerance](const Json& mark) {
    const std::optional<double> limit = mark_tolerance_um(mark, tolerance);
    return limit && depth_of(mark) > *limit;
  };
  std::size_t beyond = 0, specks_beyond = 0, unjudged = 0;
  bool own_tolerances = false;  // a mark on a design surface with its own tolerance
  const Json* deepest_beyond = nullptr;
  for (const auto& mark : marks) {
    own_tolerances = own_tolerances || mark.contains("tolerance_um");
    if (!mark_tolerance_um(mark, tolerance)) ++unjudged;
    if (!exceeds(mark)) continue;
    ++beyond;
    if (!deepest_beyond) deepest_beyond = &mark;  // marks are deepest first
  }
  for (const auto& speck : specks["list"]) {
    own_tolerances = own_tolerances || speck.contains("tolerance_um");
    specks_beyond += exceeds(speck) ? 1 : 0;
  }
  verdict["marks_beyond_tolerance"] = beyond;
  verdict["specks_beyond_tolerance"] = specks_beyond;
  verdict["marks_without_tolerance"] = unjudged;

  // Per design surface (or view where the mark lies on none): its tolerance, marks, marks
  // beyond it and the deepest; in the order of each surface's deepest mark.
  Json surfaces = Json::array();
  for (const auto& mark : marks) {
    const std::string name = mark.value("design_surface", mark.value("surface", mark.value("view", "")));
    Json* entry = nullptr;
    for (auto& candidate : surfaces) {
      if (candidate["surface"] == name) entry = &candidate;
    }
    if (!entry) {
      const std::optional<double> limit = mark_tolerance_um(mark, tolerance);
      surfaces.push_back({{"surface", name},
                          {"tolerance_um", limit ? Json(*limit) : Json(nullptr)},
                          {"tolerance_source", mark.contains("tolerance_um") ? "design surface" : tolerance.source},
                          {"marks", 0},
                          {"marks_beyond_tolerance", 0},
                          {"deepest_um", depth_of(mark)}});
      entry = &surfaces.back();
    }
    (*entry)["marks"] = (*entry)["marks"].get<int>() + 1;
    if (exceeds(mark)) (*entry)["marks_beyond_tolerance"] = (*entry)["marks_beyond_tolerance"].get<int>() + 1;
  }
  verdict["surfaces"] = surfaces;

  const double worst = marks.empty() ? 0.0 : depth_of(marks[0]);
  // "10 um", or "10 um; 5 um on <surface>, ..." where design surfaces have their own.
  std::string tolerances = tolerance.um ? figure(*tolerance.um) + " um" : "";
  if (own_tolerances) {
    for (const auto& surface : surfaces) {
      if (surface["tolerance_source"] != "design surface") continue;
      tolerances += (tolerances.empty() ? "" : tolerances.find(" on ") == std::string::npos ? "; " : ", ") +
                    figure(surface["tolerance_um"].get<double>()) + " um on " + surface["surface"].get<std::string>();
    }
  }
  std::string headline;
  if (!tolerance.um && !own_tolerances) {
    verdict["status"] = "no_tolerance";
    headline = marks.empty() ? "No mark found. No tolerance was given"
                             : "The deepest mark is " + figure(worst) + " um. No tolerance was given";
    headline += " (--tolerance-um, or tolerance_um in the part file), so there is no verdict.";
  } else if (beyond > 0) {
    verdict["status"] = "not_within";
    if (!own_tolerances) {
      headline = "Not within tolerance (" + tolerances + "): " + std::to_string(beyond) +
                 (beyond == 1 ? " mark exceeds it" : " marks exceed it") + ", the deepest " +
                 figure(depth_of(*deepest_beyond)) + " um.";
    } else {
      const Json& mark = *deepest_beyond;
      headline = "Not within tolerance (" + tolerances + "): " + std::to_string(beyond) +
                 (beyond == 1 ? " mark exceeds" : " marks exceed") + " the tolerance of " +
                 (beyond == 1 ? "its surface" : "their surfaces") + ", the deepest " + figure(depth_of(mark)) +
                 " um on " + mark.value("design_surface", mark.value("surface", mark.value("view", ""))) +
                 " (tolerance " + figure(*mark_tolerance_um(mark, tolerance)) + " um).";
    }
  } else if (unjudged > 0) {
    verdict["status"] = "no_tolerance";
    headline = "No verdict: " + std::to_string(unjudged) + (unjudged == 1 ? " mark lies" : " marks lie") +
               " on surfaces without a tolerance (--tolerance-um, or tolerance_um in the part file); the marks "
               "on surfaces with one (" + tolerances + ") are within it.";
  } else {
    verdict["status"] = "within";
    headline = "Within tolerance (" + tolerances + "): " +
               (marks.empty() ? std::string("no mark found.")
                              : "the deepest mark is " + figure(worst) + " um.");
  }
  verdict["headline"] = headline;

  std::string summary;
  if (!marks.empty()) {
    const Json& mark = marks[0];
    summary = "The deepest mark is " + std::string(mark.value("kind", "") == "gouge" ? "a gouge" : "excess material") +
              " of " + figure(worst) + " um over " + figure(mark.value("area_mm2", 0.0)) + " mm2 at " +
              point_text(mark.value("deepest_point_mm", Json())) + " on the " +
              mark.value("surface", mark.value("view", "") + " view");
    if (mark.value("line", 0) > 0) {
      summary += ", made by program line " + std::to_string(mark.value("line", 0));
      const std::string text = mark.value("block_text", "");
      if (!text.empty()) summary += " (" + text + ")";
    }
    const std::string places = joined(mark.value("place", Json::array()), ", ", true);
    if (!places.empty()) summary += ", at a " + places;
    const std::string axes = joined(mark.value("responsible_axes", Json::array()), ", ", false);
    if (!axes.empty()) summary += "; the following error of " + axes + " causes most of it";
    summary += ".";
    std::map<std::string, int> place_counts, axis_counts;
    std::map<int, int> line_counts;
    for (const auto& m : marks) {
      for (const auto& place : m.value("place", Json::array())) place_counts[place_in_words(place.get<std::string>())]++;
      for (const auto& axis : m.value("responsible_axes", Json::array())) axis_counts[axis.get<std::string>()]++;
      if (m.value("line", 0) > 0) line_counts[m.value("line", 0)]++;
    }
    if (marks.size() > 1) {
      summary += " " + std::to_string(marks.size()) + " marks in all";
      if (!place_counts.empty()) summary += "; at: " + counted(place_counts);
      if (!axis_counts.empty()) summary += "; caused by the axes: " + counted(axis_counts);
      std::vector<std::pair<int, int>> lines;
      for (const auto& [line, count] : line_counts) lines.emplace_back(count, line);
      std::stable_sort(lines.begin(), lines.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
      if (!lines.empty()) {
        summary += "; program lines with most marks: ";
        for (std::size_t i = 0; i < std::min<std::size_t>(lines.size(), 5); ++i) {
          summary += (i ? ", " : "") + std::to_string(lines[i].second);
        }
      }
      summary += ".";
    }
  }
  const std::size_t speck_count = specks.value("count", std::size_t{0});
  if (speck_count > 0) {
    summary += (summary.empty() ? "" : " ") + std::to_string(speck_count) + " smaller deviations (under " +
               figure(specks.value("min_area_mm2", 0.0)) + " mm2 each, the deepest " +
               figure(specks.value("deepest_um", 0.0)) + " um) are not counted as marks";
    if (specks_beyond > 0) summary += "; " + std::to_string(specks_beyond) + " of them exceed the tolerance";
    summary += " (marks.csv lists them).";
  }
  for (const auto& check : checks) {
    const std::string status = check.value("status", "");
    if (status != "ok") {
      // "Warning: production drive currents ... (detail)." rather than the label run into the text.
      const std::string verdict_word = status == "FAILED" ? "Failed" : status == "WARNING" ? "Warning" : status;
      summary += (summary.empty() ? "" : " ") + verdict_word + ", validity check: " + check.value("check", "") +
                 (check.contains("detail") ? " (" + check.value("detail", "") + ")" : "") + ".";
    }
  }
  verdict["summary"] = summary;
  return verdict;
}

std::string marks_csv(const Json& curated) {
  std::ostringstream csv;
  csv << "rank,speck,kind,depth_um,area_mm2,lines,view,x_mm,y_mm,z_mm,s_mm,line,block,block_text,place,"
         "responsible_axes\n";
  const auto row = [&csv](const Json& mark, bool speck) {
    const Json point = mark.value("deepest_point_mm", Json::array({0.0, 0.0, 0.0}));
    char numbers[256];
    std::snprintf(numbers, sizeof numbers, "%.4f,%.5f,%zu", depth_of(mark), mark.value("area_mm2", 0.0),
                  mark.value("lines", std::size_t{0}));
    char position[160];
    std::snprintf(position, sizeof position, "%.4f,%.4f,%.4f,%.3f", point[0].get<double>(), point[1].get<double>(),
                  point[2].get<double>(), mark.value("s_mm", 0.0));
    csv << mark.value("rank", 0) << ',' << (speck ? "yes" : "no") << ',' << mark.value("kind", "") << ','
        << numbers << ',' << csv_field(mark.value("view", "")) << ',' << position << ',' << mark.value("line", 0)
        << ',' << csv_field(mark.value("block", "")) << ',' << csv_field(mark.value("block_text", "")) << ','
        << csv_field(joined(mark.value("place", Json::array()), "; ", true)) << ','
        << csv_field(joined(mark.value("responsible_axes", Json::array()), " ", false)) << '\n';
  };
  for (const auto& mark : curated["marks"]) row(mark, false);
  for (const auto& speck : curated["specks"]["list"]) row(speck, true);
  return csv.str();
}

}  // namespace vmsim::app

#pragma once
// simulate-part's report.html: one self-contained page (images beside it in the folder) that an
// engineer can forward. From the top: the verdict against the tolerance and its cause, the
// context (part, machine, tool, stock, feeds and where they came from, NC modes, date, version,
// command line), the validity checks, the marks a machinist would act on (the first
// kHtmlMarkRows; all of them in report.json and marks.csv), the following errors while cutting,
// the images with captions, the program excerpts each mark links to, and the stage times.
// Paths are shown relative to the report's folder; no code identifier is shown as text.
#include <cstddef>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

namespace vmsim::app {

/// Marks listed in the page; the rest are in report.json and marks.csv.
inline constexpr std::size_t kHtmlMarkRows = 25;

/// The page for report.json's content `report` and the images written beside it (file names).
std::string html_report(const nlohmann::json& report, const std::vector<std::string>& images);

/// `text` with & < > " ' escaped for HTML.
std::string html_escape(const std::string& text);

}  // namespace vmsim::app

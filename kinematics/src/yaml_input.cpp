#include "vmsim/kinematics/yaml_input.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <sstream>
#include <system_error>

#include <yaml-cpp/eventhandler.h>

#include "machine_loader_internal.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim::kinematics {
namespace {

// More nodes than any machine or part file has; a file beyond it is aliases expanding
// exponentially (a "billion laughs"), which would otherwise exhaust time and memory.
constexpr std::size_t kNodeBudget = 1'000'000;

// Sees the documents of a YAML stream without building them: whether each holds anything, and
// where it starts.
struct DocumentScan : YAML::EventHandler {
  bool has_content = false;
  YAML::Mark start;    ///< of the document
  YAML::Mark content;  ///< of its first node
  void OnDocumentStart(const YAML::Mark& mark) override { start = mark, has_content = false; }
  void OnDocumentEnd() override {}
  void OnNull(const YAML::Mark&, YAML::anchor_t) override {}
  void OnAlias(const YAML::Mark& mark, YAML::anchor_t) override { saw(mark); }
  void OnScalar(const YAML::Mark& mark, const std::string&, YAML::anchor_t, const std::string&) override {
    saw(mark);
  }
  void OnSequenceStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t,
                       YAML::EmitterStyle::value) override {
    saw(mark);
  }
  void OnSequenceEnd() override {}
  void OnMapStart(const YAML::Mark& mark, const std::string&, YAML::anchor_t, YAML::EmitterStyle::value) override {
    saw(mark);
  }
  void OnMapEnd() override {}
  void saw(const YAML::Mark& mark) {
    if (!has_content) content = mark;
    has_content = true;
  }
};

// More empty documents than any file has: yaml-cpp 0.7 returns empty documents for ever on a
// ',' outside brackets (its LoadAll then fills the memory).
constexpr int kDocumentBudget = 1000;

struct DuplicateKeyCheck {
  const std::string& file;
  std::size_t nodes_seen = 0;

  void walk(const YAML::Node& node) {
    if (++nodes_seen > kNodeBudget) {
      throw InputError(located_at(file, node,
                                  "the document expands to more than " +
                                      std::to_string(kNodeBudget) +
                                      " values (anchors and aliases nested too deeply?)"));
    }
    if (node.IsSequence()) {
      for (const YAML::Node& element : node) walk(element);
    } else if (node.IsMap()) {
      std::map<std::string, YAML::Mark> first_seen;
      for (const auto& entry : node) {
        if (!entry.first.IsScalar()) {
          throw InputError(located_at(file, entry.first, "a key must be plain text, not a list or map"));
        }
        const std::string& key = entry.first.Scalar();
        const auto [earlier, inserted] = first_seen.emplace(key, entry.first.Mark());
        if (!inserted) {
          throw InputError(located_at(
              file, entry.first,
              "key '" + key + "' is given twice in the same map (first on line " +
                  std::to_string(earlier->second.line + 1) + "): keep one"));
        }
        walk(entry.second);
      }
    }
  }
};

}  // namespace

std::string located_at(const std::string& file, const YAML::Node& node, const std::string& message) {
  const YAML::Mark mark = node.Mark();
  return located_message(file, mark.is_null() ? 0 : mark.line + 1,
                         mark.is_null() ? 0 : mark.column + 1, message);
}

YAML::Node parse_yaml_input(std::string_view text, const std::string& file_name_for_messages) {
  const std::string content(strip_utf8_bom(text));
  YAML::Node document;
  try {
    document = YAML::Load(content);
    // The documents after the first: `---` with nothing after it carries nothing; anything else
    // is refused (not LoadAll: see kDocumentBudget).
    std::istringstream stream(content);
    YAML::Parser parser(stream);
    DocumentScan scan;
    for (int index = 0; parser.HandleNextDocument(scan); ++index) {
      if (index == 0) continue;
      if (scan.has_content) {
        throw InputError(located_message(file_name_for_messages, scan.content.line + 1, scan.content.column + 1,
                                         "a second YAML document starts here (after a '---' or '...' line); "
                                         "an input file holds one document: remove it or merge it into the "
                                         "first"));
      }
      if (index > kDocumentBudget) {
        throw InputError(located_message(file_name_for_messages, scan.start.line + 1, scan.start.column + 1,
                                         "YAML syntax: the parser does not get past this place (a ',' "
                                         "outside brackets?)"));
      }
    }
  } catch (const YAML::Exception& error) {
    throw InputError(located_message(file_name_for_messages, error.mark.line + 1,
                                     error.mark.column + 1, "YAML syntax: " + error.msg));
  }
  DuplicateKeyCheck check{file_name_for_messages};
  check.walk(document);
  return document;
}

YAML::Node load_yaml_input(const std::string& path) { return parse_yaml_input(read_file(path), path); }

NumberText parse_number_text(std::string_view text) {
  NumberText result;
  const char* begin = text.data();
  const char* end = begin + text.size();
  if (begin != end && *begin == '+') ++begin;
  const auto [stop, error] = std::from_chars(begin, end, result.value);
  if (text.empty() || (error != std::errc() && error != std::errc::result_out_of_range) ||
      stop != end) {
    result.problem = "is not a number";
  } else if (error == std::errc::result_out_of_range) {
    result.problem = "is beyond the range of a double (magnitude above 1.8e308 or below 2.2e-308)";
  } else if (!std::isfinite(result.value)) {
    result.problem = "is not a finite number";
  } else if (result.value != 0.0 && !std::isnormal(result.value)) {
    result.problem = "is a subnormal number (magnitude below 2.2e-308): not a plausible quantity";
  } else {
    result.ok = true;
  }
  return result;
}

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t substitution = diagonal + (a[i - 1] == b[j - 1] ? 0 : 1);
      diagonal = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, substitution});
    }
  }
  return row[b.size()];
}

std::string nearest_key_hint(const std::string& key, const std::vector<std::string>& known_keys) {
  std::string nearest;
  std::size_t nearest_distance = std::max<std::size_t>(2, key.size() / 3) + 1;
  for (const std::string& known : known_keys) {
    const std::size_t distance = edit_distance(key, known);
    if (distance < nearest_distance) {
      nearest_distance = distance;
      nearest = known;
    }
  }
  return nearest.empty() ? "" : " (did you mean '" + nearest + "'?)";
}

}  // namespace vmsim::kinematics

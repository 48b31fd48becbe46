#include "vmsim/kinematics/yaml_input.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <map>
#include <system_error>

#include "machine_loader_internal.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim::kinematics {
namespace {

// More nodes than any machine or part file has; a file beyond it is aliases expanding
// exponentially (a "billion laughs"), which would otherwise exhaust time and memory.
constexpr std::size_t kNodeBudget = 1'000'000;

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
  std::vector<YAML::Node> documents;
  try {
    documents = YAML::LoadAll(std::string(strip_utf8_bom(text)));
  } catch (const YAML::Exception& error) {
    throw InputError(located_message(file_name_for_messages, error.mark.line + 1,
                                     error.mark.column + 1, "YAML syntax: " + error.msg));
  }
  if (documents.empty()) return YAML::Node();
  for (std::size_t i = 1; i < documents.size(); ++i) {
    if (documents[i].IsNull()) continue;  // `---` with nothing after it carries nothing
    throw InputError(located_at(file_name_for_messages, documents[i],
                                "a second YAML document starts here (after a '---' or '...' line); "
                                "an input file holds one document: remove it or merge it into the "
                                "first"));
  }
  DuplicateKeyCheck check{file_name_for_messages};
  check.walk(documents.front());
  return documents.front();
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

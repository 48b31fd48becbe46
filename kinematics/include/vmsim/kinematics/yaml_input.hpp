#pragma once
// Reading YAML input files (machine files, part files) the same way everywhere: the checks
// yaml-cpp does not make, with errors that name the file, line and column.
//
// Include only from code that links yaml-cpp (the kinematics library, identify, the app).
#include <yaml-cpp/yaml.h>

#include <string>
#include <string_view>
#include <vector>

namespace vmsim::kinematics {

/// Parses the text of a YAML input file. Beyond yaml-cpp's syntax errors it refuses, with the
/// file, line and column (vmsim::InputError):
/// - a key given twice in one map (yaml-cpp would keep one value silently), and a key that is
///   not plain text;
/// - a second document after the first (`---` then more: yaml-cpp's Load would ignore it);
///   empty documents after the first carry nothing and are accepted;
/// - files whose anchors and aliases expand to more than a million nodes.
/// A UTF-8 byte-order mark at the start is skipped. An empty text gives a null node.
YAML::Node parse_yaml_input(std::string_view text, const std::string& file_name_for_messages);

/// read_file (regular files only, size cap) and parse_yaml_input.
YAML::Node load_yaml_input(const std::string& path);

/// "file:line:column: message" at the node's place in the file.
std::string located_at(const std::string& file, const YAML::Node& node, const std::string& message);

/// The result of reading a number from text.
struct NumberText {
  bool ok = false;
  double value = 0.0;
  std::string problem;  ///< why it was refused, e.g. "is not a number"; empty when ok
};

/// Reads a whole text as a decimal number (a leading '+' is allowed). Refused: anything else,
/// infinities and NaN, numbers beyond the range of a double, and subnormal numbers
/// (4.9e-324: no plausible quantity; zero stays allowed).
NumberText parse_number_text(std::string_view text);

/// " (did you mean 'x'?)" with the known key nearest to `key` (edit distance, at most a third of
/// its length), or "" when none is near.
std::string nearest_key_hint(const std::string& key, const std::vector<std::string>& known_keys);

}  // namespace vmsim::kinematics

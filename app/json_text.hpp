#pragma once
// JSON text of the output files.
#include <nlohmann/json.hpp>
#include <string>

namespace vmsim::app {

/// Indented JSON text ending with a newline. Strings taken from the user's files (paths, block
/// names) need not be UTF-8: bad bytes are written as U+FFFD instead of failing after the work.
inline std::string json_file_text(const nlohmann::json& value) {
  return value.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) + "\n";
}

}  // namespace vmsim::app

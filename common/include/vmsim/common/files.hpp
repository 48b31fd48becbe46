#pragma once
// Writing output so that a file is complete or absent, never half-written.
#include <string>

namespace vmsim {

/// Writes `content` to `path` through a temporary file in the same folder and a rename.
/// Throws vmsim::InputError naming the path when it cannot be written.
void write_file_atomically(const std::string& path, const std::string& content);

/// Reads a whole file; throws vmsim::InputError naming the path when it cannot be read.
std::string read_file(const std::string& path);

/// Shortest decimal text of a double that reads back to the same value.
std::string format_double(double value);

}  // namespace vmsim

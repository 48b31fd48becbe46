#pragma once
// Writing an output file too large to hold whole, complete or absent as write_file_atomically
// (files.hpp) writes one.
#include <functional>
#include <iosfwd>
#include <string>

namespace vmsim {

/// Writes `path` through a temporary file in the same folder and a rename; `write` writes the
/// content piece by piece to the temporary file's stream. When `write` throws or the writing
/// fails, the temporary file is removed and nothing is left at `path`. Throws
/// vmsim::InputError naming the path when it cannot be written.
void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write);

}  // namespace vmsim

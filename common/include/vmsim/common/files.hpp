#pragma once
// Reading input files safely, and writing output so that a file is complete or absent, never
// half-written.
#include <cstdint>
#include <string>
#include <string_view>

namespace vmsim {

/// Writes `content` to `path` through a temporary file in the same folder and a rename.
/// Throws vmsim::InputError naming the path when it cannot be written.
void write_file_atomically(const std::string& path, const std::string& content);

/// The largest input file read_file accepts [bytes]: 2 GiB. Larger is no plausible machine,
/// part, tool path, trace or mesh, and would exhaust memory before any message.
inline constexpr std::uint64_t kInputFileSizeLimit_bytes = std::uint64_t{2} << 30;

/// Reads a whole input file. Every reader of user files goes through it, so that none of them
/// can block or run out of memory on a bad path. Throws vmsim::InputError naming the path when it
/// cannot be opened, is not a regular file (a folder, a FIFO, a device such as /dev/zero: those
/// would block or never end), or is larger than `size_limit_bytes`.
std::string read_file(const std::string& path,
                      std::uint64_t size_limit_bytes = kInputFileSizeLimit_bytes);

/// `text` without a UTF-8 byte-order mark (EF BB BF) at its very start, if it has one. Every text
/// reader skips it (spreadsheets and some editors write one; shared/spec/trace-format.md). Line
/// and column numbers are unchanged: the mark is not a character of the first line.
std::string_view strip_utf8_bom(std::string_view text);

/// Shortest decimal text of a double that reads back to the same value.
std::string format_double(double value);

}  // namespace vmsim

#pragma once
// Typed errors shared by every vmsim library.
//
// Libraries never print and never exit: they throw one of these, and the vmsim program turns it
// into a message and an exit code (see app/exit_codes.hpp).
#include <stdexcept>
#include <string>

namespace vmsim {

/// Bad user input: a file, a field, a line or a value the user gave is wrong.
/// The message names the file, the line (and column) where known, the field and the value.
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Valid input that asks for something the machine cannot do: an unreachable pose, a joint
/// limit violated along the tool path. The message names the tool path block.
class InfeasibleError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Formats "file:line:column: message" (line/column left out where zero).
std::string located_message(const std::string& file, int line, int column,
                            const std::string& message);

}  // namespace vmsim

#pragma once
// The G-code program pre-pass: runs the programming language of a G-code file (Fanuc Custom
// Macro B and LinuxCNC: # parameters, expressions, IF/GOTO/WHILE, M98/M99/G65 subprograms,
// LinuxCNC o-words) and hands the block interpreter (gcode_reader.cpp) the plain blocks, with
// every parameter and expression replaced by its number, in the order the control runs them.
// The language it accepts is documented in vmsim/toolpath/toolpath.hpp ("G-code programs").
//
// Lines without any macro syntax (no '#', '[', '<', O word, keyword of two or more letters,
// M98/M99/G65-G67) are handed over unchanged, without being tokenised here: a plain program costs
// one scan of its characters.
#include <functional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "vmsim/common/errors.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::toolpath::detail {

/// One block for the block interpreter.
struct ExpandedBlock {
  int line = 0;             ///< 1-based line of the source block
  std::string_view source;  ///< that line as written (without its line end)
  std::string_view text;    ///< the block to interpret: plain words, numbers substituted
  /// (column in text, column in source), both 1-based, ascending: a column of `text` maps to the
  /// source column of the last pair at or before it. Empty: `text` is `source`.
  const std::vector<std::pair<int, int>>* columns = nullptr;
  /// The file of the block where it is not the program's own (a subprogram found in
  /// ReaderOptions::subprogram_folder); nullptr for the program's file.
  const std::string* file = nullptr;

  /// The source column of a 1-based column of `text` (a word keeps the column of the word or
  /// expression it was made from).
  int source_column(int text_column) const;
};

/// Runs `run()`, which reads a block of the file `other`: its errors, which name the program's
/// `file`, name `other` instead.
template <class Run>
void with_messages_naming(const std::string& file, const std::string& other, Run run) {
  const auto renamed = [&](const std::string& message) {
    return message.rfind(file + ":", 0) == 0 ? other + message.substr(file.size()) : message;
  };
  try {
    run();
  } catch (const InputError& error) {
    throw InputError(renamed(error.what()));
  } catch (const InfeasibleError& error) {
    throw InfeasibleError(renamed(error.what()));
  }
}

/// Runs the G-code program `text` (UTF-8 already checked, byte-order mark removed) and calls
/// `emit` with every block to interpret, in the order of execution, until the program ends (the
/// end of the main program, M99 in the main program) or `emit` returns false (the interpreter
/// met M2/M30). Throws vmsim::InputError "file:line:column: 'word': what is wrong" for errors of
/// the language (syntax, an undefined parameter, label or subprogram, division by zero, a
/// function outside its domain) and when ReaderOptions::max_executed_blocks or
/// max_call_depth is exceeded.
void run_gcode_program(std::string_view text, const std::string& file,
                       const ReaderOptions& options,
                       const std::function<bool(const ExpandedBlock&)>& emit);

}  // namespace vmsim::toolpath::detail

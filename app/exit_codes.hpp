#pragma once
// Exit codes of the vmsim program (documented in the README and in `vmsim --help`).
#include <stdexcept>

namespace vmsim::app {

/// A command-line value that parses but is not allowed (an unknown method, a negative feed):
/// exit kUsageError like CLI11's own errors, not kInputError (which names a file).
class CommandLineError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

enum ExitCode : int {
  kSuccess = 0,
  kInternalError = 1,   ///< a bug: please report it with the command line
  kUsageError = 2,      ///< bad command line (unknown option, missing argument)
  kInputError = 3,      ///< bad input file: the message names file, line and value
  kInfeasible = 4,      ///< valid input the machine cannot do (unreachable pose, travel exceeded)
  kNoDisplay = 5,       ///< a render was asked for and no X display is there (use xvfb-run -a)
  kOutOfMemory = 6,     ///< the job needs more memory than the process may have (not a bug)
};

inline constexpr const char* kExitCodeHelp =
    "Exit codes: 0 success; 1 internal error; 2 bad command line; 3 bad input file (the message "
    "names file, line and value); 4 infeasible (unreachable pose, travel exceeded); 5 no display "
    "for a render (run under xvfb-run -a); 6 out of memory (a coarser grid, --memory-budget-gb, or "
    "mpirun over several machines).";

}  // namespace vmsim::app

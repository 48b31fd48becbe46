#pragma once
// Exit codes of the vmsim program (documented in the README and in `vmsim --help`).
namespace vmsim::app {

enum ExitCode : int {
  kSuccess = 0,
  kInternalError = 1,   ///< a bug: please report it with the command line
  kUsageError = 2,      ///< bad command line (unknown option, missing argument)
  kInputError = 3,      ///< bad input file: the message names file, line and value
  kInfeasible = 4,      ///< valid input the machine cannot do (unreachable pose, travel exceeded)
  kNoDisplay = 5,       ///< a render was asked for and no X display is there (use xvfb-run -a)
};

inline constexpr const char* kExitCodeHelp =
    "Exit codes: 0 success; 1 internal error; 2 bad command line; 3 bad input file (the message "
    "names file, line and value); 4 infeasible (unreachable pose, travel exceeded); 5 no display "
    "for a render (run under xvfb-run -a).";

}  // namespace vmsim::app

// vmsim: the command-line program. A thin layer over the libraries: it parses arguments, calls
// the libraries, prints, and turns errors into exit codes (exit_codes.hpp).
#include <CLI/CLI.hpp>
#include <sys/resource.h>
#include <unistd.h>

#include <cstdio>
#include <exception>
#include <filesystem>
#include <iostream>
#include <new>
#include <string>

#include "commands.hpp"
#include "exit_codes.hpp"
#include "mpi_ranks.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/memory.hpp"
#include "vmsim/viz/display.hpp"

namespace {

// Under mpirun with several ranks: only simulate-part is split (the other commands would run
// whole on every rank and write the same files); ranks other than 0 print nothing but errors.
int run(int argc, char** argv);

// The process's peak resident memory so far [MiB] (the kernel's high-water mark; KiB on Linux).
long long peak_resident_mib() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return static_cast<long long>(usage.ru_maxrss / 1024);
}

// Ends the job with `code` after an error on this rank. One rank: returns it. Several: ranks
// other than 0 first wait a moment, so that where every rank fails alike (bad input, read by
// all) rank 0's message is the one printed and its MPI_Abort ends the others; then every rank
// of the job ends with `code` (MPI_Abort; mpirun exits with it).
int fail(int code, const std::string& message) {
  const vmsim::app::Ranks& ranks = vmsim::app::Ranks::world();
  if (!ranks.distributed()) {
    std::cerr << message;
    return code;
  }
  if (!ranks.root()) ::sleep(2);
  std::cerr << (ranks.root() ? "" : "rank " + std::to_string(ranks.rank()) + ": ") << message << std::flush;
  ranks.abort(code);
}

}  // namespace

int main(int argc, char** argv) {
  vmsim::app::MpiSession mpi(argc, argv);
  return run(argc, argv);
}

namespace {

int run(int argc, char** argv) {
  using namespace vmsim::app;
  vmsim::keep_freed_memory_in_process();
  const Ranks& ranks = Ranks::world();
  if (ranks.distributed() && !ranks.root()) {
    // Progress and results are rank 0's to print.
    if (std::freopen("/dev/null", "w", stdout) == nullptr) return fail(kInternalError, "cannot silence stdout\n");
  }
  CLI::App app{"vmsim: virtual machining simulator. Predicts how a machine's drives follow a tool "
               "path at production feed and what marks that leaves on the part."};
  app.footer(kExitCodeHelp);
  app.require_subcommand(1);
  CommandContext context;
  // For reports, which are forwarded: an absolute path is shown by its last name only.
  for (int i = 0; i < argc; ++i) {
    std::string argument = i == 0 ? std::filesystem::path(argv[0]).filename().string() : argv[i];
    const std::size_t value_at = argument.rfind("--", 0) == 0 && argument.find('=') != std::string::npos
                                     ? argument.find('=') + 1
                                     : 0;
    if (argument.size() > value_at && argument[value_at] == '/') {
      std::filesystem::path path(argument.substr(value_at));
      if (!path.has_filename()) path = path.parent_path();  // "/tmp/out/"
      argument = argument.substr(0, value_at) + ".../" + path.filename().string();
    }
    if (argument.find_first_of(" \t\"'") != std::string::npos) argument = "'" + argument + "'";
    context.command_line += (i ? " " : "") + argument;
  }
  app.add_flag("-q,--quiet", context.quiet, "print nothing but warnings and errors");
  add_simulate_part_command(app, context);
  add_kinematics_command(app, context);
  add_dynamics_command(app, context);
  add_plan_command(app, context);
  add_servo_command(app, context);
  add_plot_command(app, context);
  add_identify_command(app, context);
  add_diagnose_command(app, context);
  add_remove_command(app, context);
  add_circle_test_command(app, context);
  add_calibrate_command(app, context);

  if (ranks.distributed()) {
    // Checked before parsing runs the command (CLI11 runs a subcommand's callback in parse()).
    for (CLI::App* command : app.get_subcommands({})) {
      command->preparse_callback([command, &ranks](std::size_t) {
        if (command->get_name() != "simulate-part") {
          throw CommandLineError(command->get_name() + " runs on one process; under mpirun (" +
                                 std::to_string(ranks.size()) + " ranks) only simulate-part is split");
        }
      });
    }
  }

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& help) {
    return ranks.root() ? app.exit(help) : 0;
  } catch (const CLI::CallForAllHelp& help) {
    return ranks.root() ? app.exit(help) : 0;
  } catch (const CLI::ParseError& error) {
    if (!ranks.distributed()) {
      app.exit(error);
      return kUsageError;
    }
    return fail(kUsageError, "error: " + std::string(error.what()) + "\n");
  } catch (const CommandLineError& error) {
    return fail(kUsageError, "error: " + std::string(error.what()) + "\nRun with --help for more information.\n");
  } catch (const vmsim::InputError& error) {
    return fail(kInputError, "error: " + std::string(error.what()) + "\n");
  } catch (const vmsim::InfeasibleError& error) {
    return fail(kInfeasible, "error: " + std::string(error.what()) + "\n");
  } catch (const vmsim::viz::NoDisplayError& error) {
    return fail(kNoDisplay, "error: " + std::string(error.what()) + "\n");
  } catch (const std::filesystem::filesystem_error& error) {
    // The system refused a file operation (no space, read-only, permission): the user's to fix.
    return fail(kInputError, "error: " + std::string(error.what()) + "\n");
  } catch (const std::bad_alloc&) {
    // The job is larger than the memory the process may have (the machine's, or a ulimit):
    // the user's to resize, not a bug. The output folder is left as it was (OutputFolder).
    return fail(kOutOfMemory,
                "error: out of memory (the process's peak resident memory: " +
                    std::to_string(peak_resident_mib()) +
                    " MiB). The job needs more memory than this process may have: a coarser grid "
                    "(--grid-um), a lower --memory-budget-gb (the Z-map heights beyond it go to disk, "
                    "--spill-dir), fewer surface views, or simulate-part under mpirun over several "
                    "machines (README, \"Scale\" and \"Running on several processes\")\n");
  } catch (const std::exception& error) {
    return fail(kInternalError, "internal error: " + std::string(error.what()) +
                                    "\n(this is a bug in vmsim: please report it with the command line)\n");
  }
  return context.result;
}

}  // namespace

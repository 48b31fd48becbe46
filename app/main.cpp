// vmsim: the command-line program. A thin layer over the libraries: it parses arguments, calls
// the libraries, prints, and turns errors into exit codes (exit_codes.hpp).
#include <CLI/CLI.hpp>
#include <exception>
#include <filesystem>
#include <iostream>

#include "commands.hpp"
#include "exit_codes.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/memory.hpp"
#include "vmsim/viz/display.hpp"

int main(int argc, char** argv) {
  using namespace vmsim::app;
  vmsim::keep_freed_memory_in_process();
  CLI::App app{"vmsim: virtual machining simulator. Predicts how a machine's drives follow a tool "
               "path at production feed and what marks that leaves on the part."};
  app.footer(kExitCodeHelp);
  app.require_subcommand(1);
  CommandContext context;
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

  try {
    app.parse(argc, argv);
  } catch (const CLI::CallForHelp& help) {
    return app.exit(help);
  } catch (const CLI::CallForAllHelp& help) {
    return app.exit(help);
  } catch (const CLI::ParseError& error) {
    app.exit(error);
    return kUsageError;
  } catch (const CommandLineError& error) {
    std::cerr << "error: " << error.what() << "\nRun with --help for more information.\n";
    return kUsageError;
  } catch (const vmsim::InputError& error) {
    std::cerr << "error: " << error.what() << '\n';
    return kInputError;
  } catch (const vmsim::InfeasibleError& error) {
    std::cerr << "error: " << error.what() << '\n';
    return kInfeasible;
  } catch (const vmsim::viz::NoDisplayError& error) {
    std::cerr << "error: " << error.what() << '\n';
    return kNoDisplay;
  } catch (const std::filesystem::filesystem_error& error) {
    // The system refused a file operation (no space, read-only, permission): the user's to fix.
    std::cerr << "error: " << error.what() << '\n';
    return kInputError;
  } catch (const std::exception& error) {
    std::cerr << "internal error: " << error.what()
              << "\n(this is a bug in vmsim: please report it with the command line)\n";
    return kInternalError;
  }
  return context.result;
}

// vmsim: the command-line program. A thin layer over the libraries: it parses arguments, calls
// the libraries, prints, and turns errors into exit codes (exit_codes.hpp).
#include <CLI/CLI.hpp>
#include <exception>
#include <filesystem>
#include <iostream>
#include <string>

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

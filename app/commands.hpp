#pragma once
// The subcommands of vmsim. Each adds itself to the CLI11 app; its callback stores the exit code.
#include <CLI/CLI.hpp>
#include <iostream>
#include <string>

namespace vmsim::app {

struct CommandContext {
  bool quiet = false;
  int result = 0;
  /// The command line as typed (arguments quoted where needed), for reports.
  std::string command_line;
  void say(const std::string& line) const {
    if (!quiet) std::cout << line << '\n';
  }
  void warn(const std::string& line) const { std::cerr << "warning: " << line << '\n'; }
};

void add_kinematics_command(CLI::App& app, CommandContext& context);
void add_simulate_part_command(CLI::App& app, CommandContext& context);
void add_dynamics_command(CLI::App& app, CommandContext& context);
void add_plan_command(CLI::App& app, CommandContext& context);
void add_servo_command(CLI::App& app, CommandContext& context);
void add_plot_command(CLI::App& app, CommandContext& context);
void add_identify_command(CLI::App& app, CommandContext& context);
void add_diagnose_command(CLI::App& app, CommandContext& context);
void add_remove_command(CLI::App& app, CommandContext& context);
void add_circle_test_command(CLI::App& app, CommandContext& context);
void add_calibrate_command(CLI::App& app, CommandContext& context);

}  // namespace vmsim::app

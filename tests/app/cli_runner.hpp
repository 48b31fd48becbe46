#pragma once
// Runs the vmsim program in a test: exit code and combined output.
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <string>

#include "../temp_folder.hpp"

namespace vmsim::test {

struct RunResult {
  int exit_code = -1;
  std::string output;  ///< stdout and stderr
};

/// Runs `<prefix> vmsim <arguments>` through the shell; prefix e.g. "env -u DISPLAY".
inline RunResult run_vmsim_with_env(const std::string& prefix, const std::string& arguments) {
  const std::string command = prefix + " " + VMSIM_BINARY + " " + arguments + " 2>&1";
  RunResult result;
  FILE* pipe = popen(command.c_str(), "r");
  if (!pipe) return result;
  std::array<char, 4096> buffer{};
  while (fgets(buffer.data(), static_cast<int>(buffer.size()), pipe)) result.output += buffer.data();
  const int status = pclose(pipe);
  result.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return result;
}

inline RunResult run_vmsim(const std::string& arguments) { return run_vmsim_with_env("", arguments); }

/// A fresh empty folder under the system's temporary folder, private to this process.
inline std::filesystem::path fresh_folder(const std::string& name) { return fresh_temp_folder(name); }

}  // namespace vmsim::test

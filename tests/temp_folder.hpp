#pragma once
// A fresh folder per test and per process: ctest runs programs in parallel, and some test
// programs run twice at once (viz under Xvfb and without a display), so a folder named after the
// test alone is shared between processes that remove each other's files.

#include <unistd.h>

#include <filesystem>
#include <string>

namespace vmsim::test {

/// An empty folder `vmsim_test_<name>_<pid>` under the system's temporary folder.
inline std::filesystem::path fresh_temp_folder(const std::string& name) {
  const std::filesystem::path folder = std::filesystem::temp_directory_path() /
                                       ("vmsim_test_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::remove_all(folder);
  std::filesystem::create_directories(folder);
  return folder;
}

}  // namespace vmsim::test

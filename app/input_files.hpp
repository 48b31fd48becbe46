#pragma once
// The input files a command read: an output must never replace or hold one of them
// (vmsim/common/output_folder.hpp).
#include <set>
#include <string>
#include <vector>

#include "chain_inputs.hpp"

namespace vmsim::app {

/// The part, machine and tool path files (every file the tool path reader read) of the chain
/// inputs, each once.
inline std::vector<std::string> chain_input_files(const ChainInputOptions& options, const ChainInputs& inputs) {
  std::set<std::string> files = {options.part_path, options.machine_path, options.toolpath_path,
                                 inputs.machine.source_file};
  for (const auto& block : inputs.toolpath.blocks) files.insert(block.file);
  files.erase("");
  return {files.begin(), files.end()};
}

}  // namespace vmsim::app

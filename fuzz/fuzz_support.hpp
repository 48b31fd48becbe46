#pragma once
// What every fuzz target shares (README, "Hostile testing"): a private folder for the files the
// readers open, the rule of what counts as an expected outcome, and the sample machine's direct
// kinematics for the tool path readers' callbacks.
//
// A target writes the fuzzer's bytes to a file with the extension the app uses and calls the
// library reader the app calls. vmsim's typed errors (InputError, InfeasibleError) are the
// expected outcome of bad input; any other exception escapes (libFuzzer reports it as a crash),
// and so do crashes, hangs (-timeout) and sanitizer reports.
#include <unistd.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <numbers>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "vmsim/common/errors.hpp"
#include "vmsim/kinematics/kinematics.hpp"
#include "vmsim/kinematics/machine_loader.hpp"
#include "vmsim/kinematics/machine_model.hpp"
#include "vmsim/toolpath/toolpath.hpp"

namespace vmsim::fuzz {

/// The repository root (samples/), compiled in.
inline std::string source_dir() { return VMSIM_SOURCE_DIR; }

/// A folder of this process, removed at exit: `vmsim_fuzz_<target>_<pid>` under TMPDIR.
inline const std::filesystem::path& work_folder(const char* target) {
  // Never destroyed: the exit handler below still needs it after static destructors ran.
  static const std::filesystem::path* folder = [target] {
    auto* path = new std::filesystem::path(std::filesystem::temp_directory_path() /
                                           (std::string("vmsim_fuzz_") + target + "_" +
                                            std::to_string(::getpid())));
    std::filesystem::remove_all(*path);
    std::filesystem::create_directories(*path);
    std::atexit([] {
      std::error_code ignored;
      std::filesystem::remove_all(*folder, ignored);
    });
    return path;
  }();
  return *folder;
}

/// Writes bytes to a file (created or truncated); aborts when it cannot (not a finding).
inline void write_bytes(const std::filesystem::path& path, const void* data, std::size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(static_cast<const char*>(data), static_cast<std::streamsize>(size));
  out.close();
  if (!out) {
    std::fprintf(stderr, "fuzz: cannot write %s\n", path.c_str());
    std::abort();
  }
}

inline std::string read_bytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) {
    std::fprintf(stderr, "fuzz: cannot read %s\n", path.c_str());
    std::abort();
  }
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

/// A law of the reader's output (what its header promises): when broken, says which and aborts,
/// a finding like a crash.
inline void require(bool holds, const char* law) {
  if (!holds) {
    std::fprintf(stderr, "fuzz: the reader's output breaks a law: %s\n", law);
    std::abort();
  }
}

/// Runs `read`; vmsim's typed errors are an expected outcome, anything else escapes.
template <typename Read>
void expect_only_typed_errors(Read&& read) {
  try {
    read();
  } catch (const InputError&) {
  } catch (const InfeasibleError&) {
  }
}

/// What every tool path a reader returns must satisfy (toolpath/toolpath.hpp): motion, finite
/// tips, unit axes, feeds finite and not negative, each point naming one of the blocks.
inline void check_toolpath(const toolpath::Toolpath& path) {
  require(!path.points.empty(), "a tool path has at least one point (else 'no motion')");
  for (const toolpath::PathPoint& point : path.points) {
    require(point.tip_W_m.allFinite(), "tool tip finite");
    require(point.axis_W.allFinite() && std::abs(point.axis_W.norm() - 1.0) < 1e-9,
            "tool axis unit");
    require(std::isfinite(point.feed_m_per_s) && point.feed_m_per_s >= 0.0, "feed finite, >= 0");
    require(std::isfinite(point.inverse_time_feed_per_s) && point.inverse_time_feed_per_s >= 0.0,
            "inverse-time feed finite, >= 0");
    require(point.block >= 0 && static_cast<std::size_t>(point.block) < path.blocks.size(),
            "point.block indexes Toolpath::blocks");
    require(std::isnan(point.corner_tolerance_m) ||
                (std::isfinite(point.corner_tolerance_m) && point.corner_tolerance_m >= 0.0),
            "corner tolerance NaN or finite, >= 0");
    require(point.tool_number >= -1, "tool number -1 (none) or a T number");
  }
  if (path.cutter_diameter_m) {
    require(std::isfinite(*path.cutter_diameter_m), "cutter diameter finite");
  }
  if (path.cutter_corner_radius_m) {
    require(std::isfinite(*path.cutter_corner_radius_m), "cutter corner radius finite");
  }
}

/// What every machine the loader returns must satisfy (kinematics/machine_model.hpp): finite
/// home positions, gravity and a positive period, chains of finite poses, unit joint directions
/// and finite bodies (travel may be unbounded on a continuous axis).
inline void check_machine(const kinematics::MachineModel& machine) {
  require(!machine.axes.empty(), "a machine has axes");
  require(machine.home_positions().allFinite(), "home positions finite");
  require(machine.gravity_B_m_per_s2.allFinite(), "gravity finite");
  require(std::isfinite(machine.interpolation_period_s) && machine.interpolation_period_s > 0.0,
          "interpolation period finite, > 0");
  for (const kinematics::Chain* chain : {&machine.workpiece_chain, &machine.tool_chain}) {
    for (const kinematics::Joint& joint : *chain) {
      require(joint.origin.matrix().allFinite(), "joint origin finite");
      require(joint.direction.allFinite() && std::abs(joint.direction.norm() - 1.0) < 1e-9,
              "joint direction unit");
      require(std::isfinite(joint.body.mass_kg) && joint.body.mass_kg >= 0.0,
              "body mass finite, >= 0");
      require(joint.body.com_m.allFinite() && joint.body.inertia_kg_m2.allFinite(),
              "body centre of mass and inertia finite");
    }
  }
}

/// Options for the tool path readers as app/chain_inputs.cpp builds them: the axis words go
/// through the direct kinematics of the Mikron UCP710 sample (X Y Z A C) with a 100 mm tool.
class SampleMachineReaderOptions {
 public:
  SampleMachineReaderOptions()
      : machine_(kinematics::load_machine(source_dir() + "/samples/machines/mikron_ucp710.yaml")) {
    // A G-code loop that never ends runs to ReaderOptions::max_executed_blocks (10 million
    // blocks: about 1 s in a release build, minutes under the sanitizers, which the fuzzer would
    // report as a hang); the limit itself is what the fuzzer checks, not how long it takes.
    options_.max_executed_blocks = 20'000;
    options_.rotary_words_to_tool_axis = [this](const auto& words) {
      return kinematics::forward_kinematics(machine_, axes_from_words(words), kToolLength_m).axis_W;
    };
    options_.axis_words_to_pose = [this](const auto& words) {
      const kinematics::ToolPose pose =
          kinematics::forward_kinematics(machine_, axes_from_words(words), kToolLength_m);
      return toolpath::AxisWordPose{pose.tip_W_m, pose.axis_W};
    };
    // As a part file's setup would (app/chain_inputs.cpp, apply_machine_setup): one tool length
    // for every H, and a few work offsets for the coordinate-system words to reach.
    options_.default_tool_length_mm = kToolLength_m * 1e3;
    options_.work_offsets_mm["G54"] = Eigen::Vector3d(0.0, 0.0, -400.0);
    options_.work_offsets_mm["G55"] = Eigen::Vector3d(-50.0, 20.0, -400.0);
    options_.work_offsets_mm["G54.1 P1"] = Eigen::Vector3d(10.0, 0.0, -450.0);
  }
  SampleMachineReaderOptions(const SampleMachineReaderOptions&) = delete;
  SampleMachineReaderOptions& operator=(const SampleMachineReaderOptions&) = delete;

  const toolpath::ReaderOptions& options() const { return options_; }

 private:
  static constexpr double kToolLength_m = 0.1;

  // As app/chain_inputs.cpp (axes_from_words): letters must name axes of the machine.
  Eigen::VectorXd axes_from_words(const std::vector<std::pair<char, double>>& words) const {
    Eigen::VectorXd q = machine_.home_positions();
    for (const auto& [letter, value] : words) {
      const int index = machine_.axis_index(std::string(1, letter));
      if (index < 0) throw InputError(std::string("axis word ") + letter + " names no axis");
      const auto& axis = machine_.axes[static_cast<std::size_t>(index)];
      q[index] = axis.type == kinematics::AxisType::linear ? value * 1e-3
                                                           : value * std::numbers::pi / 180.0;
    }
    return q;
  }

  kinematics::MachineModel machine_;
  toolpath::ReaderOptions options_;
};

}  // namespace vmsim::fuzz

// --out end to end: vmsim never deletes or overwrites what it did not write (the current folder,
// a file, the inputs' folder), refuses an unusable --out with exit 3 before the work, and
// replaces a previous result as a whole or not at all (a full disk leaves the old set intact).
#include <gtest/gtest.h>
#include <sys/mount.h>
#include <sys/statvfs.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "cli_runner.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/common/output_folder.hpp"

namespace vmsim {
namespace {
namespace fs = std::filesystem;

const std::string kRoot = VMSIM_SOURCE_DIR;
const std::string kMikron = kRoot + "/samples/machines/mikron_ucp710.yaml";
const std::string kPath = "FEDRAT/MMPM,1000\nGOTO/0,0,50\nGOTO/10,0,50\nGOTO/10,10,50\n";

void write(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

// Every name in `folder` with the content of each file ("<folder>" for a folder).
std::map<std::string, std::string> contents_of(const fs::path& folder) {
  std::map<std::string, std::string> contents;
  for (const auto& entry : fs::directory_iterator(folder)) {
    contents[entry.path().filename().string()] =
        entry.is_directory() ? std::string("<folder>") : read_file(entry.path().string());
  }
  return contents;
}

// `vmsim plan` on a 20 mm tool path in `path_file` (fast: second order, no plot).
std::string plan_arguments(const fs::path& path_file, const std::string& out, double feed_mm_per_min = 1000) {
  return "-q plan --machine " + kMikron + " --toolpath " + path_file.string() +
         " --tool-length-mm 100 --no-third-order --no-plot --feed-mm-per-min " + format_double(feed_mm_per_min) +
         " --out " + out;
}

// A folder of inputs outside the folder under test.
fs::path inputs_folder(const fs::path& folder) {
  fs::create_directories(folder / "inputs");
  write(folder / "inputs" / "path.apt", kPath);
  return folder / "inputs";
}

void expect_refused(const test::RunResult& run, const std::string& message) {
  EXPECT_EQ(run.exit_code, 3) << run.output;
  EXPECT_NE(run.output.find(message), std::string::npos) << run.output;
  EXPECT_EQ(run.output.find("internal error"), std::string::npos) << run.output;
}

TEST(CliOutput, OutDotInAFolderOfUserFilesIsRefusedAndNothingIsWritten) {
  const fs::path folder = test::fresh_folder("output_dot");
  const fs::path inputs = inputs_folder(folder);
  fs::create_directories(folder / "work");
  write(folder / "work" / "notes.txt", "my notes");
  const auto before = contents_of(folder / "work");
  const test::RunResult run =
      test::run_vmsim_with_env("cd " + (folder / "work").string() + " &&", plan_arguments(inputs / "path.apt", "."));
  expect_refused(run, "holds no vmsim result");
  EXPECT_EQ(contents_of(folder / "work"), before);
  EXPECT_EQ(contents_of(folder).size(), 2u);  // inputs, work: no staging folder left
}

// The case: simulate-part --out . in the folder of the part deleted the part.
TEST(CliOutput, SimulatePartNeverDeletesThePartsFolderOrAFile) {
  const fs::path folder = test::fresh_folder("output_simulate_part");
  // The first pass of sample part 1 on a strip of stock (small: the refusal comes before the
  // work, and on the old code the run was quick).
  std::istringstream apt(read_file(kRoot + "/samples/parts/part1_tangency/toolpath.apt"));
  std::ostringstream path;
  int rapids = 0;
  for (std::string line; std::getline(apt, line);) {
    if (line == "RAPID" && ++rapids > 2) break;
    path << line << '\n';
  }
  write(folder / "toolpath.apt", path.str() + "FINI\n");
  write(folder / "part.yaml", "name: one_pass\nmachine: " + kMikron +
                                  "\ntoolpath: toolpath.apt\n"
                                  "tool: {type: ball, diameter_mm: 10, corner_radius_mm: 5, length_mm: 60}\n"
                                  "stock: {box: {min_mm: [-12, -5, 0], max_mm: [16, -4.5, 40]}}\n"
                                  "feeds: {production_mm_per_min: 10000, reference_mm_per_min: 100}\n");
  write(folder / "notes.txt", "my notes");
  const auto before = contents_of(folder);
  const std::string common = "-q simulate-part --part part.yaml --no-renders --grid-um 200 --out ";
  const std::string cd = "cd " + folder.string() + " &&";
  expect_refused(test::run_vmsim_with_env(cd, common + "."), "holds the input file part.yaml");
  EXPECT_EQ(contents_of(folder), before);
  expect_refused(test::run_vmsim_with_env(cd, common + folder.string()), "holds the input file");
  EXPECT_EQ(contents_of(folder), before);
  expect_refused(test::run_vmsim_with_env(cd, common + "part.yaml"), "is not a folder");
  EXPECT_EQ(contents_of(folder), before);
  expect_refused(test::run_vmsim_with_env(cd, common + "notes.txt"), "is not a folder");
  EXPECT_EQ(contents_of(folder), before);
}

TEST(CliOutput, AnExistingFileIsNotAnOutputFolder) {
  const fs::path folder = test::fresh_folder("output_existing_file");
  const fs::path inputs = inputs_folder(folder);
  write(folder / "notes.txt", "my notes");
  expect_refused(test::run_vmsim(plan_arguments(inputs / "path.apt", (folder / "notes.txt").string())),
                 "is not a folder");
  EXPECT_EQ(read_file((folder / "notes.txt").string()), "my notes");
}

TEST(CliOutput, TheInputsFolderIsRefusedEvenWhenItHoldsAPreviousResult) {
  const fs::path folder = test::fresh_folder("output_inputs_folder");
  const fs::path inputs = inputs_folder(folder);
  const auto before = contents_of(inputs);
  expect_refused(test::run_vmsim(plan_arguments(inputs / "path.apt", inputs.string())),
                 "holds the input file " + (inputs / "path.apt").string());
  EXPECT_EQ(contents_of(inputs), before);
  // A previous result with an input put into it: the swap would delete the input.
  const fs::path out = folder / "out";
  ASSERT_EQ(test::run_vmsim(plan_arguments(inputs / "path.apt", out.string())).exit_code, 0);
  fs::copy_file(inputs / "path.apt", out / "path.apt");
  expect_refused(test::run_vmsim(plan_arguments(out / "path.apt", out.string())), "holds the input file");
  EXPECT_EQ(read_file((out / "path.apt").string()), kPath);
}

TEST(CliOutput, APreviousResultIsReplacedAsAWhole) {
  const fs::path folder = test::fresh_folder("output_replace");
  const fs::path inputs = inputs_folder(folder);
  const fs::path out = folder / "out";
  ASSERT_EQ(test::run_vmsim(plan_arguments(inputs / "path.apt", out.string(), 1000)).exit_code, 0);
  EXPECT_NE(read_file((out / kResultMarkerFile).string()).find("vmsim plan"), std::string::npos);
  write(out / "from_an_older_run.csv", "old");
  const double old_duration = nlohmann::json::parse(read_file((out / "summary.json").string()))["duration_s"];
  const test::RunResult run = test::run_vmsim(plan_arguments(inputs / "path.apt", out.string(), 500));
  ASSERT_EQ(run.exit_code, 0) << run.output;
  const double new_duration = nlohmann::json::parse(read_file((out / "summary.json").string()))["duration_s"];
  EXPECT_GT(new_duration, 1.5 * old_duration);
  std::set<std::string> names;
  for (const auto& [name, content] : contents_of(out)) names.insert(name);
  EXPECT_EQ(names, (std::set<std::string>{kResultMarkerFile, "limits.csv", "setpoints.csv", "summary.json"}));
  EXPECT_EQ(contents_of(folder).size(), 2u);  // inputs, out: no staging or old set left beside
}

// A job larger than the memory the process may have (here an address-space limit of 1.5 GB
// against part 1 at a 2 um grid, 2e8 Z-map lines) is exit 6 with what to do, not an
// "internal error", and the previous result in the output folder is left as it was.
TEST(CliOutput, RunningOutOfMemoryIsExit6AndLeavesThePreviousResult) {
  const fs::path folder = test::fresh_folder("output_out_of_memory");
  const fs::path inputs = inputs_folder(folder);
  const fs::path out = folder / "out";
  ASSERT_EQ(test::run_vmsim(plan_arguments(inputs / "path.apt", out.string())).exit_code, 0);
  const auto before = contents_of(out);
  const test::RunResult run = test::run_vmsim_with_env(
      "ulimit -v 1500000;", "-q simulate-part --part " + kRoot + "/samples/parts/part1_tangency/part.yaml --out " +
                                out.string() + " --grid-um 2 --no-renders");
  EXPECT_EQ(run.exit_code, 6) << run.output;
  EXPECT_NE(run.output.find("out of memory"), std::string::npos) << run.output;
  EXPECT_NE(run.output.find("--grid-um"), std::string::npos) << run.output;
  EXPECT_EQ(run.output.find("internal error"), std::string::npos) << run.output;
  EXPECT_EQ(contents_of(out), before);
  EXPECT_EQ(contents_of(folder).size(), 2u);  // inputs, out: no staging folder left beside
}

TEST(CliOutput, AnUnwritablePlaceIsExit3WithTheReason) {
  const fs::path folder = test::fresh_folder("output_unwritable");
  const fs::path inputs = inputs_folder(folder);
  write(folder / "notes.txt", "my notes");
  // A parent that is a regular file (ENOTDIR): folder outputs and single files.
  expect_refused(test::run_vmsim(plan_arguments(inputs / "path.apt", (folder / "notes.txt" / "out").string())),
                 "ot a directory");
  expect_refused(test::run_vmsim("kinematics --machine " + kMikron + " --toolpath " + (inputs / "path.apt").string() +
                                 " --tool-length-mm 100 --out " + (folder / "notes.txt" / "k.csv").string()),
                 "ot a directory");
  EXPECT_EQ(read_file((folder / "notes.txt").string()), "my notes");

  // A read-only file system (root writes through permissions, not through a read-only mount).
  if (::geteuid() != 0) GTEST_SKIP() << "a read-only bind mount needs root";
  fs::create_directories(folder / "ro");
  if (::mount((folder / "ro").c_str(), (folder / "ro").c_str(), nullptr, MS_BIND, nullptr) != 0) {
    GTEST_SKIP() << "cannot bind-mount here (no CAP_SYS_ADMIN?)";
  }
  const bool read_only = ::mount(nullptr, (folder / "ro").c_str(), nullptr, MS_REMOUNT | MS_BIND | MS_RDONLY, nullptr) == 0;
  const test::RunResult plan = test::run_vmsim(plan_arguments(inputs / "path.apt", (folder / "ro" / "out").string()));
  const test::RunResult kinematics =
      test::run_vmsim("kinematics --machine " + kMikron + " --toolpath " + (inputs / "path.apt").string() +
                      " --tool-length-mm 100 --out " + (folder / "ro" / "k.csv").string());
  ::umount2((folder / "ro").c_str(), MNT_DETACH);
  if (!read_only) GTEST_SKIP() << "cannot remount the bind mount read-only";
  expect_refused(plan, "ead-only file system");
  expect_refused(kinematics, "ead-only file system");
}

// A full disk while the new set is written: exit 3, the previous result intact; once there is
// space, the set is replaced whole.
TEST(CliOutput, AFullDiskLeavesThePreviousResultIntact) {
  if (::geteuid() != 0) GTEST_SKIP() << "mounting a small tmpfs needs root";
  const fs::path folder = test::fresh_folder("output_full_disk");
  const fs::path inputs = inputs_folder(folder);
  const fs::path disk = folder / "disk";
  fs::create_directories(disk);
  if (::mount("tmpfs", disk.c_str(), "tmpfs", 0, "size=4m") != 0) GTEST_SKIP() << "cannot mount a tmpfs here";
  struct Unmount {
    fs::path path;
    ~Unmount() { ::umount2(path.c_str(), MNT_DETACH); }
  } unmount{disk};

  const fs::path out = disk / "out";
  ASSERT_EQ(test::run_vmsim(plan_arguments(inputs / "path.apt", out.string(), 1000)).exit_code, 0);
  const auto old_result = contents_of(out);
  // Fill the disk to within a page.
  struct statvfs space {};
  ASSERT_EQ(::statvfs(disk.c_str(), &space), 0);
  const std::size_t free_bytes = space.f_bavail * space.f_frsize;
  ASSERT_GT(free_bytes, 8192u);
  write(disk / "filler", std::string(free_bytes - 4096, 'x'));

  const test::RunResult full = test::run_vmsim(plan_arguments(inputs / "path.apt", out.string(), 500));
  expect_refused(full, (disk / ".out.vmsim-staging-").string());
  EXPECT_EQ(contents_of(out), old_result);
  EXPECT_EQ(contents_of(disk).size(), 2u);  // out, filler: no staging folder left

  fs::remove(disk / "filler");
  ASSERT_EQ(test::run_vmsim(plan_arguments(inputs / "path.apt", out.string(), 500)).exit_code, 0);
  EXPECT_NE(contents_of(out).at("summary.json"), old_result.at("summary.json"));
  EXPECT_EQ(contents_of(disk).size(), 1u);
}

// kinematics --out F --summary S: both or neither; an input is never an output; a previous
// output file of the same name is replaced.
TEST(CliOutput, KinematicsWritesItsTwoFilesTogetherAndNeverOverAnInput) {
  const fs::path folder = test::fresh_folder("output_kinematics");
  const fs::path inputs = inputs_folder(folder);
  const std::string arguments = "-q kinematics --machine " + kMikron + " --toolpath " + (inputs / "path.apt").string() +
                                " --tool-length-mm 100 --out ";
  const std::string k = (folder / "k.csv").string();
  expect_refused(test::run_vmsim(arguments + k + " --summary " + (folder / "missing" / "s.json").string()),
                 "does not exist");
  EXPECT_FALSE(fs::exists(k));
  expect_refused(test::run_vmsim(arguments + k + " --summary " + k), "named twice");
  EXPECT_FALSE(fs::exists(k));
  expect_refused(test::run_vmsim(arguments + (inputs / "path.apt").string()), "is an input file");
  EXPECT_EQ(read_file((inputs / "path.apt").string()), kPath);
  expect_refused(test::run_vmsim(arguments + folder.string()), "is a folder");

  const std::string summary = " --summary " + (folder / "s.json").string();
  ASSERT_EQ(test::run_vmsim(arguments + k + summary).exit_code, 0);
  ASSERT_EQ(test::run_vmsim(arguments + k + summary).exit_code, 0);  // its own previous output
  EXPECT_TRUE(fs::exists(folder / "s.json"));
  std::set<std::string> names;
  for (const auto& [name, content] : contents_of(folder)) names.insert(name);
  EXPECT_EQ(names, (std::set<std::string>{"inputs", "k.csv", "s.json"}));  // no temporary file left
}

// A tool path whose file name is not UTF-8 (Latin-1 "pé.apt"): the summaries name its blocks.
// kinematics --summary used to fail after writing the trace (exit 1, the trace left alone).
TEST(CliOutput, NamesThatAreNotUtf8DoNotFailTheSummariesAfterTheWork) {
  const fs::path folder = test::fresh_folder("output_latin1");
  const fs::path path_file = folder / "p\xe9.apt";
  write(path_file, kPath);
  const std::string k = (folder / "k.csv").string(), s = (folder / "s.json").string();
  const test::RunResult kinematics =
      test::run_vmsim("-q kinematics --machine " + kMikron + " --toolpath " + path_file.string() +
                      " --tool-length-mm 100 --out " + k + " --summary " + s);
  EXPECT_EQ(kinematics.exit_code, 0) << kinematics.output;
  EXPECT_TRUE(fs::exists(k));
  EXPECT_TRUE(fs::exists(s));
  const test::RunResult plan = test::run_vmsim(plan_arguments(path_file, (folder / "plan").string()));
  EXPECT_EQ(plan.exit_code, 0) << plan.output;
  EXPECT_TRUE(fs::exists(folder / "plan" / "summary.json"));
}

}  // namespace
}  // namespace vmsim

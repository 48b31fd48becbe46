// Output folders and files (vmsim/common/output_folder.hpp): a result set is swapped in whole or
// not at all, only over an empty folder or a previous result (the marker), never over a folder
// holding an input; staging folders are removed on a signal and, when a process was killed,
// by the next run.
#include "vmsim/common/output_folder.hpp"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <filesystem>
#include <fstream>
#include <set>

#include "../temp_folder.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim {
namespace {
namespace fs = std::filesystem;

const ResultOrigin kOrigin{"test", "0"};

void write_text(const fs::path& path, const std::string& text) { std::ofstream(path) << text; }

// The names in `folder` (hidden ones included).
std::set<std::string> names_in(const fs::path& folder) {
  std::set<std::string> names;
  for (const auto& entry : fs::directory_iterator(folder)) names.insert(entry.path().filename().string());
  return names;
}

// Writes a result with the given files (name -> content) into `target`.
void write_result(const fs::path& target, const std::vector<std::pair<std::string, std::string>>& files) {
  OutputFolder output(target.string(), {}, kOrigin);
  for (const auto& [name, content] : files) write_file_atomically(output.path_of(name), content);
  output.commit();
}

// The message of the InputError `action` throws ("" and a test failure when it throws none).
template <class Action>
std::string input_error_of(Action action) {
  try {
    action();
  } catch (const InputError& error) {
    return error.what();
  }
  ADD_FAILURE() << "no InputError";
  return "";
}

TEST(OutputFolder, ANewTargetGetsTheFilesAndTheMarkerAndNoStagingIsLeft) {
  const fs::path folder = test::fresh_temp_folder("output_new");
  write_result(folder / "out", {{"a.txt", "new a"}});
  EXPECT_EQ(names_in(folder / "out"), (std::set<std::string>{"a.txt", kResultMarkerFile}));
  EXPECT_EQ(read_file((folder / "out" / "a.txt").string()), "new a");
  EXPECT_NE(read_file((folder / "out" / kResultMarkerFile).string()).find("vmsim test"), std::string::npos);
  EXPECT_EQ(names_in(folder), std::set<std::string>{"out"});
}

TEST(OutputFolder, MissingParentFoldersAreCreated) {
  const fs::path folder = test::fresh_temp_folder("output_parents");
  write_result(folder / "a" / "b" / "out", {{"a.txt", "a"}});
  EXPECT_TRUE(fs::exists(folder / "a" / "b" / "out" / "a.txt"));
}

TEST(OutputFolder, APreviousResultIsReplacedAsAWhole) {
  const fs::path folder = test::fresh_temp_folder("output_replace");
  write_result(folder / "out", {{"a.txt", "old a"}, {"b.txt", "old b"}});
  write_result(folder / "out", {{"a.txt", "new a"}});
  EXPECT_EQ(names_in(folder / "out"), (std::set<std::string>{"a.txt", kResultMarkerFile}));
  EXPECT_EQ(read_file((folder / "out" / "a.txt").string()), "new a");
  EXPECT_EQ(names_in(folder), std::set<std::string>{"out"});  // the old set removed
}

TEST(OutputFolder, AnEmptyFolderIsUsed) {
  const fs::path folder = test::fresh_temp_folder("output_empty");
  fs::create_directory(folder / "out");
  write_result(folder / "out", {{"a.txt", "a"}});
  EXPECT_TRUE(fs::exists(folder / "out" / "a.txt"));
}

TEST(OutputFolder, WithoutCommitTheOldSetStaysIntactAndTheStagingIsRemoved) {
  const fs::path folder = test::fresh_temp_folder("output_abandon");
  write_result(folder / "out", {{"a.txt", "old a"}, {"b.txt", "old b"}});
  try {
    OutputFolder output((folder / "out").string(), {}, kOrigin);
    write_file_atomically(output.path_of("a.txt"), "new a");
    EXPECT_EQ(names_in(folder).size(), 2u);  // out and the staging folder
    throw InputError("a write failed half-way");
  } catch (const InputError&) {
  }
  EXPECT_EQ(names_in(folder / "out"), (std::set<std::string>{"a.txt", "b.txt", kResultMarkerFile}));
  EXPECT_EQ(read_file((folder / "out" / "a.txt").string()), "old a");
  EXPECT_EQ(names_in(folder), std::set<std::string>{"out"});
}

TEST(OutputFolder, AFolderWithoutTheMarkerIsRefusedAndLeftAlone) {
  const fs::path folder = test::fresh_temp_folder("output_foreign");
  fs::create_directory(folder / "mine");
  write_text(folder / "mine" / "notes.txt", "my notes");
  const std::string message = input_error_of([&] { OutputFolder((folder / "mine").string(), {}, kOrigin); });
  EXPECT_NE(message.find((folder / "mine").string()), std::string::npos) << message;
  EXPECT_NE(message.find("holds no vmsim result"), std::string::npos) << message;
  EXPECT_NE(message.find("give a new or empty folder"), std::string::npos) << message;
  EXPECT_EQ(read_file((folder / "mine" / "notes.txt").string()), "my notes");
  EXPECT_EQ(names_in(folder), std::set<std::string>{"mine"});  // no staging made
}

TEST(OutputFolder, AnExistingFileIsRefusedAndLeftAlone) {
  const fs::path folder = test::fresh_temp_folder("output_file");
  write_text(folder / "notes.txt", "my notes");
  const std::string message = input_error_of([&] { OutputFolder((folder / "notes.txt").string(), {}, kOrigin); });
  EXPECT_NE(message.find("is not a folder"), std::string::npos) << message;
  EXPECT_EQ(read_file((folder / "notes.txt").string()), "my notes");
}

TEST(OutputFolder, AFolderHoldingAnInputIsRefusedEvenWithTheMarker) {
  const fs::path folder = test::fresh_temp_folder("output_inputs");
  write_result(folder / "out", {{"a.txt", "a"}});
  write_text(folder / "out" / "part.yaml", "name: x");
  write_text(folder / "path.apt", "FINI");
  // the input inside a previous result, and the inputs' own folder (and one above it)
  const std::vector<std::pair<fs::path, fs::path>> cases = {
      {folder / "out", folder / "out" / "part.yaml"}, {folder, folder / "path.apt"}, {folder.parent_path(), folder / "path.apt"}};
  for (const auto& target_and_input : cases) {
    const fs::path& target = target_and_input.first;  // (clang 14 cannot capture structured bindings)
    const fs::path& input = target_and_input.second;
    SCOPED_TRACE(target.string());
    const std::string message = input_error_of([&] { OutputFolder(target.string(), {input.string()}, kOrigin); });
    EXPECT_NE(message.find("holds the input file " + input.string()), std::string::npos) << message;
  }
  EXPECT_TRUE(fs::exists(folder / "out" / "part.yaml"));
  EXPECT_TRUE(fs::exists(folder / "path.apt"));
}

TEST(OutputFolder, AParentThatIsAFileIsAnInputErrorWithTheReason) {
  const fs::path folder = test::fresh_temp_folder("output_notdir");
  write_text(folder / "notes.txt", "my notes");
  const std::string message = input_error_of([&] { OutputFolder((folder / "notes.txt" / "out").string(), {}, kOrigin); });
  EXPECT_NE(message.find("otes.txt"), std::string::npos) << message;
  EXPECT_NE(message.find("ot a directory"), std::string::npos) << message;
  EXPECT_EQ(read_file((folder / "notes.txt").string()), "my notes");
}

TEST(OutputFolder, FilesPutIntoTheTargetDuringTheRunStopTheSwap) {
  const fs::path folder = test::fresh_temp_folder("output_race");
  fs::create_directory(folder / "out");
  OutputFolder output((folder / "out").string(), {}, kOrigin);
  write_file_atomically(output.path_of("a.txt"), "new a");
  write_text(folder / "out" / "notes.txt", "put there meanwhile");
  const std::string message = input_error_of([&] { output.commit(); });
  EXPECT_NE(message.find("holds no vmsim result"), std::string::npos) << message;
  EXPECT_EQ(names_in(folder / "out"), std::set<std::string>{"notes.txt"});
}

// A process killed with SIGKILL leaves its staging folder: the next run beside the same target
// removes it, and leaves those of processes still alive.
TEST(OutputFolder, StagingFoldersOfDeadProcessesAreRemovedByTheNextRun) {
  const fs::path folder = test::fresh_temp_folder("output_stale");
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ASSERT_GT(child, 0);
  ::waitpid(child, nullptr, 0);  // dead now
  const fs::path dead = folder / (".out.vmsim-staging-" + std::to_string(child));
  const fs::path alive = folder / (".out.vmsim-staging-" + std::to_string(::getppid()));
  const fs::path other = folder / (".other.vmsim-staging-" + std::to_string(child));
  for (const fs::path& staging : {dead, alive, other}) {
    fs::create_directory(staging);
    write_text(staging / ".vmsim-staging", "");  // as OutputFolder makes them
    write_text(staging / "a.txt", "half");
  }
  write_result(folder / "out", {{"a.txt", "a"}});
  EXPECT_FALSE(fs::exists(dead));
  EXPECT_TRUE(fs::exists(alive / "a.txt"));
  EXPECT_TRUE(fs::exists(other / "a.txt"));  // another target's
}

// A folder of the staging name that vmsim did not make (no staging or result marker) is the
// user's: never removed, even when its "pid" is dead or is this process's.
TEST(OutputFolder, AFolderWithAStagingNameThatIsNotVmsimsStays) {
  const fs::path folder = test::fresh_temp_folder("output_foreign_staging");
  const pid_t child = ::fork();
  if (child == 0) ::_exit(0);
  ASSERT_GT(child, 0);
  ::waitpid(child, nullptr, 0);
  const fs::path dead = folder / (".out.vmsim-staging-" + std::to_string(child));
  fs::create_directory(dead);
  write_text(dead / "mine.txt", "the user's");
  write_result(folder / "out", {{"a.txt", "a"}});
  EXPECT_TRUE(fs::exists(dead / "mine.txt"));
  // The result holds no staging marker.
  EXPECT_FALSE(fs::exists(folder / "out" / ".vmsim-staging"));
}

// SIGTERM while the results are being written: the staging folder goes, the process ends by
// the signal, the previous result stays.
TEST(OutputFolder, ASignalRemovesTheStagingFolderAndEndsTheProcess) {
  const fs::path folder = test::fresh_temp_folder("output_signal");
  write_result(folder / "out", {{"a.txt", "old a"}});
  int tested = 0;
  for (int signal_number : {SIGTERM, SIGINT, SIGHUP}) {
    SCOPED_TRACE(signal_number);
    // A signal this process inherited as ignored (nohup; SIGINT in a background job of a shell
    // without job control) is left ignored by vmsim on purpose: nothing to test for it here.
    struct sigaction inherited {};
    ASSERT_EQ(::sigaction(signal_number, nullptr, &inherited), 0);
    if (inherited.sa_handler == SIG_IGN) continue;
    ++tested;
    const pid_t child = ::fork();
    if (child == 0) {
      OutputFolder output((folder / "out").string(), {}, kOrigin);
      write_file_atomically(output.path_of("a.txt"), "new a");
      fs::create_directory(output.staging() / "sub");
      write_file_atomically((output.staging() / "sub" / "b.txt").string(), "new b");
      ::raise(signal_number);
      ::_exit(0);  // not reached
    }
    ASSERT_GT(child, 0);
    int status = 0;
    ::waitpid(child, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status)) << status;
    EXPECT_EQ(WTERMSIG(status), signal_number);
    EXPECT_EQ(names_in(folder), std::set<std::string>{"out"});
    EXPECT_EQ(read_file((folder / "out" / "a.txt").string()), "old a");
  }
  EXPECT_GT(tested, 0) << "every signal was inherited as ignored";
}

TEST(CheckOutputFile, RefusesAFolderAnInputAMissingFolderAndAcceptsAPreviousOutput) {
  const fs::path folder = test::fresh_temp_folder("output_check_file");
  write_text(folder / "in.csv", "t\n0\n");
  fs::create_hard_link(folder / "in.csv", folder / "same.csv");
  EXPECT_NE(input_error_of([&] { check_output_file(folder.string(), {}); }).find("is a folder"), std::string::npos);
  EXPECT_NE(input_error_of([&] { check_output_file((folder / "same.csv").string(), {(folder / "in.csv").string()}); })
                .find("is an input file"),
            std::string::npos);
  EXPECT_NE(input_error_of([&] { check_output_file((folder / "no" / "out.csv").string(), {}); }).find("does not exist"),
            std::string::npos);
  EXPECT_NE(input_error_of([&] { check_output_file((folder / "in.csv" / "out.csv").string(), {}); }).find("ot a directory"),
            std::string::npos);
  write_text(folder / "out.csv", "previous");
  EXPECT_NO_THROW(check_output_file((folder / "out.csv").string(), {(folder / "in.csv").string()}));
  EXPECT_EQ(names_in(folder), (std::set<std::string>{"in.csv", "same.csv", "out.csv"}));  // no probe left
}

TEST(OutputFileSet, BothFilesAreReplacedTogetherOrNeither) {
  const fs::path folder = test::fresh_temp_folder("output_file_set");
  const std::string k = (folder / "k.csv").string(), s = (folder / "s.json").string();
  write_text(k, "old k");
  write_text(s, "old s");
  {
    OutputFileSet set({k, s}, {});
    set.write(k, "new k");
    // the summary never written (its computation failed): commit refuses, nothing replaced
    EXPECT_NE(input_error_of([&] { set.commit(); }).find("was not written"), std::string::npos);
  }
  EXPECT_EQ(read_file(k), "old k");
  EXPECT_EQ(read_file(s), "old s");
  EXPECT_EQ(names_in(folder), (std::set<std::string>{"k.csv", "s.json"}));
  {
    OutputFileSet set({k, s}, {});
    set.write(k, "new k");
    set.write(s, "new s");
    set.commit();
  }
  EXPECT_EQ(read_file(k), "new k");
  EXPECT_EQ(read_file(s), "new s");
  EXPECT_EQ(names_in(folder), (std::set<std::string>{"k.csv", "s.json"}));
  EXPECT_NE(input_error_of([&] { OutputFileSet({k, k}, {}); }).find("named twice"), std::string::npos);
}

}  // namespace
}  // namespace vmsim

// Input files that are not files (a FIFO, a device, a folder) and byte-order marks: every reader
// goes through read_file, which refuses the first promptly, and skips the second.
#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "../temp_folder.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/common/trace.hpp"

namespace vmsim {
namespace {

std::string read_error_of(const std::string& path) {
  try {
    read_file(path);
  } catch (const InputError& error) {
    return error.what();
  }
  return "";
}

TEST(InputFiles, FifoIsRefusedWithoutWaitingForAWriter) {
  const auto folder = test::fresh_temp_folder("read_fifo");
  const std::string fifo = (folder / "input.csv").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  const std::string error = read_error_of(fifo);
  EXPECT_NE(error.find(fifo), std::string::npos) << error;
  EXPECT_NE(error.find("FIFO"), std::string::npos) << error;
}

TEST(InputFiles, DeviceIsRefusedInsteadOfReadForEver) {
  const std::string error = read_error_of("/dev/zero");
  EXPECT_NE(error.find("/dev/zero: is a character device, not a regular file"), std::string::npos)
      << error;
}

TEST(InputFiles, FolderIsRefused) {
  const auto folder = test::fresh_temp_folder("read_folder");
  const std::string error = read_error_of(folder.string());
  EXPECT_NE(error.find("not a regular file"), std::string::npos) << error;
}

TEST(InputFiles, TraceThatIsAFifoIsRefused) {
  const auto folder = test::fresh_temp_folder("trace_fifo");
  const std::string fifo = (folder / "run.csv").string();
  ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
  EXPECT_THROW(read_trace(fifo), InputError);
}

TEST(InputFiles, TraceWithAByteOrderMarkReadsAsWithout) {
  const std::string text = "t,X.cmd\n0,1\n0.001,2\n";
  const Trace plain = parse_trace(text, "run.csv");
  const Trace marked = parse_trace("\xEF\xBB\xBF" + text, "run.csv");
  EXPECT_EQ(marked.columns, plain.columns);
  EXPECT_EQ(marked.values, plain.values);
}

TEST(InputFiles, TraceWithAByteOrderMarkBeforeAComment) {
  const Trace marked = parse_trace("\xEF\xBB\xBF# source: sheet\nt,X.cmd\n0,1\n", "run.csv");
  ASSERT_EQ(marked.metadata.size(), 1u);
  EXPECT_EQ(marked.metadata[0].first, "source");
}

}  // namespace
}  // namespace vmsim

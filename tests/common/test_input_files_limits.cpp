// read_file's size cap and strip_utf8_bom (functions added with the input checks).
#include <gtest/gtest.h>

#include <fstream>
#include <string>

#include "../temp_folder.hpp"
#include "vmsim/common/errors.hpp"
#include "vmsim/common/files.hpp"

namespace vmsim {
namespace {

TEST(InputFileLimits, FileOverTheCapIsRefusedNamingIt) {
  const auto folder = test::fresh_temp_folder("read_cap");
  const std::string path = (folder / "big.csv").string();
  std::ofstream(path) << std::string(1000, 'x');
  EXPECT_EQ(read_file(path, 1000).size(), 1000u);
  try {
    read_file(path, 999);
    FAIL() << "the cap was not applied";
  } catch (const InputError& error) {
    EXPECT_NE(std::string(error.what()).find(path + ": the file is too large"), std::string::npos)
        << error.what();
  }
}

TEST(InputFileLimits, ProcFilesOfSizeZeroAreReadToTheEnd) {
  EXPECT_FALSE(read_file("/proc/self/status").empty());
}

TEST(InputFileLimits, StripUtf8BomRemovesOnlyALeadingMark) {
  EXPECT_EQ(strip_utf8_bom("\xEF\xBB\xBFt,X.cmd"), "t,X.cmd");
  EXPECT_EQ(strip_utf8_bom("t,X.cmd"), "t,X.cmd");
  EXPECT_EQ(strip_utf8_bom("a\xEF\xBB\xBF"), "a\xEF\xBB\xBF");
  EXPECT_EQ(strip_utf8_bom("\xEF\xBB"), "\xEF\xBB");
}

}  // namespace
}  // namespace vmsim

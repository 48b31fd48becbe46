// write_file_atomically's streamed form: the file is the pieces written, or absent (with no
// temporary left) when the writer throws.
#include <gtest/gtest.h>

#include <filesystem>
#include <ostream>
#include <stdexcept>
#include <string>

#include "../temp_folder.hpp"
#include "vmsim/common/files.hpp"
#include "vmsim/common/streamed_file.hpp"

namespace vmsim {
namespace {

TEST(StreamedFile, HoldsThePiecesInOrder) {
  const auto folder = test::fresh_temp_folder("streamed_file");
  const std::string path = (folder / "out.bin").string();
  write_file_atomically(path, [](std::ostream& out) {
    for (int k = 0; k < 1000; ++k) out << k << ';';
  });
  std::string expected;
  for (int k = 0; k < 1000; ++k) expected += std::to_string(k) + ';';
  EXPECT_EQ(read_file(path), expected);
}

TEST(StreamedFile, AWriterThatThrowsLeavesNothing) {
  const auto folder = test::fresh_temp_folder("streamed_file_throw");
  const std::string path = (folder / "out.bin").string();
  EXPECT_THROW(write_file_atomically(path,
                                     [](std::ostream& out) {
                                       out << "half";
                                       throw std::runtime_error("stopped");
                                     }),
               std::runtime_error);
  EXPECT_TRUE(std::filesystem::is_empty(folder));
}

}  // namespace
}  // namespace vmsim

#include "vmsim/common/files.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <charconv>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <system_error>

#include "vmsim/common/errors.hpp"
#include "vmsim/common/streamed_file.hpp"

namespace vmsim {

void write_file_atomically(const std::string& path, const std::string& content) {
  write_file_atomically(path, [&content](std::ostream& out) { out << content; });
}

void write_file_atomically(const std::string& path, const std::function<void(std::ostream&)>& write) {
  const std::string temporary = path + ".tmp-" + std::to_string(::getpid());
  {
    std::ofstream out(temporary, std::ios::binary | std::ios::trunc);
    if (!out) throw InputError(path + ": cannot write (does the folder exist and is it writable?)");
    try {
      write(out);
    } catch (...) {
      out.close();
      std::remove(temporary.c_str());
      throw;
    }
    out.flush();
    if (!out) {
      out.close();
      std::remove(temporary.c_str());
      throw InputError(path + ": writing failed (disk full?)");
    }
  }
  std::error_code error;
  std::filesystem::rename(temporary, path, error);
  if (error) {
    std::remove(temporary.c_str());
    throw InputError(path + ": cannot rename the finished file into place: " + error.message());
  }
}

namespace {

std::string file_kind(mode_t mode) {
  if (S_ISDIR(mode)) return "a folder";
  if (S_ISFIFO(mode)) return "a FIFO (named pipe)";
  if (S_ISCHR(mode)) return "a character device";
  if (S_ISBLK(mode)) return "a block device";
  if (S_ISSOCK(mode)) return "a socket";
  return "not a regular file";
}

}  // namespace

std::string read_file(const std::string& path, std::uint64_t size_limit_bytes) {
  // Opened without blocking and checked on the open descriptor (no race with a stat of the
  // path): opening a FIFO for reading would otherwise wait for a writer for ever.
  const int descriptor = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
  if (descriptor < 0) {
    throw InputError(path + ": cannot open the file (" + std::strerror(errno) + ")");
  }
  struct Closer {
    int descriptor;
    ~Closer() { ::close(descriptor); }
  } closer{descriptor};
  struct stat status {};
  if (::fstat(descriptor, &status) != 0) {
    throw InputError(path + ": cannot read the file's status (" + std::strerror(errno) + ")");
  }
  if (!S_ISREG(status.st_mode)) {
    throw InputError(path + ": is " + file_kind(status.st_mode) +
                     ", not a regular file; vmsim reads its inputs from regular files only");
  }
  const auto too_large = [&](std::uint64_t size_bytes) {
    return InputError(path + ": the file is too large (" + std::to_string(size_bytes) +
                      " bytes or more; at most " + std::to_string(size_limit_bytes) +
                      " bytes are read)");
  };
  if (static_cast<std::uint64_t>(status.st_size) > size_limit_bytes) {
    throw too_large(static_cast<std::uint64_t>(status.st_size));
  }
  // Regular files never block; clear the flag anyway so that reads behave as usual.
  ::fcntl(descriptor, F_SETFL, ::fcntl(descriptor, F_GETFL) & ~O_NONBLOCK);
  std::string content;
  content.reserve(static_cast<std::size_t>(status.st_size));
  // Read to the end rather than st_size bytes: files in /proc report size 0, others may grow.
  char buffer[1 << 16];
  while (true) {
    const ssize_t count = ::read(descriptor, buffer, sizeof buffer);
    if (count < 0) {
      if (errno == EINTR) continue;
      throw InputError(path + ": reading failed (" + std::strerror(errno) + ")");
    }
    if (count == 0) break;
    content.append(buffer, static_cast<std::size_t>(count));
    if (content.size() > size_limit_bytes) throw too_large(content.size());
  }
  return content;
}

std::string_view strip_utf8_bom(std::string_view text) {
  constexpr std::string_view kUtf8Bom = "\xEF\xBB\xBF";
  if (text.substr(0, kUtf8Bom.size()) == kUtf8Bom) text.remove_prefix(kUtf8Bom.size());
  return text;
}

std::string format_double(double value) {
  char buffer[64];
  const auto result = std::to_chars(buffer, buffer + sizeof buffer, value);
  return std::string(buffer, result.ptr);
}

}  // namespace vmsim

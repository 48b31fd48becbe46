#include "vmsim/common/output_folder.hpp"

#include <dirent.h>
#include <fcntl.h>
#include <sys/stat.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdio>
#include <cstring>
#include <mutex>
#include <system_error>

#include "vmsim/common/errors.hpp"

namespace vmsim {
namespace fs = std::filesystem;

namespace {

// ---------------------------------------------------------------------------------------------
// Removal on SIGINT / SIGTERM / SIGHUP. The handler may run at any point of the computation, so
// it uses only async-signal-safe calls: the paths sit in fixed buffers, the tree is removed with
// openat / getdents64 / unlinkat.

constexpr std::size_t kCleanupSlots = 16;
constexpr std::size_t kCleanupPathBytes = 4096;

struct CleanupSlot {
  std::atomic<bool> in_use{false};
  char path[kCleanupPathBytes] = {};
};
std::array<CleanupSlot, kCleanupSlots> g_cleanup_slots;
std::mutex g_cleanup_mutex;  // guards claiming a slot (not used by the handler)

struct LinuxDirent64 {
  ino64_t d_ino;
  off64_t d_off;
  unsigned short d_reclen;
  unsigned char d_type;
  char d_name[256];  // the kernel writes the name here (at most 255 bytes and the NUL)
};

// Removes `name` under `parent_fd`: a file, or a folder with everything in it (async-signal-safe).
void remove_tree_signal_safe(int parent_fd, const char* name, int depth) {
  if (::unlinkat(parent_fd, name, 0) == 0 || errno == ENOENT) return;
  if (depth > 16) return;
  const int fd = ::openat(parent_fd, name, O_RDONLY | O_DIRECTORY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) return;
  alignas(8) char buffer[2048];
  // Entries removed while reading may shift the listing: read again from the start until a
  // pass finds nothing to remove.
  for (bool removed = true; removed;) {
    removed = false;
    if (::lseek(fd, 0, SEEK_SET) != 0) break;
    for (;;) {
      const long bytes = ::syscall(SYS_getdents64, fd, buffer, sizeof buffer);
      if (bytes <= 0) break;
      for (long offset = 0; offset < bytes;) {
        const auto* entry = reinterpret_cast<const LinuxDirent64*>(buffer + offset);
        offset += entry->d_reclen;
        const char* entry_name = entry->d_name;
        if (std::strcmp(entry_name, ".") == 0 || std::strcmp(entry_name, "..") == 0) continue;
        remove_tree_signal_safe(fd, entry_name, depth + 1);
        removed = true;
      }
    }
  }
  ::close(fd);
  ::unlinkat(parent_fd, name, AT_REMOVEDIR);
}

extern "C" void remove_staging_and_reraise(int signal_number) {
  const int saved_errno = errno;
  for (CleanupSlot& slot : g_cleanup_slots) {
    if (slot.in_use.load()) remove_tree_signal_safe(AT_FDCWD, slot.path, 0);
  }
  errno = saved_errno;
  // End the process as the signal would have (exit status, core rules, the parent's view).
  ::signal(signal_number, SIG_DFL);
  ::raise(signal_number);
}

void install_signal_handlers_once() {
  static std::once_flag once;
  std::call_once(once, [] {
    for (int signal_number : {SIGINT, SIGTERM, SIGHUP}) {
      struct sigaction previous {};
      if (::sigaction(signal_number, nullptr, &previous) != 0) continue;
      // A signal the caller ignores (nohup) or handles itself stays as it is.
      if (previous.sa_handler != SIG_DFL || (previous.sa_flags & SA_SIGINFO) != 0) continue;
      struct sigaction action {};
      action.sa_handler = remove_staging_and_reraise;
      sigemptyset(&action.sa_mask);
      ::sigaction(signal_number, &action, nullptr);
    }
  });
}

// Registers `path` (absolute) for removal on a signal; returns the slot, -1 when none is free
// or the path is too long (then only the next run's stale cleanup removes it).
int register_cleanup(const fs::path& path) {
  install_signal_handlers_once();
  const std::string text = path.string();
  if (text.size() + 1 > kCleanupPathBytes) return -1;
  std::lock_guard lock(g_cleanup_mutex);
  for (std::size_t i = 0; i < kCleanupSlots; ++i) {
    CleanupSlot& slot = g_cleanup_slots[i];
    if (slot.in_use.load()) continue;
    std::memcpy(slot.path, text.c_str(), text.size() + 1);
    slot.in_use.store(true);
    return static_cast<int>(i);
  }
  return -1;
}

void unregister_cleanup(const fs::path& path) {
  std::lock_guard lock(g_cleanup_mutex);
  for (CleanupSlot& slot : g_cleanup_slots) {
    if (slot.in_use.load() && path.string() == slot.path) slot.in_use.store(false);
  }
}

// ---------------------------------------------------------------------------------------------

std::string reason(int error_number) { return std::strerror(error_number); }

// Absolute, with the symbolic links of the part that exists resolved.
fs::path resolved(const std::string& path) {
  std::error_code error;
  fs::path absolute = fs::absolute(path, error);
  if (error) absolute = fs::path(path);
  fs::path canonical = fs::weakly_canonical(absolute, error);
  if (error) return absolute.lexically_normal();
  return canonical;
}

// True when `path` lies inside `folder` (at any depth) or is `folder`.
bool is_within(const fs::path& path, const fs::path& folder) {
  auto p = path.begin();
  for (auto f = folder.begin(); f != folder.end(); ++f, ++p) {
    if (f->empty()) continue;  // a trailing separator
    if (p == path.end() || *p != *f) return false;
  }
  return true;
}

bool process_alive(long pid) {
  if (pid <= 0) return false;
  if (pid == static_cast<long>(::getpid())) return false;  // left by an earlier process with this pid
  return ::kill(static_cast<pid_t>(pid), 0) == 0 || errno == EPERM;
}

/// Written into every staging folder as soon as it is made: what marks it as vmsim's.
constexpr const char* kStagingMarkerFile = ".vmsim-staging";

/// A real folder (not a link) that vmsim made: a staging folder (its marker), a result or a
/// retired result (kResultMarkerFile), or empty (a retired empty target).
bool made_by_vmsim(const fs::path& folder) {
  std::error_code error;
  if (!fs::is_directory(fs::symlink_status(folder, error))) return false;
  if (fs::is_empty(folder, error) && !error) return true;
  return fs::is_regular_file(fs::symlink_status(folder / kStagingMarkerFile, error)) ||
         fs::is_regular_file(fs::symlink_status(folder / kResultMarkerFile, error));
}

// Removes the entries `<prefix><pid>` in `folder` whose process is no longer alive.
void remove_stale_entries(const fs::path& folder, const std::vector<std::string>& prefixes) {
  std::error_code error;
  for (fs::directory_iterator it(folder, error), end; !error && it != end; it.increment(error)) {
    const std::string name = it->path().filename().string();
    for (const std::string& prefix : prefixes) {
      if (name.size() <= prefix.size() || name.compare(0, prefix.size(), prefix) != 0) continue;
      const std::string digits = name.substr(prefix.size());
      if (digits.find_first_not_of("0123456789") != std::string::npos || digits.size() > 9) continue;
      if (process_alive(std::stol(digits))) continue;
      // Only a folder vmsim made (a link is not followed nor removed; a folder of that name
      // that is not vmsim's stays).
      std::error_code ignored;
      if (!made_by_vmsim(it->path())) continue;
      fs::remove_all(it->path(), ignored);
    }
  }
}

// Writes a whole file; throws InputError with the path and the system's reason.
void write_whole_file(const fs::path& path, const std::string& content) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0666);
  if (fd < 0) throw InputError(path.string() + ": cannot create the file: " + reason(errno));
  std::size_t done = 0;
  while (done < content.size()) {
    const ssize_t written = ::write(fd, content.data() + done, content.size() - done);
    if (written < 0 && errno == EINTR) continue;
    if (written <= 0) {
      const int error_number = written < 0 ? errno : ENOSPC;
      ::close(fd);
      ::unlink(path.c_str());
      throw InputError(path.string() + ": writing failed: " + reason(error_number));
    }
    done += static_cast<std::size_t>(written);
  }
  if (::close(fd) != 0) {
    const int error_number = errno;
    ::unlink(path.c_str());
    throw InputError(path.string() + ": writing failed: " + reason(error_number));
  }
}

enum class FolderState { missing, empty, result, foreign };

// What `folder` (an existing folder) holds, for the decision to replace it.
FolderState folder_state(const fs::path& folder, const std::string& shown) {
  std::error_code error;
  fs::directory_iterator it(folder, error);
  if (error) throw InputError(shown + ": cannot read the folder: " + error.message());
  if (it == fs::directory_iterator()) return FolderState::empty;
  const fs::file_status marker = fs::symlink_status(folder / kResultMarkerFile, error);
  return fs::is_regular_file(marker) ? FolderState::result : FolderState::foreign;
}

FolderState target_state(const fs::path& target, const std::string& shown) {
  std::error_code error;
  const fs::file_status status = fs::status(target, error);
  if (status.type() == fs::file_type::not_found) return FolderState::missing;
  if (error) throw InputError(shown + ": cannot use it as the output folder: " + error.message());
  if (!fs::is_directory(status)) {
    throw InputError(shown + ": exists and is not a folder; the output is a folder of results: "
                             "give a new folder (vmsim does not remove the file)");
  }
  return folder_state(target, shown);
}

void refuse_foreign(const std::string& shown) {
  throw InputError(shown + ": the folder is not empty and holds no vmsim result (no " +
                   std::string(kResultMarkerFile) +
                   " file in it); vmsim replaces its output folder as a whole and never deletes "
                   "what it did not write: give a new or empty folder");
}

std::string staging_prefix(const fs::path& target) { return "." + target.filename().string() + ".vmsim-staging-"; }
std::string retired_prefix(const fs::path& target) { return "." + target.filename().string() + ".vmsim-retired-"; }
std::string part_prefix(const fs::path& target) { return "." + target.filename().string() + ".vmsim-part-"; }
std::string pid_text() { return std::to_string(::getpid()); }

}  // namespace

// ---------------------------------------------------------------------------------------------

OutputFolder::OutputFolder(const std::string& target, const std::vector<std::string>& input_files,
                           ResultOrigin origin)
    : target_given_(target), origin_(std::move(origin)) {
  if (target.empty()) throw InputError("no output folder given");
  target_ = resolved(target);
  if (target_.filename().empty() || target_ == target_.root_path()) {
    throw InputError(target + ": cannot be an output folder (it has no parent folder to write beside)");
  }
  const std::string shown = shown_target();
  const FolderState state = target_state(target_, shown);
  // Inputs before the marker: a result folder never holds inputs, and the message names it.
  for (const std::string& input : input_files) {
    if (input.empty()) continue;
    const fs::path input_path = resolved(input);
    if (is_within(input_path, target_)) {
      throw InputError(shown + ": the output folder holds the input file " + input +
                       "; vmsim replaces its output folder as a whole, which would delete it: "
                       "give another output folder");
    }
  }
  if (state == FolderState::foreign) refuse_foreign(shown);

  const fs::path parent = target_.parent_path();
  std::error_code error;
  fs::create_directories(parent, error);
  if (error) throw InputError(shown + ": cannot create its parent folder " + parent.string() + ": " + error.message());
  remove_stale_entries(parent, {staging_prefix(target_), retired_prefix(target_)});

  staging_ = parent / (staging_prefix(target_) + pid_text());
  if (made_by_vmsim(staging_)) fs::remove_all(staging_, error);  // an earlier process with this pid
  if (::mkdir(staging_.c_str(), 0777) != 0) {
    throw InputError(shown + ": cannot write the results beside it (creating " + staging_.string() +
                     " failed: " + reason(errno) + "); give an output folder in a writable place");
  }
  register_cleanup(staging_);
  write_whole_file(staging_ / kStagingMarkerFile, "vmsim is writing results here (a staging folder)\n");
}

OutputFolder::~OutputFolder() {
  if (!committed_ && !staging_.empty()) {
    std::error_code ignored;
    fs::remove_all(staging_, ignored);
  }
  if (!staging_.empty()) unregister_cleanup(staging_);
}

std::string OutputFolder::shown_target() const {
  return target_given_ == target_.string() ? target_given_ : target_given_ + " (" + target_.string() + ")";
}

std::string OutputFolder::path_of(const std::string& file_name) const { return (staging_ / file_name).string(); }

void OutputFolder::commit() {
  if (committed_) return;
  fs::remove(staging_ / kStagingMarkerFile);  // a result from here on (its own marker below)
  write_whole_file(staging_ / kResultMarkerFile,
                   "vmsim result: written by `vmsim " + origin_.command + "` (vmsim " + origin_.version +
                       ").\nvmsim replaces this folder as a whole when it writes its results here "
                       "again: keep nothing else in it.\n");
  const std::string shown = shown_target();
  const FolderState state = target_state(target_, shown);
  if (state == FolderState::foreign) refuse_foreign(shown);

  if (state == FolderState::missing) {
    if (::rename(staging_.c_str(), target_.c_str()) != 0) {
      throw InputError(shown + ": cannot move the results into place: " + reason(errno));
    }
    committed_ = true;
    return;
  }
  // Swap: the target holds the new set, the staging name the old one.
  if (::renameat2(AT_FDCWD, staging_.c_str(), AT_FDCWD, target_.c_str(), RENAME_EXCHANGE) != 0) {
    const int error_number = errno;
    if (error_number != EINVAL && error_number != ENOSYS && error_number != ENOTSUP) {
      throw InputError(shown + ": cannot swap the new results in: " + reason(error_number));
    }
    // A file system without the exchange: move the old set aside, then the new one in.
    const fs::path retired = target_.parent_path() / (retired_prefix(target_) + pid_text());
    if (::rename(target_.c_str(), retired.c_str()) != 0) {
      throw InputError(shown + ": cannot move the previous results aside: " + reason(errno));
    }
    if (::rename(staging_.c_str(), target_.c_str()) != 0) {
      const int move_error = errno;
      ::rename(retired.c_str(), target_.c_str());  // put the old set back
      throw InputError(shown + ": cannot move the results into place: " + reason(move_error));
    }
    committed_ = true;
    std::error_code ignored;
    if (folder_state(retired, shown) != FolderState::foreign) fs::remove_all(retired, ignored);
    return;
  }
  // The old set is removed only if it still is a vmsim result (or empty): something put into
  // the folder between the check and the swap is swapped back, and the run refused.
  std::error_code ignored;
  if (folder_state(staging_, shown) == FolderState::foreign) {
    ::renameat2(AT_FDCWD, staging_.c_str(), AT_FDCWD, target_.c_str(), RENAME_EXCHANGE);
    refuse_foreign(shown);
  }
  committed_ = true;
  fs::remove_all(staging_, ignored);  // the old set; what stays is removed by the next run
}

// ---------------------------------------------------------------------------------------------

void check_output_file(const std::string& path, const std::vector<std::string>& input_files) {
  if (path.empty()) throw InputError("no output file given");
  const fs::path target = resolved(path);
  std::error_code error;
  const fs::file_status status = fs::status(target, error);
  if (error && status.type() != fs::file_type::not_found) {
    throw InputError(path + ": cannot write the output file: " + error.message());
  }
  if (fs::is_directory(status)) {
    throw InputError(path + ": is a folder; give the name of the output file (e.g. " +
                     (fs::path(path) / "out.csv").string() + ")");
  }
  if (fs::exists(status)) {
    for (const std::string& input : input_files) {
      if (input.empty()) continue;
      std::error_code ignored;
      if (fs::equivalent(target, input, ignored)) {
        throw InputError(path + ": is an input file of this command (" + input +
                         "); writing the output there would destroy it: give another output file");
      }
    }
  }
  const fs::path folder = target.parent_path();
  const fs::file_status folder_status = fs::status(folder, error);
  if (folder_status.type() == fs::file_type::not_found) {
    throw InputError(path + ": the folder " + folder.string() + " does not exist (create it first)");
  }
  if (error || !fs::is_directory(folder_status)) {
    throw InputError(path + ": cannot write in " + folder.string() + ": " +
                     (error ? error.message() : reason(ENOTDIR)));
  }
  // Writable? Try it: permissions alone do not tell (root, read-only mounts, ACLs).
  const fs::path probe = folder / ("." + target.filename().string() + ".vmsim-probe-" + pid_text());
  const int fd = ::open(probe.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
  if (fd < 0) {
    if (errno != EEXIST) throw InputError(path + ": cannot write in " + folder.string() + ": " + reason(errno));
  } else {
    ::close(fd);
    ::unlink(probe.c_str());
  }
  remove_stale_entries(folder, {part_prefix(target), retired_prefix(target)});
}

OutputFileSet::OutputFileSet(const std::vector<std::string>& paths, const std::vector<std::string>& input_files) {
  for (const std::string& path : paths) {
    check_output_file(path, input_files);
    const fs::path target = resolved(path);
    for (const Entry& entry : entries_) {
      if (resolved(entry.target) == target) {
        throw InputError(path + ": named twice among the output files (" + entry.target + " and " + path + ")");
      }
    }
    entries_.push_back({path, (target.parent_path() / (part_prefix(target) + pid_text())).string(), false});
    register_cleanup(entries_.back().temporary);
  }
}

OutputFileSet::~OutputFileSet() {
  for (const Entry& entry : entries_) {
    if (!committed_) ::unlink(entry.temporary.c_str());
    unregister_cleanup(entry.temporary);
  }
}

void OutputFileSet::write(const std::string& path, const std::string& content) {
  for (Entry& entry : entries_) {
    if (entry.target != path) continue;
    try {
      write_whole_file(entry.temporary, content);
    } catch (const InputError& error) {
      throw InputError(path + ": " + error.what());
    }
    entry.written = true;
    return;
  }
  throw InputError(path + ": not one of the output files of this set");
}

void OutputFileSet::commit() {
  if (committed_) return;
  for (const Entry& entry : entries_) {
    if (!entry.written) throw InputError(entry.target + ": the output file was not written");
  }
  // Keep each previous file under a second name (a hard link) until all are in place, so a
  // failed rename can put the previous set back.
  std::vector<std::string> backups(entries_.size());
  auto drop_backups = [&backups] {
    for (const std::string& backup : backups) {
      if (!backup.empty()) ::unlink(backup.c_str());
    }
  };
  for (std::size_t i = 0; i < entries_.size(); ++i) {
    const fs::path target = resolved(entries_[i].target);
    const fs::path backup = target.parent_path() / (retired_prefix(target) + pid_text());
    ::unlink(backup.c_str());
    if (::link(target.c_str(), backup.c_str()) == 0) backups[i] = backup.string();
  }
  for (std::size_t i = 0; i < entries_.size(); ++i) {
    if (::rename(entries_[i].temporary.c_str(), entries_[i].target.c_str()) == 0) continue;
    const int error_number = errno;
    for (std::size_t k = 0; k < i; ++k) {  // put back what was replaced
      if (!backups[k].empty()) {
        ::rename(backups[k].c_str(), entries_[k].target.c_str());
        backups[k].clear();
      } else {
        ::unlink(entries_[k].target.c_str());
      }
    }
    drop_backups();
    throw InputError(entries_[i].target + ": cannot move the finished file into place: " + reason(error_number));
  }
  committed_ = true;
  drop_backups();
}

}  // namespace vmsim

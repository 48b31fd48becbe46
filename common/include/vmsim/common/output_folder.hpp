#pragma once
// Output that never destroys what vmsim did not write, and results replaced as a set.
//
// A command that writes several files writes them into a staging folder beside its target
// (same parent, hidden name with the process id), then swaps the staging folder and the target
// in one rename (Linux renameat2 RENAME_EXCHANGE; a plain rename where there is no target yet)
// and removes the old set only after the swap. A reader of the target sees the old set or the
// new one, never a mix. Every result folder holds a marker file (kResultMarkerFile): an existing
// target is replaced only when it is empty or holds that marker.
//
// Every check runs when the object is made, before the command computes anything: a bad --out
// fails at once with vmsim::InputError naming the path, the reason and what to do.
//
// SIGINT, SIGTERM and SIGHUP remove this process's staging folders and temporary files, then
// end the process as the signal would have; what a SIGKILL leaves is removed by the next run
// writing beside the same target (staging entries of processes that are no longer alive).
#include <filesystem>
#include <string>
#include <vector>

namespace vmsim {

/// The marker file in every result folder vmsim writes (it names the command and version).
inline constexpr const char* kResultMarkerFile = ".vmsim-result";

/// What writes a result: goes into the marker file.
struct ResultOrigin {
  std::string command;  ///< e.g. "plan"
  std::string version;  ///< vmsim's version
};

/// A result folder being written. Make it before computing (it checks the target and creates
/// the staging folder), write every file into staging(), then commit(). Destroyed without
/// commit() (an exception, a failed write) it removes the staging folder: the target is left
/// as it was.
class OutputFolder {
 public:
  /// Throws vmsim::InputError when `target`:
  ///  - exists and is not a folder;
  ///  - is a folder holding anything but a previous vmsim result (no marker, not empty);
  ///  - holds (at any depth) or is the folder of one of `input_files` (the swap would delete
  ///    them), marker or not;
  ///  - cannot be written beside (the staging folder cannot be created: the reason is given,
  ///    e.g. read-only file system, permission denied, not a directory, no space left).
  /// Missing parent folders of `target` are created. Stale staging folders beside the target
  /// (of processes no longer alive) are removed.
  OutputFolder(const std::string& target, const std::vector<std::string>& input_files, ResultOrigin origin);
  ~OutputFolder();
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;

  /// The folder to write the results into (beside the target, hidden).
  const std::filesystem::path& staging() const { return staging_; }
  /// staging() / file_name, as a string.
  std::string path_of(const std::string& file_name) const;
  /// The target as given.
  const std::string& target() const { return target_given_; }

  /// Writes the marker, checks the target once more (someone may have put files there in the
  /// meantime), swaps staging and target, removes the old set. Throws vmsim::InputError when the
  /// swap cannot be done: the target is then as it was and the staging folder is removed.
  void commit();

 private:
  std::string shown_target() const;  // for messages: as given, and resolved where that differs

  std::string target_given_;
  std::filesystem::path target_;   // absolute, symbolic links resolved
  std::filesystem::path staging_;  // beside target_
  ResultOrigin origin_;
  bool committed_ = false;
};

/// Checks a single output file before computing. Throws vmsim::InputError when `path`:
///  - is an existing folder;
///  - is one of `input_files` (the same file, by inode);
///  - lies in a folder that does not exist or cannot be written (tried by creating and removing
///    a file there; the reason is given).
/// A previous output file of the same name may be overwritten. Stale temporary files of
/// OutputFileSet beside `path` (of processes no longer alive) are removed.
void check_output_file(const std::string& path, const std::vector<std::string>& input_files);

/// Several output files replaced together (e.g. a trace and its summary): each is checked as by
/// check_output_file when the set is made, written under a hidden temporary name beside its
/// target by write(), and commit() renames them into place only once all are written. Destroyed
/// without commit() it removes its temporary files; a failed rename in commit() puts back the
/// files already replaced, so on failure neither the new set nor a mix is left.
class OutputFileSet {
 public:
  OutputFileSet(const std::vector<std::string>& paths, const std::vector<std::string>& input_files);
  ~OutputFileSet();
  OutputFileSet(const OutputFileSet&) = delete;
  OutputFileSet& operator=(const OutputFileSet&) = delete;

  /// Writes the content of `path` (one of the set's paths) to its temporary file.
  void write(const std::string& path, const std::string& content);
  /// Renames every written file into place. Throws vmsim::InputError when one of the set's paths
  /// was not written or a rename fails (then the previous files are put back).
  void commit();

 private:
  struct Entry {
    std::string target;
    std::string temporary;
    bool written = false;
  };
  std::vector<Entry> entries_;
  bool committed_ = false;
};

}  // namespace vmsim

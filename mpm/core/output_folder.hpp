// An output folder that a run owns for its whole length.
//
// - Only this program's files are ever removed: every file the run makes is first listed in the
//   folder's manifest (.pfm-mpm-files, one name a line), and clearing a folder for a new run
//   removes exactly the listed files (and their temporaries), never another file, never a
//   folder. A folder holding files the manifest does not list is refused unless the user asks
//   to write beside them (--overwrite); even then only the listed files go.
// - A lock (.pfm-mpm.lock, an advisory flock held from opening to the end of the process, so
//   also released when the process is killed) makes a second run or restart on the same folder
//   stop at once with exit 2, naming the holder's process id.
// - A few kilobytes set aside (reserve()) are given back when a write fails on a full disk, so
//   that run.json can still say why the run stopped.
// - Failures to create or write the folder are IoError (exit 4) with the path and the system's
//   reason; refusals (a file where a folder should be, foreign files, a held lock) InputError.
#pragma once

#include <set>
#include <stdexcept>
#include <string>

namespace pfm {

/// A write to an output file failed (full disk, unwritable folder): exit code 4.
class IoError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// "<what> <path>: <strerror(errno)>" as an IoError, for a failed system call.
[[noreturn]] void throw_io_error(const std::string& what, const std::string& path, int error);

class OutputFolder {
 public:
  enum class Mode {
    kNew,        ///< a new run: the folder is empty, new, or holds only an earlier run's files
    kOverwrite,  ///< a new run beside foreign files (only the listed files are removed)
    kResume      ///< a restart: the folder holds the run; nothing is removed
  };
  static constexpr const char* kManifest = ".pfm-mpm-files";
  static constexpr const char* kLock = ".pfm-mpm.lock";
  static constexpr const char* kReserve = ".pfm-mpm-reserve";

  /// Checks, creates, locks and (kNew, kOverwrite) clears `path`. `option` names the command-line
  /// option in messages ("--out").
  OutputFolder(std::string path, Mode mode, std::string option = "--out");
  ~OutputFolder();  ///< unlock()
  OutputFolder(const OutputFolder&) = delete;
  OutputFolder& operator=(const OutputFolder&) = delete;

  const std::string& path() const { return path_; }
  /// `path()/name`, listed in the manifest (written to disk) before the caller creates it.
  std::string file(const std::string& name);
  /// Removes the temporaries (name.tmp, name.rebuild) of the listed files; never throws.
  void remove_temporaries() const noexcept;
  /// Sets `bytes` of disk aside in the folder (.pfm-mpm-reserve), so that a run that a full disk
  /// stops can still mark its run.json failed; release_reserve() gives them back. IoError when
  /// the disk has not that much left.
  void reserve(std::size_t bytes);
  void release_reserve() const noexcept;
  /// Empties the lock file and releases the lock (the folder is done with; nothing may be
  /// written after). Never throws; a second call does nothing.
  void unlock() noexcept;

 private:
  void write_manifest() const;
  std::string path_;
  std::set<std::string> listed_;
  int lock_fd_ = -1;
};

/// Writes `text` to `path` atomically (a temporary `path`.tmp, then a rename); IoError with the
/// path and the reason when a write fails (the temporary is removed).
void write_file_atomically(const std::string& path, const std::string& text);

/// Copies the file `from` to `to` atomically (as write_file_atomically, read in pieces of 1 MB);
/// IoError with the path and the reason when a read or write fails.
void copy_file_atomically(const std::string& from, const std::string& to);

}  // namespace pfm

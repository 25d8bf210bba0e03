#include "mpm/core/output_folder.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <vector>

#include "mpm/core/json_input.hpp"

namespace pfm {

namespace fs = std::filesystem;

void throw_io_error(const std::string& what, const std::string& path, int error) {
  throw IoError(what + " " + path + ": " +
                (error != 0 ? std::strerror(error) : "the library gave no reason"));
}

namespace {

constexpr const char* kTemporaries[] = {".tmp", ".rebuild"};

bool plain_name(const std::string& name) {
  return !name.empty() && name != "." && name != ".." && name.find('/') == std::string::npos;
}

/// The names a folder's manifest lists (lines that are not plain file names are ignored, so a
/// damaged manifest can never name a file outside the folder).
std::set<std::string> read_manifest(const fs::path& folder) {
  std::set<std::string> names;
  std::ifstream in(folder / OutputFolder::kManifest);
  std::string line;
  while (std::getline(in, line))
    if (plain_name(line)) names.insert(line);
  return names;
}

bool ours(const std::string& name, const std::set<std::string>& listed) {
  const std::string manifest = OutputFolder::kManifest;
  if (name == manifest || name == manifest + ".tmp" || name == OutputFolder::kLock ||
      name == OutputFolder::kReserve)
    return true;
  if (listed.count(name) > 0) return true;
  for (const std::string suffix : kTemporaries) {
    if (name.size() > suffix.size() && name.ends_with(suffix) &&
        listed.count(name.substr(0, name.size() - suffix.size())) > 0)
      return true;
  }
  return false;
}

/// The entries of `folder` that are not this program's (sorted).
std::vector<std::string> foreign_entries(const fs::path& folder,
                                         const std::set<std::string>& listed) {
  std::vector<std::string> foreign;
  std::error_code error;
  for (fs::directory_iterator it(folder, error), end; !error && it != end; it.increment(error)) {
    const std::string name = it->path().filename().string();
    if (!ours(name, listed)) foreign.push_back(name);
  }
  if (error) throw_io_error("cannot read the output folder", folder.string(), error.value());
  std::sort(foreign.begin(), foreign.end());
  return foreign;
}

std::string some_of(const std::vector<std::string>& names) {
  std::string out;
  for (std::size_t k = 0; k < names.size() && k < 3; ++k) out += (k ? ", " : "") + names[k];
  if (names.size() > 3) out += " and " + std::to_string(names.size() - 3) + " more";
  return out;
}

void remove_file(const fs::path& file) {
  std::error_code error;
  if (fs::is_directory(fs::symlink_status(file, error))) {
    throw InputError(file.string() + ": the earlier run's file list names it, but it is a folder " +
                     "now: never removed; move it away or choose another output folder");
  }
  fs::remove(file, error);
  if (error && error != std::errc::no_such_file_or_directory)
    throw_io_error("cannot remove the earlier run's file", file.string(), error.value());
}

}  // namespace

OutputFolder::OutputFolder(std::string path, Mode mode, std::string option)
    : path_(std::move(path)) {
  const std::string where = option + " " + path_;
  if (path_.empty()) throw InputError(option + ": an output folder is required");
  const fs::path folder(path_);
  fs::path prefix;
  for (const fs::path& part : folder) {
    if (part.string().size() > NAME_MAX) {
      throw InputError(where + ": the name \"" + part.string() + "\" is longer than " +
                       std::to_string(NAME_MAX) + " bytes");
    }
    prefix /= part;
    std::error_code error;
    const fs::file_status status = fs::status(prefix, error);
    if (fs::exists(status) && !fs::is_directory(status))
      throw InputError(where + ": " + prefix.string() + " exists and is not a folder");
  }
  const std::string refusal_tail = ": the folder holds files that are not this program's output (" +
                                   std::string("listed in ") + kManifest + "): ";
  auto refuse_foreign = [&](const std::vector<std::string>& foreign) {
    throw InputError(where + refusal_tail + some_of(foreign) +
                     ". Choose another folder, or give --overwrite to write beside them (only "
                     "this program's files are replaced, never another)");
  };
  std::error_code error;
  if (fs::exists(folder, error)) {
    if (mode == Mode::kNew) {
      const std::vector<std::string> foreign = foreign_entries(folder, read_manifest(folder));
      if (!foreign.empty()) refuse_foreign(foreign);
    }
  } else if (mode == Mode::kResume) {
    throw InputError(where + ": no such folder");
  }
  fs::create_directories(folder, error);
  if (error) throw_io_error("cannot create the output folder", path_, error.value());

  const std::string lock_path = (folder / kLock).string();
  lock_fd_ = ::open(lock_path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (lock_fd_ < 0) throw_io_error("cannot create the lock file", lock_path, errno);
  try {
    if (::flock(lock_fd_, LOCK_EX | LOCK_NB) != 0) {
      const int lock_error = errno;
      if (lock_error != EWOULDBLOCK) throw_io_error("cannot lock", lock_path, lock_error);
      // The holder writes its process id right after it takes the lock: wait up to 0.2 s for it.
      std::string pid;
      for (int attempt = 0; attempt < 20 && pid.empty(); ++attempt) {
        if (attempt > 0) ::usleep(10000);
        char holder[32] = {};
        const ssize_t n = ::pread(lock_fd_, holder, sizeof holder - 1, 0);
        if (n > 0) pid.assign(holder, static_cast<std::size_t>(n));
      }
      while (!pid.empty() && (pid.back() == '\n' || pid.back() == ' ')) pid.pop_back();
      throw InputError(where + ": the folder is in use by another pfm-mpm run (process " +
                       (pid.empty() ? "still starting" : pid) + ", lock " + lock_path + ")");
    }
    const std::string pid = std::to_string(::getpid()) + "\n";
    if (::ftruncate(lock_fd_, 0) != 0 ||
        ::pwrite(lock_fd_, pid.data(), pid.size(), 0) != static_cast<ssize_t>(pid.size()))
      throw_io_error("cannot write the lock file", lock_path, errno);

    // Under the lock: the folder as it is now (a run that just ended may have added files).
    listed_ = read_manifest(folder);
    if (mode != Mode::kResume) {
      if (mode == Mode::kNew) {
        const std::vector<std::string> foreign = foreign_entries(folder, listed_);
        if (!foreign.empty()) refuse_foreign(foreign);
      }
      for (const std::string& name : listed_) {
        remove_file(folder / name);
        for (const std::string suffix : kTemporaries) remove_file(folder / (name + suffix));
      }
      listed_.clear();
      write_manifest();
    }
  } catch (...) {
    ::close(lock_fd_);
    lock_fd_ = -1;
    throw;
  }
}

OutputFolder::~OutputFolder() {
  unlock();
}

void OutputFolder::unlock() noexcept {
  if (lock_fd_ < 0) return;
  // Emptied, so that two runs of the same input leave the same bytes; a killed run's process id
  // stays (its lock went with the process).
  if (::ftruncate(lock_fd_, 0) != 0) {
    // Nothing to do: the lock file's content is informative only.
  }
  ::close(lock_fd_);  // releases the flock
  lock_fd_ = -1;
}

std::string OutputFolder::file(const std::string& name) {
  if (listed_.insert(name).second) write_manifest();
  return path_ + "/" + name;
}

void OutputFolder::remove_temporaries() const noexcept {
  for (const std::string& name : listed_) {
    for (const std::string suffix : kTemporaries) {
      std::error_code error;
      fs::remove(fs::path(path_) / (name + suffix), error);
    }
  }
  std::error_code error;
  fs::remove(fs::path(path_) / (std::string(kManifest) + ".tmp"), error);
}

void OutputFolder::reserve(std::size_t bytes) {
  const std::string path = path_ + "/" + kReserve;
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw_io_error("cannot create", path, errno);
  const int error = ::posix_fallocate(fd, 0, static_cast<off_t>(bytes));
  ::close(fd);
  if (error != 0) {
    ::unlink(path.c_str());
    throw_io_error("cannot set disk space aside in", path, error);
  }
}

void OutputFolder::release_reserve() const noexcept {
  ::unlink((path_ + "/" + kReserve).c_str());
}

void OutputFolder::write_manifest() const {
  std::string text;
  for (const std::string& name : listed_) text += name + "\n";
  write_file_atomically(path_ + "/" + kManifest, text);
}

namespace {

/// A file `path` written through its temporary `path`.tmp and renamed over it by commit(); a
/// failed write, or destruction before commit(), removes the temporary. Failures are IoError
/// with the path and the system's reason.
class AtomicWrite {
 public:
  explicit AtomicWrite(const std::string& path) : path_(path), temporary_(path + ".tmp") {
    fd_ = ::open(temporary_.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd_ < 0) throw_io_error("cannot create", temporary_, errno);
  }
  ~AtomicWrite() {
    if (fd_ >= 0) ::close(fd_);
    if (!committed_) ::unlink(temporary_.c_str());
  }
  AtomicWrite(const AtomicWrite&) = delete;
  AtomicWrite& operator=(const AtomicWrite&) = delete;

  void write(const char* data, std::size_t size) {
    std::size_t done = 0;
    while (done < size) {
      const ssize_t n = ::write(fd_, data + done, size - done);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) throw_io_error("cannot write", temporary_, n < 0 ? errno : ENOSPC);
      done += static_cast<std::size_t>(n);
    }
  }

  void commit() {
    const int fd = fd_;
    fd_ = -1;
    if (::close(fd) != 0) throw_io_error("cannot write", temporary_, errno);
    if (::rename(temporary_.c_str(), path_.c_str()) != 0)
      throw_io_error("cannot rename to", path_, errno);
    committed_ = true;
  }

 private:
  std::string path_, temporary_;
  int fd_ = -1;
  bool committed_ = false;
};

}  // namespace

void write_file_atomically(const std::string& path, const std::string& text) {
  AtomicWrite file(path);
  file.write(text.data(), text.size());
  file.commit();
}

void copy_file_atomically(const std::string& from, const std::string& to) {
  const int in = ::open(from.c_str(), O_RDONLY | O_CLOEXEC);
  if (in < 0) throw_io_error("cannot open", from, errno);
  try {
    AtomicWrite file(to);
    std::vector<char> buffer(std::size_t{1} << 20);
    for (;;) {
      const ssize_t got = ::read(in, buffer.data(), buffer.size());
      if (got < 0 && errno == EINTR) continue;
      if (got < 0) throw_io_error("cannot read", from, errno);
      if (got == 0) break;
      file.write(buffer.data(), static_cast<std::size_t>(got));
    }
    file.commit();
  } catch (...) {
    ::close(in);
    throw;
  }
  ::close(in);
}

}  // namespace pfm

#include "svms/base/file_io.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>

namespace svms {
namespace {

namespace fs = std::filesystem;

std::string Reason(int err) { return std::strerror(err); }

// Where the bytes for `path` finally go: a symbolic link's target (resolved, so that the link
// itself survives the rename), else `path` itself.
std::string ResolveTarget(const std::string& path) {
  std::error_code ec;
  if (fs::is_symlink(fs::symlink_status(path, ec))) {
    const fs::path target = fs::weakly_canonical(path, ec);
    if (!ec) return target.string();
  }
  return path;
}

// A temporary file next to `target`, opened for writing; its name in *tmp. -1 and *error set
// on failure.
int OpenTemporary(const std::string& target, std::string* tmp, std::string* error) {
  static std::atomic<unsigned> counter{0};
  const fs::path p(target);
  const std::string dir = p.has_parent_path() ? p.parent_path().string() + "/" : std::string();
  const std::string name = p.filename().string();
  for (int attempt = 0; attempt < 100; ++attempt) {
    const auto now = std::chrono::steady_clock::now().time_since_epoch().count();
    const unsigned long long mix = (static_cast<unsigned long long>(now) * 0x9E3779B97F4A7C15ull) ^
                                   (static_cast<unsigned long long>(getpid()) << 20) ^
                                   counter.fetch_add(1);
    char suffix[24];
    std::snprintf(suffix, sizeof suffix, "%08llx", (mix >> 16) & 0xffffffffull);
    *tmp = dir + "." + name + ".svms-tmp-" + suffix;
    // 0666 less the umask, as for any new file (mkstemp would make it 0600).
    const int fd = ::open(tmp->c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd >= 0) return fd;
    if (errno != EEXIST) {
      *error = target + ": cannot write: " + Reason(errno);
      return -1;
    }
  }
  *error = target + ": cannot write: no free temporary name next to it";
  return -1;
}

// Writes `bytes` to a new temporary next to `target`, flushed and closed. On success the
// temporary's name is in *tmp; on failure it is removed and the message returned.
Status WriteTemporary(const std::string& target, std::string_view bytes, std::string* tmp) {
  std::error_code ec;
  if (fs::is_directory(target, ec))
    return Status::Error(target + ": cannot write: it is a directory; expected a file name");
  std::string error;
  const int fd = OpenTemporary(target, tmp, &error);
  if (fd < 0) return Status::Error(error);
  auto fail = [&](int err) {
    ::close(fd);
    ::unlink(tmp->c_str());
    return Status::Error(target + ": cannot write: " + Reason(err));
  };
  // An existing file keeps its permission bits.
  struct stat st;
  if (::stat(target.c_str(), &st) == 0 && S_ISREG(st.st_mode)) ::fchmod(fd, st.st_mode & 07777);
  const char* p = bytes.data();
  size_t left = bytes.size();
  while (left > 0) {
    const ssize_t n = ::write(fd, p, left);
    if (n < 0) {
      if (errno == EINTR) continue;
      return fail(errno);
    }
    p += n;
    left -= static_cast<size_t>(n);
  }
  // The data on disk before the rename makes it visible (a crash after the rename must not
  // leave an empty file), and the error of a delayed write shows here, not never.
  if (::fsync(fd) != 0 && errno != EINVAL && errno != EROFS) return fail(errno);
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp->c_str());
    return Status::Error(target + ": cannot write: " + Reason(err));
  }
  return Status::Ok();
}

Status RenameIntoPlace(const std::string& tmp, const std::string& target) {
  if (::rename(tmp.c_str(), target.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    return Status::Error(target + ": cannot write: " + Reason(err));
  }
  return Status::Ok();
}

}  // namespace

Status ReadTextFile(const std::string& path, std::string* text) {
  return ReadFileBytes(path, kMaxTextFileBytes, text);
}

Status ReadFileBytes(const std::string& path, size_t max_bytes, std::string* text) {
  struct stat st;
  if (::stat(path.c_str(), &st) != 0)
    return Status::Error(path + ": cannot open for reading: " + Reason(errno));
  if (S_ISDIR(st.st_mode)) return Status::Error(path + ": is a directory; expected a file");
  if (S_ISFIFO(st.st_mode) || S_ISSOCK(st.st_mode))
    return Status::Error(path + ": is a " + (S_ISFIFO(st.st_mode) ? "FIFO" : "socket") +
                         "; expected a regular file (a pipe with no writer would block forever)");
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return Status::Error(path + ": cannot open for reading: " + Reason(errno));
  // Read in pieces up to the limit, so that /dev/zero cannot exhaust memory.
  std::string out;
  char buf[1 << 16];
  for (;;) {
    const ssize_t n = ::read(fd, buf, sizeof buf);
    if (n < 0) {
      if (errno == EINTR) continue;
      const int err = errno;
      ::close(fd);
      return Status::Error(path + ": read error: " + Reason(err));
    }
    if (n == 0) break;
    out.append(buf, static_cast<size_t>(n));
    if (out.size() > max_bytes) {
      ::close(fd);
      return Status::Error(path + ": more than " + std::to_string(max_bytes >> 20) +
                           " MiB; expected a file of a sensible size");
    }
  }
  ::close(fd);
  *text = std::move(out);
  return Status::Ok();
}

Status WriteTextFile(const std::string& path, const std::string& text) {
  return WriteFileAtomically(path, text);
}

Status WriteFileAtomically(const std::string& path, std::string_view bytes) {
  if (path.empty()) return Status::Error("(empty path): cannot write; expected a file name");
  const std::string target = ResolveTarget(path);
  std::string tmp;
  if (Status s = WriteTemporary(target, bytes, &tmp); !s)
    return target == path ? s : Status::Error(path + " -> " + s.message());
  return RenameIntoPlace(tmp, target);
}

AtomicFileSet::~AtomicFileSet() { Discard(); }

void AtomicFileSet::Discard() {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const File& f : files_) ::unlink(f.temporary.c_str());
  files_.clear();
}

Status AtomicFileSet::Add(const std::string& path, std::string_view bytes) {
  File f{path, path.empty() ? path : ResolveTarget(path), ""};
  Status s = path.empty() ? Status::Error("(empty path): cannot write; expected a file name")
                          : WriteTemporary(f.target, bytes, &f.temporary);
  if (!s && f.target != path) s = Status::Error(path + " -> " + s.message());
  std::lock_guard<std::mutex> lock(mutex_);
  if (!s) {
    if (error_.ok()) error_ = s;
    return s;
  }
  AdoptLocked(std::move(f));
  return s;
}

void AtomicFileSet::Adopt(const std::string& path, const std::string& temporary) {
  File f{path, ResolveTarget(path), temporary};
  std::lock_guard<std::mutex> lock(mutex_);
  AdoptLocked(std::move(f));
}

void AtomicFileSet::AdoptLocked(File file) {
  for (File& f : files_) {
    if (f.target == file.target) {
      ::unlink(f.temporary.c_str());
      f = std::move(file);
      return;
    }
  }
  files_.push_back(std::move(file));
}

std::vector<std::string> AtomicFileSet::paths() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::string> out;
  for (const File& f : files_) out.push_back(f.path);
  return out;
}

std::string AtomicFileSet::temporary(const std::string& path) const {
  const std::string target = ResolveTarget(path);
  std::lock_guard<std::mutex> lock(mutex_);
  for (const File& f : files_)
    if (f.target == target) return f.temporary;
  return "";
}

bool AtomicFileSet::empty() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return files_.empty();
}

Status AtomicFileSet::Commit() {
  std::unique_lock<std::mutex> lock(mutex_);
  const Status error = error_;
  error_ = Status::Ok();
  if (!error.ok()) {
    lock.unlock();
    Discard();
    return error;
  }
  std::vector<File> files;
  files.swap(files_);
  lock.unlock();
  for (size_t i = 0; i < files.size(); ++i) {
    if (Status s = RenameIntoPlace(files[i].temporary, files[i].target); !s) {
      for (size_t k = i + 1; k < files.size(); ++k) ::unlink(files[k].temporary.c_str());
      return s;
    }
  }
  return Status::Ok();
}

bool SameFile(const std::string& a, const std::string& b) {
  struct stat sa, sb;
  if (::stat(a.c_str(), &sa) != 0 || ::stat(b.c_str(), &sb) != 0) return false;
  return sa.st_dev == sb.st_dev && sa.st_ino == sb.st_ino;
}

}  // namespace svms

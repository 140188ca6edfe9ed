// Reading and writing whole files: reads bounded in size, writes whole or not at all.
//
// Every file SVMS writes (models, layouts, sidecars, images, artwork, reports) goes through
// here, so that a full disk, a file-size limit, a crash or a killed process never leaves a
// truncated file where a good one was: the new bytes go to a temporary file in the target's
// directory, are flushed to disk and checked, and the temporary is renamed over the target only
// when complete (rename(2) within one file system is atomic: a reader sees the old file or the
// new one). A failed write removes its temporary and leaves the target as it was.
//
// Temporaries are named ".NAME.svms-tmp-XXXXXXXX" next to NAME; one left behind by a process
// that was killed is garbage and may be deleted. A file-size limit (ulimit -f) raises SIGXFSZ,
// which kills a process by default before write(2) can report EFBIG: the `svms` program ignores
// that signal so that the limit is reported as an error; a library user who wants the same
// should do likewise (signal(SIGXFSZ, SIG_IGN)). See docs/reliability.md.
#pragma once

#include <mutex>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "svms/base/status.h"

namespace svms {

// Text files (models, layouts, scenes, sidecars, cameras) are read up to this many bytes, so
// that /dev/zero or a runaway file cannot exhaust memory.
constexpr size_t kMaxTextFileBytes = size_t{64} << 20;

// Reads a whole text file. Refuses, naming the path: a missing file, a directory, a FIFO (a
// named pipe with no writer would block forever; expected a regular file), and more than
// kMaxTextFileBytes (devices such as /dev/zero are read up to that limit).
Status ReadTextFile(const std::string& path, std::string* text);
// The same for any file up to `max_bytes`.
Status ReadFileBytes(const std::string& path, size_t max_bytes, std::string* bytes);
// WriteFileAtomically (below).
Status WriteTextFile(const std::string& path, const std::string& text);

// Replaces (or creates) `path` with `bytes` as described above. A symbolic link at `path` is
// followed (its target is replaced and the link kept); an existing file keeps its permission
// bits, a new one gets 0666 less the umask. Errors name `path` and the system's reason
// ("PATH: cannot write: No space left on device").
Status WriteFileAtomically(const std::string& path, std::string_view bytes);

// Several files replaced as a group, e.g. a camera model and its covariance sidecar, a
// marker's SVG, PDF, PNG and JSON, or a render's images and its truth.json: Add() writes each
// file to its temporary at once (so a large group is not held in memory), and Commit() renames
// them all into place, in the order they were added, only if every Add succeeded. A set that
// is not committed (an error, or destroyed first) removes its temporaries, and no target is
// touched. (The renames are atomic one by one, not as a group: a crash between two of them
// leaves some files new and some old, which readers that cross-check the files, such as the
// sidecar's check against its model, detect.) Add and Adopt may be called from several threads.
class AtomicFileSet {
 public:
  AtomicFileSet() = default;
  AtomicFileSet(const AtomicFileSet&) = delete;
  AtomicFileSet& operator=(const AtomicFileSet&) = delete;
  ~AtomicFileSet();  // removes temporaries not committed

  // Writes `bytes` to a temporary for `path`; a second Add of the same path replaces the
  // first. An error is returned and remembered: Commit will then fail with the first one.
  Status Add(const std::string& path, std::string_view bytes);
  // Takes over `temporary`, a complete file written by someone else (a plotting program) in
  // the target's directory, to be renamed to `path` at Commit.
  void Adopt(const std::string& path, const std::string& temporary);
  // Renames every file into place, or, after a failed Add, removes every temporary and returns
  // that failure. The set is empty afterwards either way.
  Status Commit();
  // The paths added, in order.
  std::vector<std::string> paths() const;
  // Where the bytes for `path` are until Commit ("" when `path` is not in the set): for a
  // program that reads one file of the group to write another (a plot of a data file).
  std::string temporary(const std::string& path) const;
  bool empty() const;

 private:
  struct File {
    std::string path, target, temporary;  // as given; with symbolic links resolved; written
  };
  void Discard();
  void AdoptLocked(File file);
  mutable std::mutex mutex_;
  std::vector<File> files_;
  Status error_;
};

// The paths of two files are the same file (same device and inode; false when either does not
// exist). Used to refuse an output that would replace one of a command's inputs.
bool SameFile(const std::string& a, const std::string& b);

}  // namespace svms

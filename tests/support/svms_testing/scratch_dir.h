// A scratch directory for tests: a fresh directory of its own under the system's temp directory
// (mkdtemp, so concurrent ctest processes never share one), removed with all it holds when the
// object is destroyed. A function-local static one lasts the test program and is removed at its
// normal exit; a failing test that aborts leaves it for inspection.
#pragma once

#include <stdlib.h>

#include <filesystem>
#include <stdexcept>
#include <string>
#include <system_error>
#include <vector>

namespace svms_testing {

class ScratchDir {
 public:
  // `prefix` names the directory (e.g. "svms_artwork_test"); six random characters follow it.
  explicit ScratchDir(const std::string& prefix) {
    std::string pattern = (std::filesystem::temp_directory_path() / (prefix + "_XXXXXX")).string();
    std::vector<char> buf(pattern.begin(), pattern.end());
    buf.push_back('\0');
    if (::mkdtemp(buf.data()) == nullptr)
      throw std::runtime_error("cannot create a scratch directory " + pattern);
    path_ = buf.data();
  }
  ~ScratchDir() {
    std::error_code ec;  // a directory already gone, or busy, is not worth failing a test over
    std::filesystem::remove_all(path_, ec);
  }
  ScratchDir(const ScratchDir&) = delete;
  ScratchDir& operator=(const ScratchDir&) = delete;

  const std::filesystem::path& path() const { return path_; }
  // The path of `name` inside the directory (not created).
  std::string File(const std::string& name) const { return (path_ / name).string(); }

 private:
  std::filesystem::path path_;
};

}  // namespace svms_testing

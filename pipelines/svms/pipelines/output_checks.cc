#include "svms/pipelines/output_checks.h"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>

#include "svms/base/file_io.h"

namespace svms {

Status CheckNotAnInput(const std::string& flag, const std::string& out,
                       const std::vector<std::string>& inputs) {
  for (const std::string& in : inputs)
    if (SameFile(out, in))
      return Status::Error(flag + " " + out + ": is the input " + in +
                           "; expected a new file name (inputs are never overwritten)");
  return Status::Ok();
}

Status PrepareOutputDirectory(const std::string& flag, const std::string& dir) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::file_status st = fs::status(dir, ec);
  if (fs::exists(st) && !fs::is_directory(st))
    return Status::Error(flag + " " + dir + ": is a file; expected a directory");
  if (!fs::exists(st)) {
    fs::create_directories(dir, ec);
    if (ec)
      return Status::Error(flag + " " + dir + ": cannot create the directory: " + ec.message());
  }
  if (::access(dir.c_str(), W_OK | X_OK) != 0)
    return Status::Error(flag + " " + dir + ": cannot write in it: " + std::strerror(errno));
  return Status::Ok();
}

}  // namespace svms

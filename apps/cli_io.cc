#include "cli_io.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <opencv2/core.hpp>

#include "svms/base/file_io.h"

namespace svms::cli {
namespace {

// Whether `s` is valid UTF-8 (RFC 3629: no overlong forms, no surrogates, at most U+10FFFF).
bool ValidUtf8(const std::string& s) {
  const auto* p = reinterpret_cast<const unsigned char*>(s.data());
  const size_t n = s.size();
  for (size_t i = 0; i < n;) {
    const unsigned char c = p[i];
    size_t len;
    unsigned cp;
    if (c < 0x80) {
      ++i;
      continue;
    } else if ((c & 0xe0) == 0xc0) {
      len = 2, cp = c & 0x1f;
    } else if ((c & 0xf0) == 0xe0) {
      len = 3, cp = c & 0x0f;
    } else if ((c & 0xf8) == 0xf0) {
      len = 4, cp = c & 0x07;
    } else {
      return false;
    }
    if (i + len > n) return false;
    for (size_t k = 1; k < len; ++k) {
      if ((p[i + k] & 0xc0) != 0x80) return false;
      cp = (cp << 6) | (p[i + k] & 0x3f);
    }
    const unsigned min[5] = {0, 0, 0x80, 0x800, 0x10000};
    if (cp < min[len] || cp > 0x10ffff || (cp >= 0xd800 && cp <= 0xdfff)) return false;
    i += len;
  }
  return true;
}

}  // namespace

std::string DumpJson(const nlohmann::json& j, int indent) {
  return j.dump(indent, ' ', false, nlohmann::json::error_handler_t::replace);
}

void SetPath(nlohmann::json& j, const std::string& key, const std::string& path) {
  j[key] = path;
  if (ValidUtf8(path)) return;
  static const char* kHex = "0123456789abcdef";
  std::string hex;
  for (unsigned char c : path) {
    hex += kHex[c >> 4];
    hex += kHex[c & 15];
  }
  j[key + "_hex"] = hex;
}

std::string ItemFailure(const std::string& item, std::exception_ptr failure) {
  try {
    std::rethrow_exception(failure);
  } catch (const std::bad_alloc&) {
    return item + ": out of memory; expected a smaller image or fewer --threads";
  } catch (const cv::Exception& e) {
    if (e.code == cv::Error::StsNoMem)
      return item + ": out of memory (in OpenCV); expected a smaller image or fewer --threads";
    return item + ": OpenCV error: " + e.err;
  } catch (const std::exception& e) {
    return item + ": internal error: " + e.what();
  } catch (...) {
    return item + ": internal error";
  }
}

bool WriteStdout(const std::string& text, bool flush, std::string* error) {
  if (!error->empty()) return false;  // reported once; later lines are not tried
  const bool ok = std::fwrite(text.data(), 1, text.size(), stdout) == text.size() &&
                  (!flush || std::fflush(stdout) == 0);
  if (!ok) *error = std::string("standard output: cannot write: ") + std::strerror(errno);
  return ok;
}

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

bool ReadBoundedLine(std::FILE* in, size_t max_bytes, std::string* line, bool* too_long) {
  line->clear();
  *too_long = false;
  int c;
  bool any = false;
  while ((c = std::getc(in)) != EOF) {
    any = true;
    if (c == '\n') return true;
    if (line->size() < max_bytes)
      line->push_back(static_cast<char>(c));
    else
      *too_long = true;
  }
  return any;
}

}  // namespace svms::cli

namespace svms::cli {
namespace {
std::mutex& FailuresMutex() {
  static std::mutex m;
  return m;
}
std::vector<std::string>& Failures() {
  static std::vector<std::string> f;
  return f;
}
}  // namespace

void OutputFile::close() {
  if (written_) return;
  written_ = true;
  if (std::uncaught_exceptions() > exceptions_) return;
  if (Status s = WriteFileAtomically(path_, str()); !s) NoteOutputFailure(s.message());
}

void NoteOutputFailure(const std::string& message) {
  std::lock_guard<std::mutex> lock(FailuresMutex());
  Failures().push_back(message);
}

std::vector<std::string> TakeOutputFailures() {
  std::lock_guard<std::mutex> lock(FailuresMutex());
  std::vector<std::string> out;
  out.swap(Failures());
  return out;
}

int FinishOutputs(const std::string& program, int rc) {
  const std::vector<std::string> failures = TakeOutputFailures();
  for (const std::string& f : failures)
    std::fprintf(stderr, "%s: %s\n", program.c_str(), f.c_str());
  if (failures.empty()) return rc;
  std::fprintf(stderr, "%s: %zu output file(s) not written; earlier files are as they were\n",
               program.c_str(), failures.size());
  return rc == 0 ? 1 : rc;
}

}  // namespace svms::cli

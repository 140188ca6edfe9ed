#include "svms/base/memory_limit.h"

#include <sys/resource.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>

namespace svms {

uint64_t MemoryLimitBytes(std::string* source) {
  uint64_t limit = 0;
  std::string from;
  if (const char* env = std::getenv("SVMS_MEMORY_LIMIT"); env && *env) {
    char* end = nullptr;
    const double v = std::strtod(env, &end);
    double scale = 1;
    if (end && *end) {
      switch (*end) {
        case 'k':
        case 'K':
          scale = 1024.0;
          break;
        case 'm':
        case 'M':
          scale = 1024.0 * 1024;
          break;
        case 'g':
        case 'G':
          scale = 1024.0 * 1024 * 1024;
          break;
        case 't':
        case 'T':
          scale = 1024.0 * 1024 * 1024 * 1024;
          break;
        default:
          scale = 0;
      }
    }
    if (std::isfinite(v) && v > 0 && scale > 0) {
      limit = static_cast<uint64_t>(v * scale);
      from = "SVMS_MEMORY_LIMIT=" + std::string(env);
    }
  }
  if (limit == 0) {
    const long pages = sysconf(_SC_PHYS_PAGES), page = sysconf(_SC_PAGESIZE);
    const double physical = pages > 0 && page > 0 ? static_cast<double>(pages) * page : 4e9;
    limit = static_cast<uint64_t>(0.75 * physical);
    from = "3/4 of this machine's " + FormatBytes(physical) + "; SVMS_MEMORY_LIMIT sets another";
  }
  // An address-space limit counts what is mapped already (the libraries, the heap so far).
  long mapped_pages = 0;
  if (std::FILE* f = std::fopen("/proc/self/statm", "r")) {
    if (std::fscanf(f, "%ld", &mapped_pages) != 1) mapped_pages = 0;
    std::fclose(f);
  }
  const uint64_t mapped = static_cast<uint64_t>(mapped_pages) * sysconf(_SC_PAGESIZE);
  for (int resource : {RLIMIT_AS, RLIMIT_DATA}) {
    struct rlimit rl;
    if (getrlimit(resource, &rl) != 0 || rl.rlim_cur == RLIM_INFINITY) continue;
    uint64_t room = static_cast<uint64_t>(rl.rlim_cur);
    if (resource == RLIMIT_AS) room = room > mapped ? room - mapped : 0;
    if (room < limit) {
      limit = room;
      from = resource == RLIMIT_AS ? "ulimit -v, less what is mapped already" : "ulimit -d";
    }
  }
  if (source) *source = from;
  return limit;
}

std::string FormatBytes(double bytes) {
  char buf[64];
  if (bytes >= 1024.0 * 1024 * 1024)
    std::snprintf(buf, sizeof buf, "%.1f GiB", bytes / (1024.0 * 1024 * 1024));
  else
    std::snprintf(buf, sizeof buf, "%.0f MiB", std::ceil(bytes / (1024.0 * 1024)));
  return buf;
}

Status CheckMemory(const std::string& what, double bytes) {
  std::string source;
  const uint64_t limit = MemoryLimitBytes(&source);
  if (bytes <= static_cast<double>(limit)) return Status::Ok();
  return Status::Error(what + " needs about " + FormatBytes(bytes) + " of memory, more than the " +
                       "limit of " + FormatBytes(static_cast<double>(limit)) + " (" + source +
                       "); expected a smaller request");
}

}  // namespace svms

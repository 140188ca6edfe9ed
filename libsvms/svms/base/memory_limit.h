// How much memory a request may take. Commands estimate what a request needs before doing it
// (a render, a calibration's covariance) and refuse what is beyond the limit with
// one line, instead of running out of memory half way (docs/reliability.md lists the
// estimates).
#pragma once

#include <cstdint>
#include <string>

#include "svms/base/status.h"

namespace svms {

// The limit, bytes: the environment variable SVMS_MEMORY_LIMIT when set (a number of bytes
// with an optional K, M, G or T suffix, powers of 1024, e.g. "8G"), else three quarters of the
// machine's physical memory; never more than the process's address-space or data limit
// (ulimit -v, ulimit -d) when one is set. *source (optional) says where it came from.
uint64_t MemoryLimitBytes(std::string* source = nullptr);

// Ok when `bytes` fit within MemoryLimitBytes(); else "WHAT needs about X GiB of memory, more
// than the limit of Y GiB (SOURCE); expected a smaller request". `what` describes the request
// ("rendering 10000x10000 pixels on 2 threads").
Status CheckMemory(const std::string& what, double bytes);

// "1.5 GiB", "320 MiB": for messages.
std::string FormatBytes(double bytes);

}  // namespace svms

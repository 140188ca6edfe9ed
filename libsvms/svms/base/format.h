// Numbers in reports and tables (internal to SVMS: not installed).
#pragma once

#include <sstream>
#include <string>

namespace svms {

// `v` with `digits` decimals, fixed-point ("0.021").
inline std::string Fixed(double v, int digits) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(digits);
  s << v;
  return s.str();
}

}  // namespace svms

// Numbers in reports and tables (internal to SVMS: not installed). Every number a report,
// table or message writes goes through one of these, so that a table's columns read alike.
#pragma once

#include <charconv>
#include <sstream>
#include <string>

namespace svms {

// `v` with `digits` decimals, fixed-point ("0.021"): printf's %.*f.
inline std::string Fixed(double v, int digits) {
  std::ostringstream s;
  s.setf(std::ios::fixed);
  s.precision(digits);
  s << v;
  return s.str();
}

// `v` with `digits` significant digits, in the shorter of fixed and scientific notation
// ("0.00123", "1.5e-07"): printf's %.*g, and what a stream writes by default (6 digits). For
// columns of data files, where a number must read back close to its value.
inline std::string Significant(double v, int digits) {
  std::ostringstream s;
  s.precision(digits);
  s << v;
  return s.str();
}

// `v` in scientific notation with `digits` decimals ("1.23e-04"): printf's %.*e. For values
// that span decades, such as the asymmetries of an edge profile.
inline std::string Scientific(double v, int digits) {
  std::ostringstream s;
  s.setf(std::ios::scientific);
  s.precision(digits);
  s << v;
  return s.str();
}

// The shortest decimal text that reads back (strtod, Python's float) to exactly `v`
// ("0.1", "1e-07", "nan"): std::to_chars. For numbers written into files other programs read
// as data (camera models, OpenCV YAML), where print precision must not change a value.
inline std::string RoundTrip(double v) {
  char buf[64];
  const std::to_chars_result r = std::to_chars(buf, buf + sizeof(buf), v);
  return std::string(buf, r.ptr);
}

}  // namespace svms

#include "svms/base/format.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <limits>
#include <string>

namespace svms {
namespace {

// printf's text of `v` through `format` (one conversion with a precision argument).
std::string Printf(const char* format, int digits, double v) {
  char buf[128];
  std::snprintf(buf, sizeof buf, format, digits, v);
  return buf;
}

// The helpers promise printf's %.*f, %.*g and %.*e: the reports' texts depend on it.
TEST(FormatTest, MatchesPrintf) {
  const double values[] = {0,    -0.0,        1,       -1,         0.5, 2.5,  0.0125,   1234.5678,
                           1e-7, -3.14159e-5, 6.02e23, 42.0000001, NAN, -NAN, INFINITY, -INFINITY};
  for (const double v : values) {
    for (int digits : {0, 1, 3, 6, 9, 17}) {
      EXPECT_EQ(Fixed(v, digits), Printf("%.*f", digits, v)) << v << " " << digits;
      EXPECT_EQ(Significant(v, digits), Printf("%.*g", digits, v)) << v << " " << digits;
      EXPECT_EQ(Scientific(v, digits), Printf("%.*e", digits, v)) << v << " " << digits;
    }
  }
}

}  // namespace
}  // namespace svms

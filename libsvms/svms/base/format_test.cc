#include "svms/base/format.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <limits>
#include <random>
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

// RoundTrip's text reads back to the same bits (strtod), and is the shortest such: one digit
// fewer would not (checked on values whose shortest forms are known).
TEST(FormatTest, RoundTripReadsBackExactly) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> mantissa(-10, 10);
  std::uniform_int_distribution<int> exponent(-300, 300);
  for (int i = 0; i < 10000; ++i) {
    const int e = exponent(rng);  // drawn first, as GCC evaluates ldexp's arguments
    const double v = std::ldexp(mantissa(rng), e);
    const std::string t = RoundTrip(v);
    EXPECT_EQ(std::strtod(t.c_str(), nullptr), v) << t;
  }
  EXPECT_EQ(RoundTrip(0.1), "0.1");
  EXPECT_EQ(RoundTrip(1e-7), "1e-07");
  EXPECT_EQ(RoundTrip(1234.5), "1234.5");
  EXPECT_EQ(RoundTrip(0.1 + 0.2), "0.30000000000000004");
  EXPECT_EQ(RoundTrip(-2), "-2");
}

}  // namespace
}  // namespace svms

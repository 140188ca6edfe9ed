// Numbers in the benchmarks' tables: the mean of a sample, a table cell (format.h), the NEES
// band and the "no worse" comparison of two RMS errors.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace svms {

// The mean of `v`; NaN when empty.
double Mean(const std::vector<double>& v);

// A table cell: `v` with `digits` decimals (Fixed, format.h), "-" when it is not finite (no
// data).
std::string Cell(double v, int digits);

// Half the width of the chi-square(6) 95 % band on the mean of n NEES values, 6 +- this:
// 1.96 sqrt(12 / n) (n at least 1).
double NeesBandHalfWidth(size_t n);

// Whether an RMS error `rms` is no worse than `reference`, with a relative slack of 1e-6 for
// the last digits: where one solution is the other's (a rig with one camera seeing markers, a
// fusion resting on one marker), the two differ only by rounding.
bool NoWorse(double rms, double reference);

}  // namespace svms

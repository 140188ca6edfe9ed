// Numbers in the benchmarks' tables: the mean of a sample and a table cell (format.h).
#pragma once

#include <string>
#include <vector>

namespace svms {

// The mean of `v`; NaN when empty.
double Mean(const std::vector<double>& v);

// A table cell: `v` with `digits` decimals (Fixed, format.h), "-" when it is not finite (no
// data).
std::string Cell(double v, int digits);

}  // namespace svms

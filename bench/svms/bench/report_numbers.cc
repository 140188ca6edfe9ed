#include "svms/bench/report_numbers.h"

#include <cmath>

#include "svms/base/format.h"

namespace svms {

double Mean(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x;
  return v.empty() ? std::nan("") : s / v.size();
}

std::string Cell(double v, int digits) { return std::isfinite(v) ? Fixed(v, digits) : "-"; }

double NeesBandHalfWidth(size_t n) { return 1.96 * std::sqrt(12.0 / (n > 0 ? n : 1)); }

bool NoWorse(double rms, double reference) { return rms <= reference * (1 + 1e-6); }

}  // namespace svms

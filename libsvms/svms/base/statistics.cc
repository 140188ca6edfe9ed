#include "svms/base/statistics.h"

#include <algorithm>
#include <cmath>

namespace svms {

double Percentile(std::vector<double> v, double p) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  if (v.empty()) return NAN;
  std::sort(v.begin(), v.end());
  const double r = std::clamp(p, 0.0, 1.0) * (v.size() - 1);
  const size_t i = static_cast<size_t>(std::floor(r));
  if (i + 1 >= v.size()) return v.back();
  return v[i] + (r - i) * (v[i + 1] - v[i]);
}

double Median(std::vector<double> v) { return Percentile(std::move(v), 0.5); }

double Rms(const std::vector<double>& v) {
  if (v.empty()) return std::nan("");
  double ss = 0;
  for (double x : v) ss += x * x;
  return std::sqrt(ss / v.size());
}

double NormalQuantile(double p) {
  double lo = -10, hi = 10;
  for (int i = 0; i < 80; ++i) {
    const double mid = 0.5 * (lo + hi);
    (0.5 * std::erfc(-mid / std::sqrt(2.0)) < p ? lo : hi) = mid;
  }
  return 0.5 * (lo + hi);
}

double BlurredRamp(double x, double sigma) {
  const double z = x / sigma;
  return x * 0.5 * std::erfc(-z / std::sqrt(2.0)) +
         sigma * std::exp(-0.5 * z * z) / std::sqrt(2 * M_PI);
}

double ChiSquareQuantile(double p, double dof) {
  const double z = NormalQuantile(p), h = 2.0 / (9.0 * dof);
  const double c = 1 - h + z * std::sqrt(h);
  return dof * c * c * c;
}

}  // namespace svms

// Summary statistics of samples, and quantiles of the normal and chi-square distributions.
#pragma once

#include <vector>

namespace svms {

// The p-quantile of the finite values of `v` (NaN and infinities are left out), p in [0, 1]
// (clamped), by linear interpolation between the order statistics: sorted x_0..x_{n-1}, the
// value at rank p (n - 1) (numpy's default, R's type 7). NaN when `v` has no finite value.
double Percentile(std::vector<double> v, double p);

// The median of the finite values of `v`: Percentile(v, 0.5) (the mean of the two middle values
// for an even count). NaN when `v` has no finite value.
double Median(std::vector<double> v);

// The root mean square of `v`'s values; NaN when it is empty.
double Rms(const std::vector<double>& v);

// The p-quantile of the standard normal distribution, p in (0, 1): the z with Phi(z) = p, by
// bisection on erfc over [-10, 10] (p outside (0, 1) gives -10 or 10). Accurate to about
// 2e-16 / phi(z), the resolution of Phi near p: 5e-16 at the centre, 7e-14 at p = 0.999.
double NormalQuantile(double p);

// The integral of Phi(t / sigma) dt from -inf to x (sigma > 0): the ramp max(0, x) blurred by a
// Gaussian of sigma, x Phi(x / sigma) + sigma phi(x / sigma). Integrated over a pixel, it gives
// the mean of a blurred step edge there (the detector's model band, a blurred edge's Fisher
// information in the benchmarks).
double BlurredRamp(double x, double sigma);

// The p-quantile of the chi-square distribution with `dof` degrees of freedom (dof > 0), by the
// Wilson-Hilferty approximation dof (1 - h + z sqrt(h))^3, h = 2 / (9 dof), z =
// NormalQuantile(p). Its relative error shrinks as dof grows: at p = 0.95, -0.5 % for 3 dof and
// -0.2 % for 6; at p = 0.999, +2.3 % for 2 dof, +1.0 % for 6, +0.6 % for 10; below 0.02 % from
// 60 dof at p = 0.025 and 0.975.
double ChiSquareQuantile(double p, double dof);

// The 95 % quantile of chi-square with 6 degrees of freedom, exact to 4 decimals (tables): an
// honest 6-dof pose covariance leaves 95 % of the poses' NEES below it. (ChiSquareQuantile(0.95,
// 6) gives 12.569.)
inline constexpr double kChi2Dof6P95 = 12.5916;

}  // namespace svms

#include "svms/detect/disc_fit.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>

namespace svms {
namespace {

// Integral of sqrt(r^2 - X^2) dX, for |X| <= r.
double HalfChordIntegral(double r, double x) {
  const double c = std::clamp(x / r, -1.0, 1.0);
  const double xc = r * c;
  return 0.5 * (xc * std::sqrt(std::max(0.0, r * r - xc * xc)) + r * r * std::asin(c));
}

// Area of the disc of radius r (centred at 0) left of abscissa x, from a table of the unit
// disc's (linear interpolation between 4097 abscissae: off by less than 1e-5 r^2). FitDisc's
// profile takes it a few thousand times per fit; with the closed form's asin and sqrt a top of
// 3 px costs 0.1 ms to fit.
double AreaLeftOf(double r, double x) {
  if (x <= -r) return 0;
  if (x >= r) return M_PI * r * r;
  constexpr int kIntervals = 4096;
  static const std::array<double, kIntervals + 1> table = [] {
    std::array<double, kIntervals + 1> t;
    for (int i = 0; i <= kIntervals; ++i)
      t[i] = 2 * (HalfChordIntegral(1, -1 + 2.0 * i / kIntervals) - HalfChordIntegral(1, -1));
    return t;
  }();
  const double u = (x / r + 1) * (0.5 * kIntervals);
  const int i = std::min(kIntervals - 1, static_cast<int>(u));
  const double f = u - i;
  return r * r * ((1 - f) * table[i] + f * table[i + 1]);
}

}  // namespace

double DiscRectangleArea(double r, double x0, double x1, double y0, double y1) {
  if (r <= 0 || x1 <= x0 || y1 <= y0) return 0;
  // Wholly outside (its nearest point beyond r) or wholly inside (its farthest corner within
  // r): most of FitDisc's window, whose pixels need no chords.
  const double nx = std::clamp(0.0, x0, x1), ny = std::clamp(0.0, y0, y1);
  if (nx * nx + ny * ny >= r * r) return 0;
  if (std::max(x0 * x0, x1 * x1) + std::max(y0 * y0, y1 * y1) <= r * r)
    return (x1 - x0) * (y1 - y0);
  const double a = std::max(x0, -r), b = std::min(x1, r);
  if (b <= a) return 0;
  // Between consecutive break points the chord's ends are each either a side of the
  // rectangle or the circle, so the integral is in closed form piece by piece.
  std::array<double, 6> breaks;
  int n = 0;
  breaks[n++] = a;
  breaks[n++] = b;
  for (double c : {y0, y1})
    if (std::abs(c) < r) {
      const double s = std::sqrt(r * r - c * c);
      if (s > a && s < b) breaks[n++] = s;
      if (-s > a && -s < b) breaks[n++] = -s;
    }
  for (int i = 1; i < n; ++i)  // insertion sort of at most 6 (std::sort trips -Warray-bounds)
    for (int j = i; j > 0 && breaks[j] < breaks[j - 1]; --j) std::swap(breaks[j], breaks[j - 1]);
  double area = 0;
  for (int i = 0; i + 1 < n; ++i) {
    const double p = breaks[i], q = breaks[i + 1];
    if (q <= p) continue;
    const double m = 0.5 * (p + q), hm = std::sqrt(std::max(0.0, r * r - m * m));
    const double top = std::min(y1, hm), bottom = std::max(y0, -hm);
    if (top <= bottom) continue;
    const double circle = HalfChordIntegral(r, q) - HalfChordIntegral(r, p);
    area += (hm < y1 ? circle : y1 * (q - p)) - (-hm > y0 ? -circle : y0 * (q - p));
  }
  return area;
}

std::optional<DiscFit> FitDisc(const double* values, int size, int origin_x, int origin_y,
                               double radius, double search_px) {
  if (size < 3 || size > 16 || !(radius > 0) || !(search_px >= 0)) return std::nullopt;
  const int n = size * size;
  // Each axis alone, from the window's column (row) sums, which depend on the disc's abscissa
  // (ordinate) only: the profile of their least-squares cost (amplitude and background solved
  // at each place) on a fine grid, places first + j kStep from the window's first pixel. The
  // grid is walked coarsely first (every kCoarse-th place), and finely only where the coarse
  // profile leaves the place any likelihood: 2-3x fewer places for a disc of a pixel or more,
  // whose place the values pin down to a few hundredths of a pixel.
  constexpr double kStep = 0.01;
  // Fine places per coarse one; every place where the search is too short for three coarse
  // ones (search_px under 0.1 px).
  constexpr int kCoarseStep = 5;
  const double half = 0.5 * (size - 1);
  const double reach = search_px > 0 ? std::min(search_px, half) : half;
  const double first = half - reach;
  const int places = static_cast<int>(std::lround(2 * reach / kStep)) + 1;
  if (places > 1601) return std::nullopt;
  const int kCoarse = places >= 2 * kCoarseStep + 1 ? kCoarseStep : 1;
  const int coarse_places = (places - 1) / kCoarse + 1;  // fine places 0, kCoarse, ...
  std::array<std::array<double, 16>, 2> sums{};
  std::array<double, 2> sv{}, svv{};
  for (int axis = 0; axis < 2; ++axis) {
    for (int i = 0; i < n; ++i) sums[axis][axis == 0 ? i % size : i / size] += values[i];
    for (int k = 0; k < size; ++k) {
      sv[axis] += sums[axis][k];
      svv[axis] += sums[axis][k] * sums[axis][k];
    }
  }
  // The cost of fine place j on `axis`.
  auto cost = [&](int axis, int j) {
    const double origin = axis == 0 ? origin_x : origin_y;
    const double c = origin + first + j * kStep;
    double saa = 0, sa = 0, sav = 0;
    double left = AreaLeftOf(radius, origin - 0.5 - c);
    for (int k = 0; k < size; ++k) {
      const double right = AreaLeftOf(radius, origin + k + 0.5 - c);
      const double a = right - left;
      left = right;
      saa += a * a;
      sa += a;
      sav += a * sums[axis][k];
    }
    const double det = size * saa - sa * sa;
    double e = svv[axis] - sv[axis] * sv[axis] / size;  // no disc in the window: flat
    if (det > 1e-12) {
      const double amplitude = (size * sav - sa * sv[axis]) / det;
      if (amplitude > 0)
        e = svv[axis] - amplitude * sav - (sv[axis] - amplitude * sa) / size * sv[axis];
    }
    return e;
  };
  std::array<std::array<double, 1601>, 2> profile;  // fine places; coarse ones first
  std::array<double, 2> coarse_least{1e300, 1e300}, first_guess{};
  for (int axis = 0; axis < 2; ++axis) {
    int best = 0;
    for (int i = 0; i < coarse_places; ++i) {
      profile[axis][i * kCoarse] = cost(axis, i * kCoarse);
      if (profile[axis][i * kCoarse] < coarse_least[axis]) {
        coarse_least[axis] = profile[axis][i * kCoarse];
        best = i;
      }
    }
    // The coarse minimum refined by a parabola through it and its neighbours: the place at
    // which the pixel noise is read, below.
    double step = 0;
    if (best > 0 && best < coarse_places - 1) {
      const double em = profile[axis][(best - 1) * kCoarse], e0 = profile[axis][best * kCoarse],
                   ep = profile[axis][(best + 1) * kCoarse];
      const double curvature = em - 2 * e0 + ep;
      if (curvature > 0) step = std::clamp(0.5 * (em - ep) / curvature, -0.5, 0.5);
    }
    first_guess[axis] = (axis == 0 ? origin_x : origin_y) + first + (best + step) * kCoarse * kStep;
  }
  // Amplitude, background and the pixel noise from the whole window at `centre`.
  DiscFit fit;
  auto linear_fit = [&](const Eigen::Vector2d& centre) {
    Eigen::Matrix2d A = Eigen::Matrix2d::Zero();
    Eigen::Vector2d b = Eigen::Vector2d::Zero();
    std::array<double, 256> area;
    for (int i = 0; i < n; ++i) {
      const double u = origin_x + i % size - centre.x(), v = origin_y + i / size - centre.y();
      area[i] = DiscRectangleArea(radius, u - 0.5, u + 0.5, v - 0.5, v + 0.5);
      const Eigen::Vector2d g(area[i], 1);
      A += g * g.transpose();
      b += g * values[i];
    }
    if (std::abs(A.determinant()) < 1e-12) return false;
    const Eigen::Vector2d ab = A.ldlt().solve(b);
    double ssr = 0;
    for (int i = 0; i < n; ++i) ssr += std::pow(values[i] - ab(0) * area[i] - ab(1), 2);
    fit.amplitude = ab(0);
    fit.background = ab(1);
    fit.rms = std::sqrt(ssr / n);
    return true;
  };
  if (!linear_fit(Eigen::Vector2d(first_guess[0], first_guess[1])) || fit.amplitude <= 0)
    return std::nullopt;
  // The noise of a sum of `size` pixels, from the window's residual (two places and the two
  // linear parameters taken), at least 8-bit quantization's.
  const double pixel_var = std::max(fit.rms * fit.rms * n / (n - 4), 1.0 / 12);
  const double sum_var = size * pixel_var;
  // Each axis: mean and variance of the place weighted by its likelihood. Unlike a local
  // curvature this stays honest where the values hardly change with the place (a disc inside
  // one pixel column: all of that column is as likely) or where a sliver of the disc in the
  // next pixel is lost in the noise (two places are about as likely). The fine places are those
  // within a coarse place of one whose likelihood is above 1e-12 of the coarse best's; the
  // others add less than that each.
  constexpr double kNegligible = 55.3;  // -2 ln(1e-12)
  double variance = 0;
  for (int axis = 0; axis < 2; ++axis) {
    int lo = places, hi = -1;
    for (int i = 0; i < coarse_places; ++i)
      if (profile[axis][i * kCoarse] - coarse_least[axis] <= kNegligible * sum_var) {
        lo = std::min(lo, std::max(0, (i - 1) * kCoarse));
        hi = std::max(hi, std::min(places - 1, (i + 1) * kCoarse));
      }
    double least = 1e300;
    int best_j = lo;
    for (int j = lo; j <= hi; ++j) {
      if (j % kCoarse != 0) profile[axis][j] = cost(axis, j);
      if (profile[axis][j] < least) {
        least = profile[axis][j];
        best_j = j;
      }
    }
    // A restricted search whose best place is at an end of its range has not found the disc
    // (it lies farther out, or the values hold none): no answer rather than the range's edge
    // with a sigma that only describes the range. (The fine places run to an end of the range
    // whenever the coarse best is the coarse place nearest it.)
    if (reach < half && (best_j == 0 || best_j == places - 1)) return std::nullopt;
    const double origin = axis == 0 ? origin_x : origin_y;
    double w = 0, m1 = 0, m2 = 0;
    for (int j = lo; j <= hi; ++j) {
      const double wj = std::exp(-(profile[axis][j] - least) / (2 * sum_var));
      const double c = first + j * kStep;
      w += wj;
      m1 += wj * c;
      m2 += wj * c * c;
    }
    const double mean = m1 / w;
    fit.centre(axis) = origin + mean;
    variance = std::max(variance, std::max(0.0, m2 / w - mean * mean) + kStep * kStep / 12);
  }
  fit.sigma_px = std::sqrt(variance);
  if (!linear_fit(fit.centre) || fit.amplitude <= 0) return std::nullopt;
  return fit;
}

}  // namespace svms

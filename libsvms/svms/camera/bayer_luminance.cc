#include "svms/camera/bayer_luminance.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "svms/camera/photometric.h"

namespace svms {

namespace {

// The colour (0 red, 1 green, 2 blue) of the pixels of the top-left 2 x 2 cell, row by row.
std::array<int, 4> CellColours(BayerPattern p) {
  switch (p) {
    case BayerPattern::kRggb:
      return {0, 1, 1, 2};
    case BayerPattern::kBggr:
      return {2, 1, 1, 0};
    case BayerPattern::kGrbg:
      return {1, 0, 2, 1};
    case BayerPattern::kGbrg:
      return {1, 2, 0, 1};
    case BayerPattern::kNone:
      break;
  }
  return {1, 1, 1, 1};
}

double Median(std::vector<double>* v) {
  auto mid = v->begin() + v->size() / 2;
  std::nth_element(v->begin(), mid, v->end());
  return *mid;
}

}  // namespace

cv::Matx<float, 5, 5> BayerLuminanceKernel() {
  // Alleysson et al. 2005, eq. (16): zero response at (pi, pi), (pi, 0) and (0, pi).
  const float k[25] = {-2, 3, -6, 3, -2,  //
                       3,  4, 2,  4, 3,   //
                       -6, 2, 48, 2, -6,  //
                       3,  4, 2,  4, 3,   //
                       -2, 3, -6, 3, -2};
  cv::Matx<float, 5, 5> m(k);
  return m * (1.0f / 64.0f);
}

std::array<double, 3> EstimateBayerGains(const cv::Mat& mosaic, BayerPattern pattern,
                                         double saturation) {
  CV_Assert(mosaic.type() == CV_16UC1);
  if (pattern == BayerPattern::kNone) return {1, 1, 1};
  const std::array<int, 4> colour = CellColours(pattern);
  // At most about 16,000 cells, evenly strided (a median needs no more), into buffers kept per
  // thread: a frame of the same size allocates nothing.
  thread_local std::vector<double> red_over_green, blue_over_green;
  red_over_green.clear();
  blue_over_green.clear();
  const double cells = 0.25 * mosaic.rows * mosaic.cols;
  const int stride = std::max(1, static_cast<int>(std::sqrt(cells / 16000.0)));
  const double low = 0.05 * saturation, high = 0.98 * saturation;
  for (int y = 0; y + 1 < mosaic.rows; y += 2 * stride) {
    const uint16_t* r0 = mosaic.ptr<uint16_t>(y);
    const uint16_t* r1 = mosaic.ptr<uint16_t>(y + 1);
    for (int x = 0; x + 1 < mosaic.cols; x += 2 * stride) {
      const double v[4] = {double(r0[x]), double(r0[x + 1]), double(r1[x]), double(r1[x + 1])};
      double g[2], r = 0, b = 0;
      int ng = 0;
      bool clipped = false;
      for (int i = 0; i < 4; ++i) {
        clipped |= v[i] >= high;
        if (colour[i] == 1) g[ng++] = v[i];
        if (colour[i] == 0) r = v[i];
        if (colour[i] == 2) b = v[i];
      }
      const double gm = 0.5 * (g[0] + g[1]);
      if (clipped || gm < low || std::abs(g[0] - g[1]) > 0.05 * gm || r <= 0 || b <= 0) continue;
      red_over_green.push_back(r / gm);
      blue_over_green.push_back(b / gm);
    }
  }
  if (red_over_green.size() < 64) return {1, 1, 1};
  return {1 / Median(&red_over_green), 1, 1 / Median(&blue_over_green)};
}

double CornerRowWindowPx(const PhotometricModel& model) {
  return model.bayer != BayerPattern::kNone && model.demosaic == BayerMethod::kLuminance ? 3.5
                                                                                         : 2.0;
}

void BayerLuminance(const cv::Mat& mosaic, BayerPattern pattern, const std::array<double, 3>& gains,
                    cv::Mat* out) {
  CV_Assert(mosaic.type() == CV_16UC1 && out->data != mosaic.data);
  const std::array<int, 4> colour = CellColours(pattern);
  thread_local cv::Mat balanced, filtered;
  balanced.create(mosaic.size(), CV_32FC1);
  for (int y = 0; y < mosaic.rows; ++y) {
    const uint16_t* m = mosaic.ptr<uint16_t>(y);
    float* b = balanced.ptr<float>(y);
    const float g0 = float(gains[colour[(y & 1) * 2]]), g1 = float(gains[colour[(y & 1) * 2 + 1]]);
    int x = 0;
    for (; x + 1 < mosaic.cols; x += 2) {
      b[x] = g0 * m[x];
      b[x + 1] = g1 * m[x + 1];
    }
    if (x < mosaic.cols) b[x] = g0 * m[x];
  }
  // BORDER_REFLECT_101 mirrors about the edge pixel (x = -1 reads x = 1): the same colour.
  cv::filter2D(balanced, filtered, CV_32F, cv::Mat(BayerLuminanceKernel()), cv::Point(-1, -1), 0,
               cv::BORDER_REFLECT_101);
  filtered.convertTo(*out, CV_16U);  // rounds and saturates
}

}  // namespace svms

#include "svms/detect/bit_sampler.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "svms/codec/svms44.h"
#include "svms/detect/corner_refine.h"

namespace svms {
namespace {

// Bilinear sample at pixel-centre coordinates; false if outside the image.
bool Sample(const cv::Mat& img, double u, double v, double* out) {
  if (!(u >= 0 && v >= 0 && u <= img.cols - 1 && v <= img.rows - 1)) return false;
  *out = SampleImage(img, u, v);
  return true;
}

}  // namespace

float BitReading::weakest() const {
  float w = 1;
  for (float m : margin) w = std::min(w, std::abs(m));
  return w;
}

BitReading SampleBits(const cv::Mat& image, const Eigen::Matrix3d& pixel_from_plane,
                      const MarkerModel& model) {
  BitReading r;
  // Mean of 5 samples: the point and 4 around it at +-`spread` metres in the plane.
  auto mean_at = [&](const Eigen::Vector2d& p, double spread) {
    double sum = 0;
    int n = 0;
    const Eigen::Vector2d offs[5] = {{0, 0}, {spread, 0}, {-spread, 0}, {0, spread}, {0, -spread}};
    for (const auto& o : offs) {
      const Eigen::Vector3d q = pixel_from_plane * Eigen::Vector3d(p.x() + o.x(), p.y() + o.y(), 1);
      double s;
      if (q.z() > 0 && Sample(image, q.x() / q.z(), q.y() / q.z(), &s)) {
        sum += s;
        ++n;
      } else {
        ++r.samples_outside;
      }
    }
    return n ? sum / n : 0.0;
  };
  const double b = model.cell_size, half = 0.5 * model.size, w = model.stripe_width;
  // Black references sit inside the square, clear of its edge (and of a nested marker).
  double inset = std::min(0.5 * w, 0.25 * half);
  if (model.inner) inset = std::min(inset, 0.5 * (half - 6 * model.inner->cell_size));
  const double stripe_mid = half + 0.5 * w, black_line = half - inset;
  double black_sum = 0, white_sum = 0;
  std::array<double, Svms44::kBits> cell_white, cell_black;
  for (int i = 0; i < Svms44::kBits; ++i) {
    const Eigen::Vector2d c = model.BitCellCentre(i);
    // Unit vector from the ring toward the centre along this side's normal, and the position
    // along the side, clamped to where stripe and square exist.
    const int side = i / Svms44::kBitsPerSide;
    const Eigen::Vector2d normal = side == 0   ? Eigen::Vector2d(0, 1)
                                   : side == 1 ? Eigen::Vector2d(1, 0)
                                   : side == 2 ? Eigen::Vector2d(0, -1)
                                               : Eigen::Vector2d(-1, 0);
    const Eigen::Vector2d tangent(-normal.y(), normal.x());
    const double along = c.dot(tangent);
    const Eigen::Vector2d white_p =
        normal * stripe_mid + tangent * std::clamp(along, -stripe_mid, stripe_mid);
    const Eigen::Vector2d black_p =
        normal * black_line + tangent * std::clamp(along, -black_line, black_line);
    const double spread_ref = 0.2 * std::min(w, b);
    const double white = mean_at(white_p, spread_ref);
    const double black = mean_at(black_p, 0.2 * inset);
    const double value = mean_at(c, 0.25 * b);
    const double threshold = 0.5 * (white + black);
    const double range = std::max(1e-9, white - black);
    r.margin[i] = static_cast<float>((value - threshold) / range);
    if (value > threshold) r.word |= uint64_t{1} << i;
    black_sum += black;
    white_sum += white;
    cell_white[i] = white;
    cell_black[i] = black;
  }
  r.black = black_sum / Svms44::kBits;
  r.white = white_sum / Svms44::kBits;
  for (int i = 0; i < Svms44::kBits; ++i)
    r.separated_refs += cell_white[i] - cell_black[i] >= 0.5 * (r.white - r.black);
  return r;
}

}  // namespace svms

// The sensor and the camera's transfer, in a real camera's order (Renderer::Expose, render.h):
// vignetting and defocus blur on the radiance; electrons, with a Bayer filter's channel gains;
// shot and read noise; the full well; the response curve; black and white levels and the
// container's depth. Then how a view is written (PNG with its declared response, or JPEG) and
// what a reader decodes of it. The noise is drawn from a generator seeded by the scene's seed
// and the view, so an exposure is reproducible.
#include <algorithm>
#include <array>
#include <cassert>
#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "svms/camera/photometric.h"
#include "svms/sim/render_impl.h"

namespace svms {
namespace {

// The colour (0 red, 1 green, 2 blue) of each pixel of the 2x2 cell of a Bayer pattern, in
// the order (0, 0), (1, 0), (0, 1), (1, 1) as (x, y): the pattern's letters read row by row.
std::array<int, 4> BayerCell(const std::string& pattern) {
  std::array<int, 4> cell{};
  for (int i = 0; i < 4; ++i) cell[i] = pattern[i] == 'R' ? 0 : pattern[i] == 'G' ? 1 : 2;
  return cell;
}

}  // namespace

cv::Mat Renderer::Expose(const cv::Mat& radiance, int view) const {
  return Expose(radiance, view, impl_->scene.sensor);
}

cv::Mat Renderer::Expose(const cv::Mat& radiance, int view, const Sensor& s) const {
  assert(CheckSensor(s).ok());
  Response response;  // linear unless the sensor says otherwise; a table is never read here
  if (s.response.rfind("table:", 0) != 0) Response::Parse(s.response, &response);
  cv::Mat e = radiance.clone();
  // A radiance from RenderRadianceFine: the light on a grid `fine` times finer than the pixels.
  const int width = impl_->scene.camera.width(), height = impl_->scene.camera.height();
  const int fine = e.cols == width * kRadianceSupersample && e.rows == height * kRadianceSupersample
                       ? kRadianceSupersample
                       : 1;
  if (s.vignetting > 0) {
    const double cx = 0.5 * (e.cols - 1), cy = 0.5 * (e.rows - 1), r2max = cx * cx + cy * cy;
    for (int y = 0; y < e.rows; ++y) {
      float* row = e.ptr<float>(y);
      for (int x = 0; x < e.cols; ++x)
        row[x] *= static_cast<float>(1 - s.vignetting *
                                             ((x - cx) * (x - cx) + (y - cy) * (y - cy)) / r2max);
    }
  }
  if (s.defocus_sigma_px > 0)
    cv::GaussianBlur(e, e, cv::Size(0, 0), s.defocus_sigma_px * fine, 0, cv::BORDER_REFLECT);
  // Each pixel integrates the (blurred) light over its area: the mean of its fine pixels.
  if (fine > 1) cv::resize(e, e, cv::Size(width, height), 0, 0, cv::INTER_AREA);
  // Per pixel of a 2x2 cell: the electrons a grey pixel's are multiplied by (1 without a
  // colour filter array).
  std::array<double, 4> gain = {1, 1, 1, 1};
  if (!s.bayer.empty()) {
    const std::array<int, 4> cell = BayerCell(s.bayer);
    for (int i = 0; i < 4; ++i) gain[i] = s.channel_gain[cell[i]];
  }
  const double max_dn = s.bits == 16 ? 65535.0 : 255.0;
  const double black = s.black_level, span = s.white_level() - s.black_level;
  // Linear: DN = black + electrons * (span / full_well), clipped to [0, white]: as a raw sensor
  // stores it, the read noise of a dark pixel goes below the black level (down to 0), which is
  // what the black level is for; a reader's linear image clips it at black, so it is the same
  // as with the signal clipped at 0. Not so for a JPEG (its codec mixes the values below black
  // into the others) or a fractional black level (rounding): those keep the signal >= 0. Written
  // with the product first (not s * span) so that the default sensor (black 0, span 2^bits - 1)
  // rounds exactly as round(electrons * (2^bits - 1) / full_well) does, bit for bit: the images
  // the datasets' results were measured on.
  const bool linear = response.kind() == Response::Kind::kLinear;
  const double lowest_signal =
      linear && s.format != "jpeg" && black == std::floor(black) ? -black : 0.0;
  const double dn_per_electron = span / s.full_well;
  std::mt19937_64 rng(render::Mix(impl_->scene.seed ^ render::Mix(0x5e55000ULL + view)));
  std::normal_distribution<double> gauss(0, 1);
  cv::Mat out(e.rows, e.cols, s.bits == 16 ? CV_16U : CV_8U);
  for (int y = 0; y < e.rows; ++y) {
    const float* row = e.ptr<float>(y);
    for (int x = 0; x < e.cols; ++x) {
      double electrons = std::max(0.0, s.exposure * row[x]);
      if (!s.bayer.empty()) electrons *= gain[(y & 1) * 2 + (x & 1)];
      if (s.shot_noise && electrons > 0) {
        // Exact Poisson below 1000 electrons; beyond, its normal limit (relative error < 1e-3).
        if (electrons < 1000) {
          electrons = std::poisson_distribution<int>(electrons)(rng);
        } else {
          electrons += std::sqrt(electrons) * gauss(rng);
        }
      }
      if (s.read_noise > 0) electrons += s.read_noise * gauss(rng);
      const double signal =
          linear ? std::clamp(electrons * dn_per_electron, lowest_signal, span)
                 : response.FromLinear(std::clamp(electrons / s.full_well, 0.0, 1.0)) * span;
      const double dn = std::clamp(std::round(black + signal), 0.0, max_dn);
      if (s.bits == 16) {
        out.at<uint16_t>(y, x) = static_cast<uint16_t>(dn);
      } else {
        out.at<uint8_t>(y, x) = static_cast<uint8_t>(dn);
      }
    }
  }
  return out;
}

std::string ViewFileExtension(const Sensor& sensor) {
  return sensor.format == "jpeg" ? ".jpg" : ".png";
}

ImageEncoding ViewImageEncoding(const Sensor& sensor) {
  ImageEncoding encoding;
  if (sensor.format == "jpeg") {
    encoding.jpeg_quality = sensor.jpeg_quality;
    return encoding;
  }
  // The response's one spelling ("sRGB" -> "srgb"); a table, never parsed here (it would
  // read its file), is left for the encoder to refuse.
  Response r;
  encoding.png_response = sensor.response;
  if (sensor.response.rfind("table:", 0) != 0 && Response::Parse(sensor.response, &r))
    encoding.png_response = r.Name();
  return encoding;
}

Status ThroughCodec(const Sensor& sensor, const cv::Mat& exposed, cv::Mat* decoded) {
  if (sensor.format != "jpeg") {
    *decoded = exposed;
    return Status::Ok();
  }
  const std::string name = "view" + ViewFileExtension(sensor);
  std::string bytes;
  if (Status s = EncodeImage(name, exposed, ViewImageEncoding(sensor), &bytes); !s) return s;
  cv::Mat img;
  try {
    const cv::Mat buf(1, static_cast<int>(bytes.size()), CV_8U, bytes.data());
    img = cv::imdecode(buf, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR);
  } catch (const cv::Exception&) {
    img.release();
  }
  if (img.empty())
    return Status::Error(name + ": OpenCV cannot decode the " + std::to_string(bytes.size()) +
                         " bytes its own encoder wrote");
  *decoded = img;
  return Status::Ok();
}

}  // namespace svms

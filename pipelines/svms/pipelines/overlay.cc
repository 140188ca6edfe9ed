#include "svms/pipelines/overlay.h"

#include <cmath>
#include <filesystem>
#include <map>
#include <opencv2/imgproc.hpp>

#include "svms/camera/photometric.h"
#include "svms/pipelines/image_inputs.h"
#include "svms/pipelines/output_checks.h"

namespace svms {

std::string OverlayPath(const std::string& dir, const std::string& image, int frame) {
  // A video's frame as "_" and its index in at least six digits, zero-padded.
  std::string suffix;
  if (frame >= 0) {
    const std::string index = std::to_string(frame);
    suffix = "_" + std::string(index.size() < 6 ? 6 - index.size() : 0, '0') + index;
  }
  return (std::filesystem::path(dir) /
          (std::filesystem::path(image).stem().string() + suffix + ".png"))
      .string();
}

Status CheckOverlayTargets(const std::string& dir, const std::vector<std::string>& inputs) {
  std::map<std::string, std::string> first_of;
  for (const std::string& f : inputs) {
    const std::string out = OverlayPath(dir, f, IsVideoFile(f) ? 0 : -1);
    if (Status s = CheckNotAnInput("--overlay", out, inputs); !s) return s;
    auto [it, fresh] = first_of.emplace(out, f);
    if (!fresh)
      return Status::Error("--overlay " + dir + ": " + f + " and " + it->second +
                           " would both write " + out + "; expected inputs with distinct names");
  }
  return Status::Ok();
}

// The paper's Fig. 4 style: a coloured outline per marker, a star at the post tip, the ID.
void DrawOverlay(cv::Mat& bgr, const std::vector<Detection>& found) {
  static const cv::Scalar colours[] = {{0, 0, 255},   {0, 200, 0},   {255, 80, 0},
                                       {0, 200, 255}, {255, 0, 255}, {255, 255, 0}};
  const int thick = std::max(1, bgr.cols / 600);
  for (size_t i = 0; i < found.size(); ++i) {
    const Detection& d = found[i];
    const cv::Scalar c = colours[d.id % 6];
    std::vector<cv::Point> poly;
    for (const auto& p : d.corners) poly.emplace_back(cvRound(p.x() * 16), cvRound(p.y() * 16));
    cv::polylines(bgr, poly, true, c, thick, cv::LINE_AA, 4);
    cv::circle(bgr, cv::Point(cvRound(d.corners[0].x() * 16), cvRound(d.corners[0].y() * 16)),
               3 * thick * 16, c, thick, cv::LINE_AA, 4);  // the top-left corner as printed
    if (d.tip) {
      const cv::Point t(cvRound(d.tip->pixel.x()), cvRound(d.tip->pixel.y()));
      const int r = std::max(4, static_cast<int>(d.side_px() / 10));
      for (int k = 0; k < 4; ++k) {
        const double a = k * M_PI / 4;
        cv::line(bgr, t + cv::Point(cvRound(r * std::cos(a)), cvRound(r * std::sin(a))),
                 t - cv::Point(cvRound(r * std::cos(a)), cvRound(r * std::sin(a))), c, thick,
                 cv::LINE_AA);
      }
    }
    const std::string label =
        std::to_string(d.id) + (d.bit_errors ? " (" + std::to_string(d.bit_errors) + " bits)" : "");
    cv::putText(bgr, label,
                cv::Point(cvRound(d.corners[0].x()), cvRound(d.corners[0].y()) - 4 * thick),
                cv::FONT_HERSHEY_SIMPLEX, 0.5 * thick, c, thick, cv::LINE_AA);
  }
}

cv::Mat DisplayImage(const cv::Mat& linear) {
  const double full = linear.depth() == CV_16U ? 65535.0 : 255.0;
  cv::Mat lut(1, 256, CV_8U);
  cv::Mat eight;
  linear.convertTo(eight, CV_8U, 255.0 / full);
  const Response srgb = Response::Srgb();
  for (int v = 0; v < 256; ++v)
    lut.at<uchar>(v) = cv::saturate_cast<uchar>(255 * srgb.FromLinear(v / 255.0));
  cv::Mat display, bgr;
  cv::LUT(eight, lut, display);
  cv::cvtColor(display, bgr, cv::COLOR_GRAY2BGR);
  return bgr;
}

}  // namespace svms

// Overlay pictures of detections, shared by `svms detect` and the benchmarks.
#pragma once

#include <opencv2/core.hpp>
#include <vector>

#include "svms/detector.h"

namespace svms::cli {

// Draws `found` on the 8-bit BGR image in the paper's Fig. 4 style: a coloured outline per
// marker (a circle at the top-left corner as printed), a star at the post tip, the ID and the
// number of corrected bits.
void DrawOverlay(cv::Mat& bgr, const std::vector<Detection>& found);

// An 8-bit BGR picture of a linear-light image (8- or 16-bit) for people: sRGB-encoded, as
// screens show it, for overlays.
cv::Mat DisplayImage(const cv::Mat& linear);

}  // namespace svms::cli

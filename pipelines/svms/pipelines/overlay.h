// Overlay pictures of detections, shared by `svms detect` and the benchmarks.
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "svms/base/status.h"
#include "svms/detect/detector.h"

namespace svms {

// Draws `found` on the 8-bit BGR image in the paper's Fig. 4 style: a coloured outline per
// marker (a circle at the top-left corner as printed), a star at the post tip, the ID and the
// number of corrected bits.
void DrawOverlay(cv::Mat& bgr, const std::vector<Detection>& found);

// Where an overlay of `image` (of its frame `frame` for a video; -1 for an image file) goes in
// `dir`: DIR/STEM.png, DIR/STEM_000012.png.
std::string OverlayPath(const std::string& dir, const std::string& image, int frame = -1);

// Checks, before any work, that no overlay in `dir` would replace one of `inputs` and that no
// two inputs would write the same overlay; errors name both files.
Status CheckOverlayTargets(const std::string& dir, const std::vector<std::string>& inputs);

// An 8-bit BGR picture of a linear-light image (8- or 16-bit) for people: sRGB-encoded, as
// screens show it, for overlays.
cv::Mat DisplayImage(const cv::Mat& linear);

}  // namespace svms

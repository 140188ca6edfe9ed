// A check of the response curve a run reads its images with (photometry.h) against what the
// markers' edges in an image say of it (detect/response_estimate.h).
#pragma once

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "svms/detect/detector.h"

namespace svms {

// Whether the response `photometric` declares ({"response", "black_level", "white_level"}, as
// Photometry::Load gives it) agrees with the edges of the markers `found` in `stored` (the
// image as stored): "" when it does, when there are too few edges to tell, or for a Bayer
// mosaic or a table response; else a warning naming both and the response to give instead.
std::string CheckDeclaredResponse(const cv::Mat& stored, const std::vector<Detection>& found,
                                  const nlohmann::json& photometric);

}  // namespace svms

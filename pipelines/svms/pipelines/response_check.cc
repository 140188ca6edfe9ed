#include "svms/pipelines/response_check.h"

#include <algorithm>
#include <cmath>

#include "svms/base/format.h"
#include "svms/camera/photometric.h"
#include "svms/detect/response_estimate.h"

namespace svms {

std::string CheckDeclaredResponse(const cv::Mat& stored, const std::vector<Detection>& found,
                                  const nlohmann::json& photometric) {
  if (photometric.contains("bayer")) return "";  // a mosaic's edges are the demosaic's
  std::vector<EdgePatch> patches;
  CollectEdgePatches(stored, found, photometric["black_level"].get<double>(),
                     photometric["white_level"].get<double>(), &patches, 80);
  const ResponseEstimate e = EstimateGammaFromEdges(patches);
  if (e.patches == 0) return "";
  Response declared;
  if (!Response::Parse(photometric["response"].get<std::string>(), &declared).ok()) return "";
  // The declared curve's gamma. Across a black/white edge (levels 0.05-0.9 of white) sRGB
  // reads as a pure gamma of 2.46-2.57 behind 0.6-1.0 px of blur (the gamma that makes the
  // continuous edge's line spread function unskewed, a 1-D computation): its linear toe and
  // offset bend the curve more than 2.2 does. A table is not checked.
  double g = 1;
  if (declared.kind() == Response::Kind::kSrgb) g = 2.5;
  if (declared.kind() == Response::Kind::kGamma) g = declared.gamma();
  if (declared.kind() == Response::Kind::kTable) return "";
  if (std::abs(e.gamma - g) <= std::max(0.4, 4 * e.sigma)) return "";
  return "the response " + photometric["response"].get<std::string>() +
         " contradicts the image: the markers' edges (" + std::to_string(e.patches) +
         " patches) say gamma " + Fixed(e.gamma, 2) + " +- " + Fixed(e.sigma, 2) +
         "; expected --response gamma:" + Fixed(e.gamma, 1) +
         ", or srgb for a camera's JPEG (docs/detector.md)";
}

}  // namespace svms

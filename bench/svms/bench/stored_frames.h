// A rendered dataset's frames as the renderer stored them (svms dataset / svms render:
// truth.json and one image per view), read back for a benchmark.
#pragma once

#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "svms/base/status.h"
#include "svms/camera/photometric.h"
#include "svms/geometry/pose.h"
#include "svms/pipelines/photometry.h"

namespace svms {

// The photometry a rendered dataset's images were stored with (truth.json's "photometry":
// response, black and white level, bits, Bayer pattern) as the options a command takes (for
// the survey; *options) and as the model an estimator linearises with (*model): left unset where
// the files are linear, full-range and not a mosaic, which the estimator takes as they are (as a
// machine-vision camera's frames). A dataset without the block gives neither. Errors name the
// file and the field.
Status ReadStoredPhotometry(const std::string& truth_path, std::optional<PhotometricModel>* model,
                            PhotometryOptions* options);

// Each view's image file in dataset folder D as the renderer stored it (truth.json:
// "views"[i]["image"], by view name; VIEW.png where it names none) into *images, unchanged
// (cv::IMREAD_UNCHANGED), in the order of `truth`. An unreadable file: a line on stderr naming
// it and kExitBadInput; else kExitOk.
int ReadStoredImages(const std::string& D, const std::vector<std::pair<std::string, Pose>>& truth,
                     std::vector<cv::Mat>* images);

}  // namespace svms

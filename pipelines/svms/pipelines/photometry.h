// How a run turns every image file into the linear-light image the detector measures
// (camera/photometric.h): the options a command takes, the camera's photometric file, and what
// the file itself declares, resolved once per image.
#pragma once

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "svms/base/status.h"
#include "svms/camera/photometric.h"
#include "svms/detect/noise_model.h"

namespace svms {

// The photometry options every command that reads images takes (--response, --black-level,
// --white-level, --bayer, --demosaic). Each given option overrides that part of the model that
// would apply otherwise (photometric.h: the camera's photometric file, the file's own declaration,
// the default by depth).
struct PhotometryOptions {
  std::string response;  // Response::Parse text, or "estimate" (svms calibrate); "" = not given
  std::string bayer;     // "" = not given
  std::string demosaic;  // ParseBayerMethod text; "" = not given
  std::optional<double> black_level, white_level;
  bool any() const {
    return !response.empty() || !bayer.empty() || !demosaic.empty() || black_level || white_level;
  }
  bool estimate() const { return response == "estimate"; }
};

// How every image of a run is turned into linear light: the options, checked, and the
// camera's photometric file (CAMERA.cameramodel.photometric.json) when there is one.
class Photometry {
 public:
  // Checks the options (exit-2 errors name them) and reads the camera's file ("" = no camera).
  // `allow_estimate`: --response estimate is accepted (the response is then left to the
  // caller's estimate, UseResponse; until then the rest of the resolution applies).
  static Status Create(const PhotometryOptions& options, const std::string& camera_path,
                       Photometry* out, bool allow_estimate = false);
  bool estimating() const { return estimating_; }
  // From now on every image is read with `response` (as if given by --response).
  void UseResponse(const Response& response);
  // The model the options give, when they give a response (after UseResponse too): what a
  // camera's photometric file should record. nullopt otherwise.
  std::optional<PhotometricModel> GivenModel() const;
  // The corner fit's widest row window for these images (CornerRowWindowPx, bayer_luminance.h):
  // wider where a Bayer mosaic (from the options or the camera's file) becomes luminance
  // through the blurring filter.
  double CornerRowWindowPx() const;
  // The black and white levels the options give (0: not given).
  double black_level() const { return options_.black_level.value_or(0); }
  double white_level() const { return options_.white_level.value_or(0); }

  // The model for an image of `depth_max` (255 or 65535) that declares `declared` ("" when it
  // declares nothing), and where it came from.
  PhotometricModel Resolve(double depth_max, const std::string& declared,
                           PhotometrySource* source) const;

  // Loads an image file (at most `max_pixels`, checked from its header) and linearises it
  // (LoadStoredImage, LinearizeImage). *json gets {"response", "black_level", "white_level",
  // "bayer", "demosaic", "source"}; *stored_grey (optional) the image as stored, one channel
  // (colour turned to grey on the stored values); *stored_noise (optional) the noise a raw
  // frame's stored values show, in the linear image's units (EstimateStoredNoise, noise_model.h;
  // invalid where that does not apply), for Detector::Detect.
  Status Load(const std::string& path, int64_t max_pixels, cv::Mat* linear, nlohmann::json* json,
              cv::Mat* stored_grey = nullptr, NoiseModel* stored_noise = nullptr) const;
  // Linearises a decoded frame (a video's: 8-bit BGR, which declares sRGB); *stored_noise as
  // Load's.
  Status LinearizeFrame(const cv::Mat& frame, const std::string& declared, cv::Mat* linear,
                        nlohmann::json* json, NoiseModel* stored_noise = nullptr) const;

 private:
  PhotometryOptions options_;
  Response option_response_;
  BayerPattern option_bayer_ = BayerPattern::kNone;
  BayerMethod option_demosaic_ = BayerMethod::kLuminance;
  std::optional<PhotometricModel> camera_;
  std::string camera_file_;
  bool estimating_ = false;
};

}  // namespace svms

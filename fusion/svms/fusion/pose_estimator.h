// The product's end: where is the object, from one image. PoseEstimator detects every marker
// (svms::Detector, no state between frames) and solves one cam_from_object from all of them
// (object_pose.h), with its covariance, quality fields and a per-frame time budget.
//
// Built from a calibrated camera (mrcal .cameramodel) and a surveyed layout (svms survey's
// LAYOUT.json: each marker's object_from_marker and covariance). One estimator per thread;
// Estimate() is const apart from its reusable scratch, so do not share one between threads.
#pragma once

#include <chrono>
#include <optional>
#include <string>
#include <vector>

#include "svms/base/status.h"
#include "svms/camera/camera.h"
#include "svms/camera/photometric.h"
#include "svms/detect/detector.h"
#include "svms/fusion/object_pose.h"
#include "svms/marker/layout.h"

namespace svms {

struct PoseEstimatorOptions {
  DetectorOptions detector;
  ObjectPoseOptions fusion;
  // Time budget per frame, milliseconds (0: none). When detection runs out of it, the markers
  // found so far are used and ObjectPose is flagged budget_exceeded.
  double budget_ms = 0;
  // How the frames' values relate to light (photometric.h): Estimate converts each frame to
  // linear light with it. Unset: frames are linear already (a machine-vision camera's raw
  // output). CreateFromFiles sets it from the camera's photometric file when there is one.
  std::optional<PhotometricModel> photometric;
};

struct FrameResult {
  double timestamp = 0;  // seconds, as given
  ObjectPose pose;
  std::vector<Detection> detections;  // every marker found (layout or not)
  bool budget_exceeded = false;
  double latency_ms = 0;  // detection + fusion, wall clock
  double detect_ms = 0;
};

class PoseEstimator {
 public:
  // Checks the camera (not empty) and the layout (Layout::Validate, at least one marker);
  // errors name the file.
  static Status Create(const CameraModel& camera, const Layout& layout,
                       const PoseEstimatorOptions& options, std::unique_ptr<PoseEstimator>* out);
  // CreateFromFiles also reads the camera's covariance sidecar (camera_covariance.h) when
  // CAMERA.covariance.json exists; a sidecar that cannot be read or belongs to another model is
  // an error (it names the sidecar), never silently left out.
  static Status CreateFromFiles(const std::string& camera_path, const std::string& layout_path,
                                const PoseEstimatorOptions& options,
                                std::unique_ptr<PoseEstimator>* out);

  // One frame as the camera delivers it: 8-bit or 16-bit grey (or a Bayer mosaic, with the
  // photometric model's pattern), or colour, converted to linear light by
  // options().photometric. `timestamp` is passed through.
  void Estimate(const cv::Mat& image, double timestamp, FrameResult* out) const;
  // One frame already in linear light (LinearizeImage): what Estimate does after converting.
  void EstimateLinear(const cv::Mat& linear, double timestamp, FrameResult* out) const;

  const CameraModel& camera() const { return camera_; }
  const Layout& layout() const { return layout_; }
  const PoseEstimatorOptions& options() const { return options_; }

 private:
  PoseEstimator(const CameraModel& camera, const Layout& layout,
                const PoseEstimatorOptions& options);
  CameraModel camera_;
  Layout layout_;
  PoseEstimatorOptions options_;
  Detector detector_;
  Linearizer linearizer_;
};

}  // namespace svms

// The product's end: where is the object, from one image. PoseEstimator detects every marker
// (svms::Detector, no state between frames) and solves one cam_from_object from all of them
// (object_pose.h), with its covariance, quality fields and a per-frame time budget.
//
// Built from a calibrated camera (mrcal .cameramodel) and one or several surveyed layouts (svms
// survey's LAYOUT.json: each marker's object_from_marker and covariance), one layout per object
// (a docking target and a reference fixture seen by one camera). Each frame is detected once,
// with the markers of every layout, and each layout's detections are fused on their own into
// that object's pose (SolveObjectPose, the same call for one layout or several): the objects'
// poses are exactly what one single-layout estimator per object would give, for the price of
// one detection (without a time budget: under one, the frame's single detection pass spends
// it on the markers of every layout). A marker ID belongs to one layout at most: the same ID in two
// layouts would make its detection a point of two objects, so creation refuses it and names both
// layouts. Detections of no layout are reported by ID (FrameResult::unassigned_ids).
//
// One estimator per thread; Estimate() is const apart from its reusable scratch, so do not
// share one between threads.
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
  // Time budget per frame, milliseconds (0: none), from the call of Estimate (the conversion to
  // linear light and the stored-noise estimate included). When detection runs out of it, the
  // markers found so far are used and ObjectPose is flagged budget_exceeded.
  double budget_ms = 0;
  // How the frames' values relate to light (photometric.h): Estimate converts each frame to
  // linear light with it. Unset: frames are linear already (a machine-vision camera's raw
  // output). CreateFromFiles sets it from the camera's photometric file when there is one.
  std::optional<PhotometricModel> photometric;
};

struct FrameResult {
  double timestamp = 0;  // seconds, as given
  // The object of each layout, in the estimator's order (PoseEstimator::layouts()): `pose` is
  // layout 0's, the only one of a single-layout estimator; more_poses[i] is layout i + 1's.
  ObjectPose pose;
  std::vector<ObjectPose> more_poses;
  std::vector<Detection> detections;  // every marker found (of a layout or not)
  // The IDs of the detections that belong to no layout (neither an outer nor an inner marker of
  // any), one per such detection, in the order of `detections`.
  std::vector<int> unassigned_ids;
  bool budget_exceeded = false;
  // Wall clock of the whole call: conversion to linear light (Estimate), detection and the
  // fusion of every layout.
  double latency_ms = 0;
  double detect_ms = 0;  // the one detection pass
  double fuse_ms = 0;    // the fusion of every layout together
  // How many times the detector ran for this frame: 1 (0 when the frame could not be converted
  // to linear light). Shows that several layouts share one detection.
  int detection_passes = 0;

  size_t num_objects() const { return 1 + more_poses.size(); }
  // Layout i's object, i < num_objects().
  const ObjectPose& object(size_t i) const { return i == 0 ? pose : more_poses.at(i - 1); }
  ObjectPose& object(size_t i) { return i == 0 ? pose : more_poses.at(i - 1); }
};

// Makes *result a fresh FrameResult{} for `n_layouts` objects at `timestamp` (every pose invalid,
// no detections), while its vectors and messages keep their capacity: a result reused frame
// after frame allocates nothing once grown, also across frames without a pose (a rig's camera
// without a frame).
void ResetFrameResult(size_t n_layouts, double timestamp, FrameResult* result);

class PoseEstimator {
 public:
  // Checks the camera (not empty) and the layout (Layout::Validate, at least one marker);
  // errors name the file.
  static Status Create(const CameraModel& camera, const Layout& layout,
                       const PoseEstimatorOptions& options, std::unique_ptr<PoseEstimator>* out);
  // Several objects, one layout each (at least one layout), checked as above; an ID (outer or
  // inner) in two layouts is an error naming both ("layouts[1] 'fixture': marker ID 7 is also
  // in layouts[0] 'target' ...").
  static Status Create(const CameraModel& camera, const std::vector<Layout>& layouts,
                       const PoseEstimatorOptions& options, std::unique_ptr<PoseEstimator>* out);
  // CreateFromFiles also reads the camera's covariance sidecar (camera_covariance.h) when
  // CAMERA.covariance.json exists; a sidecar that cannot be read or belongs to another model is
  // an error (it names the sidecar), never silently left out.
  static Status CreateFromFiles(const std::string& camera_path, const std::string& layout_path,
                                const PoseEstimatorOptions& options,
                                std::unique_ptr<PoseEstimator>* out);
  // Several layout files, one object each; errors name the file (an ID in two files names both
  // files and the ID).
  static Status CreateFromFiles(const std::string& camera_path,
                                const std::vector<std::string>& layout_paths,
                                const PoseEstimatorOptions& options,
                                std::unique_ptr<PoseEstimator>* out);

  // One frame as the camera delivers it: 8-bit or 16-bit grey (or a Bayer mosaic, with the
  // photometric model's pattern), or colour, converted to linear light by
  // options().photometric. `timestamp` is passed through. *out holds one ObjectPose per layout.
  void Estimate(const cv::Mat& image, double timestamp, FrameResult* out) const;
  // One frame already in linear light (LinearizeImage): what Estimate does after converting.
  // `noise`, when given: the frame's noise in the linear image's units (Detector::Detect); a raw
  // frame's, measured by Estimate on its stored values (EstimateStoredNoise).
  void EstimateLinear(const cv::Mat& linear, double timestamp, FrameResult* out,
                      const NoiseModel* noise = nullptr) const;

  // Changes how frames are searched for markers and keeps everything else:
  // DetectorOptions::decimate (1 to kMaxDecimate: steps 1-4 on decimate x decimate block
  // averages, faster on textured frames, most markers under 8 decimate px lost) and
  // DetectorOptions::threads (1 to kMaxDetectorThreads threads per frame; every count gives the
  // same poses unless the budget runs out). The detector, with its threads, is made anew. Between
  // frames only: not while Estimate runs on another thread. A value out of range is an error naming
  // it, and the estimator keeps its settings.
  Status SetDetection(int decimate, int frame_threads);

  const CameraModel& camera() const { return camera_; }
  const Layout& layout() const { return layouts_.front(); }  // layout 0
  const std::vector<Layout>& layouts() const { return layouts_; }
  const PoseEstimatorOptions& options() const { return options_; }

 private:
  PoseEstimator(const CameraModel& camera, const std::vector<Layout>& layouts,
                const PoseEstimatorOptions& options);
  // Create with the layouts named by `labels` in errors (file names, or "layouts[i] 'name'").
  static Status CreateLabelled(const CameraModel& camera, const std::vector<Layout>& layouts,
                               const std::vector<std::string>& labels,
                               const PoseEstimatorOptions& options,
                               std::unique_ptr<PoseEstimator>* out);
  // The frame's deadline for a call that started at t0 (max() without a budget).
  std::chrono::steady_clock::time_point DeadlineFrom(
      std::chrono::steady_clock::time_point t0) const;
  // Detection and fusion of a linear frame whose call started at t0.
  void EstimateFrom(const cv::Mat& linear, double timestamp,
                    std::chrono::steady_clock::time_point t0,
                    std::chrono::steady_clock::time_point deadline, const NoiseModel* noise,
                    FrameResult* out) const;
  CameraModel camera_;
  std::vector<Layout> layouts_;
  std::vector<int> layout_ids_;  // every layout's IDs, outer and inner, ascending
  PoseEstimatorOptions options_;
  Detector detector_;
  Linearizer linearizer_;
};

}  // namespace svms

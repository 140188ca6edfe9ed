// Where is the object, from the cameras of a rig at one time stamp. A RigPoseEstimator holds one
// PoseEstimator per camera of a CameraRig (camera_rig.h): each detects its own camera's frame
// with its own Detector and photometric model, and fuses that camera's markers on its own (the
// per-camera poses, cam_from_object, kept in the result to compare with). Then every camera's
// observations of each layout go into one SolveRigObjectPose (object_pose.h): one
// rig_from_object per layout with its 6x6 covariance ([rotation, translation], rotation about
// the rig axes), including each camera's calibration and rig_from_cam uncertainty.
//
// The frames of one call are taken at one time stamp; frames[c] is camera c's (the rig file's
// order). An empty frame means that camera gave none this time: the others still fuse.
//
// One estimator per thread, as PoseEstimator.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "svms/camera/camera_rig.h"
#include "svms/fusion/pose_estimator.h"

namespace svms {

struct RigFrameResult {
  double timestamp = 0;  // seconds, as given
  // Each layout's rig_from_object, in the estimator's order: `pose` is layout 0's, more_poses[i]
  // layout i + 1's. ObjectPose::cam_from_object holds rig_from_object; its cameras_used (and
  // cameras_rejected) give the camera of each marker in ids_used (ids_rejected).
  ObjectPose pose;
  std::vector<ObjectPose> more_poses;
  // Each camera's own result: its detections and its camera-alone cam_from_object per layout.
  std::vector<FrameResult> cameras;
  // Every camera's frame (its conversion to linear light, detection and fusion), then the rig's
  // fusion, wall clock.
  double latency_ms = 0;

  size_t num_objects() const { return 1 + more_poses.size(); }
  const ObjectPose& object(size_t i) const { return i == 0 ? pose : more_poses.at(i - 1); }
  ObjectPose& object(size_t i) { return i == 0 ? pose : more_poses.at(i - 1); }
};

class RigPoseEstimator {
 public:
  // One PoseEstimator per camera (PoseEstimator::Create's checks; errors name the camera).
  // `options` serve every camera; its photometric model, when set, too.
  static Status Create(const CameraRig& rig, const std::vector<Layout>& layouts,
                       const PoseEstimatorOptions& options, std::unique_ptr<RigPoseEstimator>* out);
  // Reads the rig file, each camera's model (with its covariance and photometric sidecars, as
  // PoseEstimator::CreateFromFiles) and the layouts; errors name the file and field.
  static Status CreateFromFiles(const std::string& rig_path,
                                const std::vector<std::string>& layout_paths,
                                const PoseEstimatorOptions& options,
                                std::unique_ptr<RigPoseEstimator>* out);

  // frames[c]: camera c's frame as it delivers it (PoseEstimator::Estimate), or empty. A count
  // other than the rig's cameras gives invalid poses whose message says so.
  void Estimate(const std::vector<cv::Mat>& frames, double timestamp, RigFrameResult* out) const;

  // PoseEstimator::SetDetection for every camera: all of them, or (a value out of range) none;
  // an exception (threads that cannot start) may leave the cameras before it changed.
  Status SetDetection(int decimate, int frame_threads);

  const CameraRig& rig() const { return rig_; }
  size_t num_cameras() const { return cameras_.size(); }
  const PoseEstimator& camera(size_t c) const { return *cameras_.at(c); }
  const std::vector<Layout>& layouts() const { return cameras_.front()->layouts(); }
  const PoseEstimatorOptions& options() const { return cameras_.front()->options(); }

 private:
  RigPoseEstimator(CameraRig rig, std::vector<std::unique_ptr<PoseEstimator>> cameras);
  CameraRig rig_;
  std::vector<std::unique_ptr<PoseEstimator>> cameras_;
  std::vector<RigCameraView> views_;  // pointing into cameras_' models
};

}  // namespace svms

#include "svms/fusion/rig_pose_estimator.h"

#include <chrono>
#include <filesystem>

#include "svms/base/file_io.h"

namespace svms {

RigPoseEstimator::RigPoseEstimator(CameraRig rig,
                                   std::vector<std::unique_ptr<PoseEstimator>> cameras)
    : rig_(std::move(rig)), cameras_(std::move(cameras)) {
  for (size_t c = 0; c < cameras_.size(); ++c)
    views_.push_back({&cameras_[c]->camera(), rig_.cameras[c].rig_from_cam,
                      rig_.cameras[c].rig_from_cam_covariance});
}

Status RigPoseEstimator::Create(const CameraRig& rig, const std::vector<Layout>& layouts,
                                const PoseEstimatorOptions& options,
                                std::unique_ptr<RigPoseEstimator>* out) {
  if (rig.cameras.empty()) return Status::Error("rig: expected at least one camera");
  std::vector<std::unique_ptr<PoseEstimator>> cameras(rig.cameras.size());
  for (size_t c = 0; c < rig.cameras.size(); ++c)
    if (Status s = PoseEstimator::Create(rig.cameras[c].camera, layouts, options, &cameras[c]); !s)
      return Status::Error("rig camera '" + rig.cameras[c].name + "': " + s.message());
  out->reset(new RigPoseEstimator(rig, std::move(cameras)));
  return Status::Ok();
}

Status RigPoseEstimator::CreateFromFiles(const std::string& rig_path,
                                         const std::vector<std::string>& layout_paths,
                                         const PoseEstimatorOptions& options,
                                         std::unique_ptr<RigPoseEstimator>* out) {
  std::string text;
  if (Status s = ReadTextFile(rig_path, &text); !s) return s;
  CameraRig rig;
  const std::string base_dir = std::filesystem::path(rig_path).parent_path().string();
  if (Status s = ParseRig(text, rig_path, base_dir, &rig); !s) return s;
  std::vector<std::unique_ptr<PoseEstimator>> cameras(rig.cameras.size());
  for (size_t c = 0; c < rig.cameras.size(); ++c) {
    const Status s = PoseEstimator::CreateFromFiles(rig.cameras[c].cameramodel_path, layout_paths,
                                                    options, &cameras[c]);
    if (!s)
      return Status::Error(rig_path + ": cameras[" + std::to_string(c) + "] '" +
                           rig.cameras[c].name + "': " + s.message());
    rig.cameras[c].camera = cameras[c]->camera();
  }
  out->reset(new RigPoseEstimator(std::move(rig), std::move(cameras)));
  return Status::Ok();
}

Status RigPoseEstimator::SetDetection(int decimate, int frame_threads) {
  // Every camera takes the same values, so the first refuses them if any would, before any
  // camera has changed.
  for (std::unique_ptr<PoseEstimator>& camera : cameras_)
    if (Status s = camera->SetDetection(decimate, frame_threads); !s) return s;
  return Status::Ok();
}

void RigPoseEstimator::Estimate(const std::vector<cv::Mat>& frames, double timestamp,
                                RigFrameResult* out) const {
  const auto t0 = std::chrono::steady_clock::now();
  out->timestamp = timestamp;
  const size_t n_layouts = layouts().size();
  out->more_poses.resize(n_layouts - 1);
  out->cameras.resize(cameras_.size());
  if (frames.size() != cameras_.size()) {
    for (size_t i = 0; i < n_layouts; ++i) {
      out->object(i) = ObjectPose{};
      out->object(i).message = "got " + std::to_string(frames.size()) +
                               " frames; expected one per camera of the rig (" +
                               std::to_string(cameras_.size()) + ")";
    }
    return;
  }
  for (size_t c = 0; c < cameras_.size(); ++c) {
    if (frames[c].empty()) {
      // Emptied in place: a camera that drops out for a frame and comes back costs no
      // allocation (the C API's promise).
      ResetFrameResult(n_layouts, timestamp, &out->cameras[c]);
      for (size_t i = 0; i < n_layouts; ++i) out->cameras[c].object(i).message = "no frame";
      continue;
    }
    cameras_[c]->Estimate(frames[c], timestamp, &out->cameras[c]);
  }
  thread_local std::vector<MarkerObservation> obs, one;
  for (size_t i = 0; i < n_layouts; ++i) {
    obs.clear();
    for (size_t c = 0; c < cameras_.size(); ++c) {
      ObservationsFromDetections(out->cameras[c].detections, layouts()[i], &one);
      for (MarkerObservation& m : one) {
        m.camera = static_cast<int>(c);
        obs.push_back(m);
      }
    }
    SolveRigObjectPose(views_, obs, options().fusion, &out->object(i));
  }
  out->latency_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}

}  // namespace svms

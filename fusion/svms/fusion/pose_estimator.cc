#include "svms/fusion/pose_estimator.h"

#include <algorithm>
#include <filesystem>
#include <memory>

#include "svms/camera/bayer_luminance.h"
#include "svms/camera/camera_covariance.h"
#include "svms/marker/model_io.h"

namespace svms {
namespace {
using Clock = std::chrono::steady_clock;

// The models the detector needs: every layout entry's marker (inner markers come with it).
std::vector<MarkerModel> Models(const Layout& layout) {
  std::vector<MarkerModel> models;
  for (const LayoutEntry& e : layout.markers) models.push_back(e.marker);
  return models;
}
// The detector's options for frames read through `photometric`: a Bayer mosaic turned into
// luminance gets the corner fit's wider row window (CornerRowWindowPx), as `svms detect` does.
DetectorOptions ForFrames(const PoseEstimatorOptions& o) {
  DetectorOptions d = o.detector;
  if (o.photometric)
    d.refine.max_row_window_px =
        std::max(d.refine.max_row_window_px, CornerRowWindowPx(*o.photometric));
  return d;
}
}  // namespace

PoseEstimator::PoseEstimator(const CameraModel& camera, const Layout& layout,
                             const PoseEstimatorOptions& options)
    : camera_(camera),
      layout_(layout),
      options_(options),
      detector_(ForFrames(options), camera, Models(layout)),
      linearizer_(options.photometric.value_or(PhotometricModel())) {}

Status PoseEstimator::Create(const CameraModel& camera, const Layout& layout,
                             const PoseEstimatorOptions& options,
                             std::unique_ptr<PoseEstimator>* out) {
  if (camera.empty()) return Status::Error("camera: expected a camera model, got an empty one");
  if (layout.markers.empty()) return Status::Error("layout: expected at least one marker");
  if (Status s = layout.Validate(); !s) return Status::Error("layout: " + s.message());
  const ObjectPoseOptions& f = options.fusion;
  if (!(f.corner_sigma_px > 0) || !std::isfinite(f.corner_sigma_px))
    return Status::Error("corner_sigma_px: expected a positive number of pixels, got " +
                         std::to_string(f.corner_sigma_px));
  if (!(f.min_tip_sigma_px > 0) || !std::isfinite(f.min_tip_sigma_px))
    return Status::Error("min_tip_sigma_px: expected a positive number of pixels, got " +
                         std::to_string(f.min_tip_sigma_px));
  if (!(options.budget_ms >= 0) || !std::isfinite(options.budget_ms))
    return Status::Error("budget_ms: expected 0 (none) or a positive number of milliseconds, got " +
                         std::to_string(options.budget_ms));
  if (options.photometric)
    if (Status s = options.photometric->Check(); !s)
      return Status::Error("photometric: " + s.message());
  out->reset(new PoseEstimator(camera, layout, options));
  return Status::Ok();
}

Status PoseEstimator::CreateFromFiles(const std::string& camera_path,
                                      const std::string& layout_path,
                                      const PoseEstimatorOptions& options,
                                      std::unique_ptr<PoseEstimator>* out) {
  CameraModel camera;
  if (Status s = ReadCameraWithSidecar(camera_path, &camera); !s) return s;
  ModelFile file;
  if (Status s = ReadModelFile(layout_path, &file); !s) return s;
  if (file.kind != ModelFile::Kind::kLayout)
    return Status::Error(layout_path + ": expected a layout (\"type\": \"svms.layout\"), got a " +
                         (file.kind == ModelFile::Kind::kMarker ? "marker" : "marker set") +
                         " file");
  PoseEstimatorOptions with_photometry = options;
  const std::string photometric_path = PhotometricPath(camera_path);
  std::error_code ec;
  if (!options.photometric && std::filesystem::exists(photometric_path, ec)) {
    PhotometricModel m;
    if (Status s = ReadPhotometricFile(photometric_path, &m); !s) return s;
    with_photometry.photometric = m;
  }
  Status s = Create(camera, file.layout, with_photometry, out);
  if (!s) return Status::Error(layout_path + ": " + s.message());
  return Status::Ok();
}

void PoseEstimator::Estimate(const cv::Mat& image, double timestamp, FrameResult* out) const {
  if (!options_.photometric) return EstimateLinear(image, timestamp, out);
  thread_local cv::Mat linear;  // reused: no allocation per frame of one size
  if (Status s = linearizer_.Apply(image, &linear); !s) {
    *out = FrameResult();
    out->timestamp = timestamp;
    out->pose.valid = false;
    out->pose.message = "the frame cannot be converted to linear light: " + s.message();
    return;
  }
  EstimateLinear(linear, timestamp, out);
}

void PoseEstimator::EstimateLinear(const cv::Mat& image, double timestamp, FrameResult* out) const {
  const auto t0 = Clock::now();
  out->timestamp = timestamp;
  DetectionStats stats;
  const auto deadline =
      options_.budget_ms > 0
          ? t0 + std::chrono::duration_cast<Clock::duration>(
                     std::chrono::duration<double, std::milli>(options_.budget_ms))
          : Clock::time_point::max();
  detector_.Detect(image, &stats, deadline, &out->detections);
  const auto t1 = Clock::now();
  out->detect_ms = std::chrono::duration<double, std::milli>(t1 - t0).count();
  out->budget_exceeded = stats.budget_exceeded;
  thread_local std::vector<MarkerObservation> obs;  // no allocation per frame once grown
  ObservationsFromDetections(out->detections, layout_, &obs);
  SolveObjectPose(camera_, obs, options_.fusion, &out->pose);
  out->latency_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
}

}  // namespace svms

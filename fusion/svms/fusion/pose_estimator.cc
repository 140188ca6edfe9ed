#include "svms/fusion/pose_estimator.h"

#include <algorithm>
#include <filesystem>
#include <map>
#include <memory>

#include "svms/camera/bayer_luminance.h"
#include "svms/camera/camera_covariance.h"
#include "svms/marker/model_io.h"

namespace svms {
namespace {
using Clock = std::chrono::steady_clock;

// The models the detector needs: every layout entry's marker (inner markers come with it), of
// every layout.
std::vector<MarkerModel> Models(const std::vector<Layout>& layouts) {
  std::vector<MarkerModel> models;
  for (const Layout& layout : layouts)
    for (const LayoutEntry& e : layout.markers) models.push_back(e.marker);
  return models;
}
// Every ID of the layouts (outer and inner markers), ascending.
std::vector<int> LayoutIds(const std::vector<Layout>& layouts) {
  std::vector<int> ids;
  for (const Layout& layout : layouts)
    for (const LayoutEntry& e : layout.markers) {
      ids.push_back(e.marker.id);
      if (e.marker.inner) ids.push_back(e.marker.inner->id);
    }
  std::sort(ids.begin(), ids.end());
  return ids;
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

PoseEstimator::PoseEstimator(const CameraModel& camera, const std::vector<Layout>& layouts,
                             const PoseEstimatorOptions& options)
    : camera_(camera),
      layouts_(layouts),
      layout_ids_(LayoutIds(layouts)),
      options_(options),
      detector_(ForFrames(options), camera, Models(layouts)),
      linearizer_(options.photometric.value_or(PhotometricModel())) {}

Status PoseEstimator::Create(const CameraModel& camera, const Layout& layout,
                             const PoseEstimatorOptions& options,
                             std::unique_ptr<PoseEstimator>* out) {
  return CreateLabelled(camera, {layout}, {""}, options, out);
}

Status PoseEstimator::Create(const CameraModel& camera, const std::vector<Layout>& layouts,
                             const PoseEstimatorOptions& options,
                             std::unique_ptr<PoseEstimator>* out) {
  std::vector<std::string> labels;
  for (size_t i = 0; i < layouts.size(); ++i)
    labels.push_back("layouts[" + std::to_string(i) + "]" +
                     (layouts[i].name.empty() ? "" : " '" + layouts[i].name + "'"));
  return CreateLabelled(camera, layouts, labels, options, out);
}

Status PoseEstimator::CreateLabelled(const CameraModel& camera, const std::vector<Layout>& layouts,
                                     const std::vector<std::string>& labels,
                                     const PoseEstimatorOptions& options,
                                     std::unique_ptr<PoseEstimator>* out) {
  if (camera.empty()) return Status::Error("camera: expected a camera model, got an empty one");
  if (layouts.empty()) return Status::Error("layouts: expected at least one layout");
  // Each layout's errors start with its label ("" for a lone layout: the caller names it).
  const auto prefix = [&](size_t i) { return labels[i].empty() ? "" : labels[i] + ": "; };
  std::map<int, size_t> layout_of_id;
  for (size_t i = 0; i < layouts.size(); ++i) {
    const Layout& layout = layouts[i];
    if (layout.markers.empty())
      return Status::Error(prefix(i) + "layout: expected at least one marker");
    if (Status s = layout.Validate(); !s)
      return Status::Error(prefix(i) + "layout: " + s.message());
    for (const LayoutEntry& e : layout.markers)
      for (int id : {e.marker.id, e.marker.inner ? e.marker.inner->id : -1}) {
        if (id < 0) continue;
        const auto [it, inserted] = layout_of_id.emplace(id, i);
        if (!inserted)
          return Status::Error(prefix(i) + "marker ID " + std::to_string(id) + " is also in " +
                               labels[it->second] +
                               "; expected each marker ID in one layout only (a detection "
                               "must belong to one object)");
      }
  }
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
  out->reset(new PoseEstimator(camera, layouts, options));
  return Status::Ok();
}

Status PoseEstimator::SetDetection(int decimate, int frame_threads) {
  if (decimate < 1 || decimate > kMaxDecimate)
    return Status::Error("decimate: expected 1 to " + std::to_string(kMaxDecimate) + ", got " +
                         std::to_string(decimate));
  if (frame_threads < 1 || frame_threads > kMaxDetectorThreads)
    return Status::Error("frame_threads: expected 1 to " + std::to_string(kMaxDetectorThreads) +
                         ", got " + std::to_string(frame_threads));
  PoseEstimatorOptions changed = options_;
  changed.detector.decimate = decimate;
  changed.detector.threads = frame_threads;
  // Made before anything changes, so that a failure to start threads leaves the estimator whole.
  Detector detector(ForFrames(changed), camera_, Models(layouts_));
  detector_ = std::move(detector);
  options_ = std::move(changed);
  return Status::Ok();
}

namespace {
// The options with the camera's photometric file when there is one and options.photometric is
// unset.
Status WithPhotometry(const std::string& camera_path, const PoseEstimatorOptions& options,
                      PoseEstimatorOptions* with_photometry) {
  *with_photometry = options;
  const std::string photometric_path = PhotometricPath(camera_path);
  std::error_code ec;
  if (!options.photometric && std::filesystem::exists(photometric_path, ec)) {
    PhotometricModel m;
    if (Status s = ReadPhotometricFile(photometric_path, &m); !s) return s;
    with_photometry->photometric = m;
  }
  return Status::Ok();
}

Status ReadLayoutFile(const std::string& layout_path, Layout* layout) {
  ModelFile file;
  if (Status s = ReadModelFile(layout_path, &file); !s) return s;
  if (file.kind != ModelFile::Kind::kLayout)
    return Status::Error(layout_path + ": expected a layout (\"type\": \"svms.layout\"), got a " +
                         (file.kind == ModelFile::Kind::kMarker ? "marker" : "marker set") +
                         " file");
  *layout = std::move(file.layout);
  return Status::Ok();
}
}  // namespace

Status PoseEstimator::CreateFromFiles(const std::string& camera_path,
                                      const std::string& layout_path,
                                      const PoseEstimatorOptions& options,
                                      std::unique_ptr<PoseEstimator>* out) {
  CameraModel camera;
  PoseEstimatorOptions with_photometry;
  Layout layout;
  if (Status s = ReadCameraWithSidecar(camera_path, &camera); !s) return s;
  if (Status s = ReadLayoutFile(layout_path, &layout); !s) return s;
  if (Status s = WithPhotometry(camera_path, options, &with_photometry); !s) return s;
  Status s = Create(camera, layout, with_photometry, out);
  if (!s) return Status::Error(layout_path + ": " + s.message());
  return Status::Ok();
}

Status PoseEstimator::CreateFromFiles(const std::string& camera_path,
                                      const std::vector<std::string>& layout_paths,
                                      const PoseEstimatorOptions& options,
                                      std::unique_ptr<PoseEstimator>* out) {
  CameraModel camera;
  PoseEstimatorOptions with_photometry;
  if (Status s = ReadCameraWithSidecar(camera_path, &camera); !s) return s;
  std::vector<Layout> layouts(layout_paths.size());
  for (size_t i = 0; i < layout_paths.size(); ++i)
    if (Status s = ReadLayoutFile(layout_paths[i], &layouts[i]); !s) return s;
  if (Status s = WithPhotometry(camera_path, options, &with_photometry); !s) return s;
  return CreateLabelled(camera, layouts, layout_paths, with_photometry, out);
}

void ResetFrameResult(size_t n_layouts, double timestamp, FrameResult* result) {
  ObjectPose pose = std::move(result->pose);
  std::vector<ObjectPose> more_poses = std::move(result->more_poses);
  std::vector<Detection> detections = std::move(result->detections);
  std::vector<int> unassigned_ids = std::move(result->unassigned_ids);
  *result = FrameResult{};
  result->timestamp = timestamp;
  result->pose = std::move(pose);
  result->more_poses = std::move(more_poses);
  result->more_poses.resize(n_layouts - 1);
  for (size_t i = 0; i < n_layouts; ++i) ResetObjectPose(&result->object(i));
  result->detections = std::move(detections);
  result->detections.clear();
  result->unassigned_ids = std::move(unassigned_ids);
  result->unassigned_ids.clear();
}

void PoseEstimator::Estimate(const cv::Mat& image, double timestamp, FrameResult* out) const {
  if (!options_.photometric) return EstimateLinear(image, timestamp, out);
  // The budget and the latency start here: the conversion to linear light and the stored-noise
  // estimate are part of the frame's time (a flight loop's deadline is the whole call's).
  const auto t0 = Clock::now();
  const auto deadline = DeadlineFrom(t0);
  // A raw frame's noise from its stored values, below the black level included (the linear
  // image clips them at 0): a sixteenth of the pixels, under the frame's deadline.
  NoiseModel stored_noise;
  const bool have_noise =
      EstimateStoredNoise(image, *options_.photometric, deadline, &stored_noise);
  thread_local cv::Mat linear;  // reused: no allocation per frame of one size
  if (Status s = linearizer_.Apply(image, &linear); !s) {
    ResetFrameResult(layouts_.size(), timestamp, out);
    for (size_t i = 0; i < layouts_.size(); ++i)
      out->object(i).message = "the frame cannot be converted to linear light: " + s.message();
    out->latency_ms = std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    return;
  }
  EstimateFrom(linear, timestamp, t0, deadline, have_noise ? &stored_noise : nullptr, out);
}

Clock::time_point PoseEstimator::DeadlineFrom(Clock::time_point t0) const {
  return options_.budget_ms > 0
             ? t0 + std::chrono::duration_cast<Clock::duration>(
                        std::chrono::duration<double, std::milli>(options_.budget_ms))
             : Clock::time_point::max();
}

void PoseEstimator::EstimateLinear(const cv::Mat& image, double timestamp, FrameResult* out,
                                   const NoiseModel* noise) const {
  const auto t0 = Clock::now();
  EstimateFrom(image, timestamp, t0, DeadlineFrom(t0), noise, out);
}

void PoseEstimator::EstimateFrom(const cv::Mat& image, double timestamp, Clock::time_point t0,
                                 Clock::time_point deadline, const NoiseModel* noise,
                                 FrameResult* out) const {
  out->timestamp = timestamp;
  DetectionStats stats;
  // One detection pass for every layout: the detector knows the models of all of them.
  const auto t_detect = Clock::now();
  detector_.Detect(image, &stats, deadline, &out->detections, noise);
  out->detection_passes = 1;
  const auto t1 = Clock::now();
  out->detect_ms = std::chrono::duration<double, std::milli>(t1 - t_detect).count();
  out->budget_exceeded = stats.budget_exceeded;
  // Each layout's object from its own detections, independently of the others (the same call
  // as for a lone layout, so the poses equal those of one estimator per layout).
  out->more_poses.resize(layouts_.size() - 1);      // no allocation once grown
  thread_local std::vector<MarkerObservation> obs;  // no allocation per frame once grown
  for (size_t i = 0; i < layouts_.size(); ++i) {
    ObservationsFromDetections(out->detections, layouts_[i], &obs);
    SolveObjectPose(camera_, obs, options_.fusion, &out->object(i));
  }
  out->unassigned_ids.clear();
  for (const Detection& d : out->detections)
    if (!std::binary_search(layout_ids_.begin(), layout_ids_.end(), d.id))
      out->unassigned_ids.push_back(d.id);
  const auto t2 = Clock::now();
  out->fuse_ms = std::chrono::duration<double, std::milli>(t2 - t1).count();
  out->latency_ms = std::chrono::duration<double, std::milli>(t2 - t0).count();
}

}  // namespace svms

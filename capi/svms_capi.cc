// The C API (svms/svms.h) over svms::PoseEstimator. Every entry point catches everything: no
// exception crosses into C. Handles are checked against a registry of live estimators, and a
// destroyed estimator's shell is never freed, so that a call through it is detected rather than
// undefined.
#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <memory>
#include <mutex>
#include <new>
#include <opencv2/core.hpp>
#include <string>
#include <unordered_set>
#include <vector>

#include "svms/fusion/pose_estimator.h"
#include "svms/fusion/rig_pose_estimator.h"
#include "svms/svms.h"

struct svms_estimator {
  static constexpr uint64_t kMagic = 0x53564d5345535431ull;  // "SVMSEST1"
  uint64_t magic = kMagic;
  std::unique_ptr<svms::PoseEstimator> impl;
  svms::FrameResult* scratch = nullptr;  // reused every frame (its vectors keep their capacity)
  std::atomic<bool> busy{false};
};

struct svms_rig_estimator {
  static constexpr uint64_t kMagic = 0x53564d5352494731ull;  // "SVMSRIG1"
  uint64_t magic = kMagic;
  std::unique_ptr<svms::RigPoseEstimator> impl;
  svms::RigFrameResult* scratch = nullptr;  // reused every frame
  std::vector<cv::Mat>* frames = nullptr;   // reused every frame: views of the caller's pixels
  std::atomic<bool> busy{false};
};

namespace {

std::mutex registry_mutex;
std::unordered_set<const svms_rig_estimator*>& LiveRigs() {
  static auto* live = new std::unordered_set<const svms_rig_estimator*>;
  return *live;
}
std::unordered_set<const svms_estimator*>& Live() {
  static auto* live = new std::unordered_set<const svms_estimator*>;
  return *live;
}

thread_local std::string last_error;

// Sets svms_last_error() to the pieces (C or std::strings) joined, and returns s. The pieces
// are joined inside the try, so the wording may run out of memory: the status still tells.
template <typename... Pieces>
svms_status Fail(svms_status s, const Pieces&... pieces) noexcept {
  try {
    last_error.clear();
    (last_error.append(pieces), ...);
  } catch (...) {
  }
  return s;
}

// Runs an entry point's body so that nothing thrown in it -- by the estimator, or by the
// wording of an error message, or by a lock -- crosses into C: `extern "C"` callers cannot
// catch, and an exception there would end the program.
template <typename Body>
svms_status Guarded(const char* fn, Body&& body) noexcept {
  try {
    return body();
  } catch (const std::bad_alloc&) {
    return Fail(SVMS_ERR_INTERNAL, fn, ": out of memory");
  } catch (const std::exception& ex) {
    return Fail(SVMS_ERR_INTERNAL, fn, ": ", ex.what());
  } catch (...) {
    return Fail(SVMS_ERR_INTERNAL, fn, ": unknown failure");
  }
}

// What the registry knows of each kind of handle: its live handles and the function that
// creates them (named in errors).
template <typename Handle>
struct HandleKind;
template <>
struct HandleKind<svms_estimator> {
  static std::unordered_set<const svms_estimator*>& live() { return Live(); }
  static constexpr const char* kCreator = "svms_create";
};
template <>
struct HandleKind<svms_rig_estimator> {
  static std::unordered_set<const svms_rig_estimator*>& live() { return LiveRigs(); }
  static constexpr const char* kCreator = "svms_create_rig";
};

// Whether `e` came from its create function and has not been destroyed; the caller holds
// registry_mutex. Otherwise SVMS_ERR_BAD_HANDLE, the call named by `fn`.
template <typename Handle>
svms_status CheckLiveLocked(const char* fn, const Handle* e) {
  if (HandleKind<Handle>::live().count(e) && e->magic == Handle::kMagic && e->impl) return SVMS_OK;
  return Fail(SVMS_ERR_BAD_HANDLE, fn, ": the estimator is not one from ",
              HandleKind<Handle>::kCreator, ", or was destroyed");
}

// A handle one call holds: its busy flag, set by ClaimHandle, cleared when the claim ends.
template <typename Handle>
struct HandleClaim {
  Handle* e = nullptr;
  HandleClaim() = default;
  HandleClaim(const HandleClaim&) = delete;
  HandleClaim& operator=(const HandleClaim&) = delete;
  ~HandleClaim() {
    if (e) e->busy.store(false);
  }
};

// Checks `e` and sets its busy flag, both under registry_mutex, the lock every check and claim
// takes: a destroy can never free a handle between another call's check and its use, nor one a
// call is using. SVMS_ERR_BAD_HANDLE (see CheckLiveLocked) or SVMS_ERR_BUSY for a handle another
// thread is using, `fn` naming the call; the caller holds registry_mutex.
template <typename Handle>
svms_status SetBusyLocked(const char* fn, Handle* e) {
  if (const svms_status s = CheckLiveLocked(fn, e); s != SVMS_OK) return s;
  bool expected = false;
  if (!e->busy.compare_exchange_strong(expected, true))
    return Fail(SVMS_ERR_BUSY, fn, ": the estimator is in use by another thread");
  return SVMS_OK;
}

// Claims `e` for this call (SetBusyLocked): *claim releases it when it ends. No allocation but
// in wording an error.
template <typename Handle>
svms_status ClaimHandle(const char* fn, Handle* e, HandleClaim<Handle>* claim) {
  std::lock_guard<std::mutex> lock(registry_mutex);
  if (const svms_status s = SetBusyLocked(fn, e); s != SVMS_OK) return s;
  claim->e = e;
  return SVMS_OK;
}

// Claims `e` for its destroy, for good: it leaves the live handles, so that every later call
// through it is SVMS_ERR_BAD_HANDLE, and its busy flag stays set.
template <typename Handle>
svms_status ClaimForDestroy(const char* fn, Handle* e) {
  std::lock_guard<std::mutex> lock(registry_mutex);
  if (const svms_status s = SetBusyLocked(fn, e); s != SVMS_OK) return s;
  HandleKind<Handle>::live().erase(e);
  return SVMS_OK;
}

// ", expected at least W and a multiple of B" for a frame's stride (the multiple only for
// B > 1), `width` pixels of `bytes_per_pixel` bytes.
std::string ExpectedStride(int width, int bytes_per_pixel) {
  return ", expected at least " + std::to_string(static_cast<long long>(width) * bytes_per_pixel) +
         (bytes_per_pixel > 1 ? " and a multiple of " + std::to_string(bytes_per_pixel) : "");
}

// A pose as rvec[3], tvec[3] and quaternion[4] ([w, x, y, z]).
void PoseOut(const svms::Pose& pose, double* rvec, double* tvec, double* quaternion) {
  const Eigen::Quaterniond q(pose.Rotation());
  for (int i = 0; i < 3; ++i) {
    rvec[i] = pose.rvec[i];
    tvec[i] = pose.tvec[i];
  }
  quaternion[0] = q.w();
  quaternion[1] = q.x();
  quaternion[2] = q.y();
  quaternion[3] = q.z();
}

// A fused pose into *out, with the frame's time stamp, latency and budget flag.
void FillPose(const svms::ObjectPose& p, double timestamp, double latency_ms, bool budget_exceeded,
              svms_pose* out) {
  *out = svms_pose{};
  out->timestamp = timestamp;
  out->valid = p.valid ? 1 : 0;
  out->markers_seen = p.markers_seen;
  out->markers_used = p.markers_used;
  out->points_used = p.points_used;
  const size_t n = std::min<size_t>(p.ids_used.size(), SVMS_MAX_REPORTED_MARKERS);
  for (size_t i = 0; i < n; ++i) out->marker_ids[i] = p.ids_used[i];
  out->rms_px = p.rms_px;
  out->chi2 = p.chi2;
  out->dof = p.dof;
  out->flags = (p.ambiguous ? SVMS_FLAG_AMBIGUOUS : 0u) |
               (p.poorly_conditioned ? SVMS_FLAG_POORLY_CONDITIONED : 0u) |
               (budget_exceeded ? SVMS_FLAG_BUDGET_EXCEEDED : 0u) |
               (p.ids_rejected.empty() ? 0u : SVMS_FLAG_MARKER_REJECTED) |
               (p.calibration_in_covariance ? SVMS_FLAG_CALIBRATION_IN_COVARIANCE : 0u) |
               (p.extrinsics_in_covariance ? SVMS_FLAG_EXTRINSICS_IN_COVARIANCE : 0u) |
               (p.from_marker_pose ? SVMS_FLAG_MARKER_POSE_WITH_EDGES : 0u);
  out->latency_ms = latency_ms;
  if (!p.valid) return;
  PoseOut(p.cam_from_object, out->rvec, out->tvec, out->quaternion);
  for (int a = 0; a < 6; ++a)
    for (int b = 0; b < 6; ++b) out->covariance[a * 6 + b] = p.covariance(a, b);
  if (p.bias_columns() > 0) {
    const Eigen::Matrix<double, 6, 6> common = p.bias_factor() * p.bias_factor().transpose();
    for (int a = 0; a < 6; ++a)
      for (int b = 0; b < 6; ++b) out->covariance_common[a * 6 + b] = common(a, b);
  }
  if (p.alternative_cam_from_object) {
    out->has_alternative = 1;
    PoseOut(*p.alternative_cam_from_object, out->alternative_rvec, out->alternative_tvec,
            out->alternative_quaternion);
    out->alternative_weight = p.alternative_weight;
  }
}

// Layout `object`'s pose of frame r.
void Fill(const svms::FrameResult& r, size_t object, svms_pose* out) {
  FillPose(r.object(object), r.timestamp, r.latency_ms, r.budget_exceeded, out);
}

void FillInfo(const svms::FrameResult& r, svms_frame_info* info) {
  *info = svms_frame_info{};
  info->timestamp = r.timestamp;
  info->latency_ms = r.latency_ms;
  info->detect_ms = r.detect_ms;
  info->fuse_ms = r.fuse_ms;
  info->flags = r.budget_exceeded ? SVMS_FLAG_BUDGET_EXCEEDED : 0u;
  info->n_unassigned = static_cast<int>(r.unassigned_ids.size());
  const size_t n = std::min<size_t>(r.unassigned_ids.size(), SVMS_MAX_REPORTED_MARKERS);
  for (size_t i = 0; i < n; ++i) info->unassigned_ids[i] = r.unassigned_ids[i];
}

// One frame into poses[0, n_poses). `all_objects`: svms_process_frame_multi, which needs
// n_poses to be the number of layouts and writes every object; else svms_process_frame, which
// writes the first layout's object into poses[0] (n_poses 1). `fn` names the call in errors
// (a std::string is built only on an error: a frame makes no heap allocation).
svms_status Process(const char* fn, svms_estimator* e, const void* pixels, int width, int height,
                    ptrdiff_t stride, int bytes_per_pixel, double timestamp, svms_pose* poses,
                    int n_poses, bool all_objects, svms_frame_info* info) {
  if (!e || !pixels || !poses)
    return Fail(SVMS_ERR_NULL_ARGUMENT, std::string(fn) + ": " +
                                            (!e            ? "estimator"
                                             : !pixels     ? "pixels"
                                             : all_objects ? "poses"
                                                           : "out") +
                                            " is NULL");
  for (int i = 0; i < n_poses; ++i) {
    poses[i] = svms_pose{};
    poses[i].timestamp = timestamp;
  }
  if (info) {
    *info = svms_frame_info{};
    info->timestamp = timestamp;
  }
  // From here on this call holds the handle: every return releases it.
  HandleClaim<svms_estimator> claim;
  if (const svms_status s = ClaimHandle(fn, e, &claim); s != SVMS_OK) return s;
  // Until this frame's poses are in, the last ones are no longer this handle's last frame
  // (svms_last_bias_factor must not give them after a call that failed).
  e->scratch->pose.valid = false;
  for (svms::ObjectPose& p : e->scratch->more_poses) p.valid = false;
  const int layouts = static_cast<int>(e->impl->layouts().size());
  if (all_objects && n_poses != layouts)
    return Fail(SVMS_ERR_INVALID_ARGUMENT,
                std::string(fn) + ": n_poses is " + std::to_string(n_poses) +
                    ", expected the estimator's number of layouts, " + std::to_string(layouts));
  const svms::CameraModel& cam = e->impl->camera();
  if (width != cam.width() || height != cam.height())
    return Fail(SVMS_ERR_INVALID_ARGUMENT,
                std::string(fn) + ": frame is " + std::to_string(width) + "x" +
                    std::to_string(height) + " pixels, the camera model " +
                    std::to_string(cam.width()) + "x" + std::to_string(cam.height()));
  if (stride < static_cast<ptrdiff_t>(width) * bytes_per_pixel || stride % bytes_per_pixel != 0)
    return Fail(SVMS_ERR_INVALID_ARGUMENT, std::string(fn) + ": stride " + std::to_string(stride) +
                                               " bytes" + ExpectedStride(width, bytes_per_pixel));
  if (!std::isfinite(timestamp))
    return Fail(SVMS_ERR_INVALID_ARGUMENT, std::string(fn) + ": timestamp is not finite");
  svms_status status = SVMS_OK;
  try {
    // Zero-copy view of the caller's pixels.
    const cv::Mat image(height, width, bytes_per_pixel == 1 ? CV_8UC1 : CV_16UC1,
                        const_cast<void*>(pixels), static_cast<size_t>(stride));
    e->impl->Estimate(image, timestamp, e->scratch);
    for (int i = 0; i < n_poses; ++i) Fill(*e->scratch, static_cast<size_t>(i), &poses[i]);
    if (info) FillInfo(*e->scratch, info);
  } catch (const std::bad_alloc&) {
    status = Fail(SVMS_ERR_INTERNAL, std::string(fn) + ": out of memory");
  } catch (const std::exception& ex) {
    status = Fail(SVMS_ERR_INTERNAL, std::string(fn) + ": " + ex.what());
  } catch (...) {
    status = Fail(SVMS_ERR_INTERNAL, std::string(fn) + ": unknown failure");
  }
  return status;
}

// svms_last_bias_factor and svms_last_rig_bias_factor: the handle checked and claimed as
// Process claims it, the last frame's result of layout `object` copied out.
template <typename Handle>
svms_status LastBiasFactor(const char* fn, Handle* e, int object, double* out, int capacity_columns,
                           int* columns) {
  if (!e || !columns)
    return Fail(SVMS_ERR_NULL_ARGUMENT,
                std::string(fn) + ": " + (!e ? "estimator" : "columns") + " is NULL");
  *columns = 0;
  HandleClaim<Handle> claim;
  if (const svms_status s = ClaimHandle(fn, e, &claim); s != SVMS_OK) return s;
  if (capacity_columns < 0)
    return Fail(SVMS_ERR_INVALID_ARGUMENT, std::string(fn) + ": capacity_columns is " +
                                               std::to_string(capacity_columns) +
                                               ", expected 0 or more");
  const int layouts = static_cast<int>(e->impl->layouts().size());
  if (object < 0 || object >= layouts)
    return Fail(SVMS_ERR_INVALID_ARGUMENT, std::string(fn) + ": object is " +
                                               std::to_string(object) + ", expected 0 to " +
                                               std::to_string(layouts - 1));
  if (static_cast<size_t>(object) > e->scratch->more_poses.size()) return SVMS_OK;  // no frame
  const svms::ObjectPose& p = e->scratch->object(static_cast<size_t>(object));
  const int k = p.valid ? p.bias_columns() : 0;
  *columns = k;
  if (!out && capacity_columns == 0) return SVMS_OK;  // the size query
  if (k > capacity_columns)
    return Fail(SVMS_ERR_INVALID_ARGUMENT,
                std::string(fn) + ": capacity_columns is " + std::to_string(capacity_columns) +
                    ", the factor has " + std::to_string(k) + " columns");
  if (k > 0 && !out) return Fail(SVMS_ERR_NULL_ARGUMENT, std::string(fn) + ": out is NULL");
  std::copy(p.bias_factor_values.begin(), p.bias_factor_values.begin() + 6 * k, out);
  return SVMS_OK;
}

// svms_set_detection and svms_set_rig_detection: the handle claimed as Process claims it (a
// frame in progress on another thread is SVMS_ERR_BUSY), then the estimator's detector made
// anew with the values, or left as it was when they are out of range.
template <typename Handle>
svms_status SetDetection(const char* fn, Handle* e, int decimate, int frame_threads) {
  if (!e) return Fail(SVMS_ERR_NULL_ARGUMENT, fn, ": estimator is NULL");
  HandleClaim<Handle> claim;
  if (const svms_status s = ClaimHandle(fn, e, &claim); s != SVMS_OK) return s;
  if (const svms::Status s = e->impl->SetDetection(decimate, frame_threads); !s)
    return Fail(SVMS_ERR_INVALID_ARGUMENT, fn, ": ", s.message());
  return SVMS_OK;
}

// svms_process_rig_frame(_u16): `Frame` is svms_rig_frame (8-bit pixels) or svms_rig_frame_u16
// (16-bit); `fn` names the call in errors (a std::string is built only on an error: a frame makes
// no heap allocation).
template <typename Frame>
svms_status ProcessRig(const char* fn, svms_rig_estimator* e, const Frame* frames, int n_frames,
                       double timestamp, svms_pose* out) {
  constexpr int bytes_per_pixel = sizeof(*Frame{}.pixels);
  if (!e || !frames || !out)
    return Fail(SVMS_ERR_NULL_ARGUMENT, std::string(fn) + ": " +
                                            (!e        ? "estimator"
                                             : !frames ? "frames"
                                                       : "out") +
                                            " is NULL");
  *out = svms_pose{};
  out->timestamp = timestamp;
  HandleClaim<svms_rig_estimator> claim;
  if (const svms_status s = ClaimHandle(fn, e, &claim); s != SVMS_OK) return s;
  e->scratch->pose.valid = false;  // as in Process
  for (svms::ObjectPose& p : e->scratch->more_poses) p.valid = false;
  const int cameras = static_cast<int>(e->impl->num_cameras());
  if (n_frames != cameras)
    return Fail(SVMS_ERR_INVALID_ARGUMENT,
                std::string(fn) + ": n_frames is " + std::to_string(n_frames) +
                    ", expected the rig's number of cameras, " + std::to_string(cameras));
  if (!std::isfinite(timestamp))
    return Fail(SVMS_ERR_INVALID_ARGUMENT, std::string(fn) + ": timestamp is not finite");
  for (int c = 0; c < cameras; ++c) {
    const Frame& f = frames[c];
    (*e->frames)[c] = cv::Mat();
    if (!f.pixels) continue;
    const svms::CameraModel& cam = e->impl->camera(static_cast<size_t>(c)).camera();
    if (f.width != cam.width() || f.height != cam.height())
      return Fail(SVMS_ERR_INVALID_ARGUMENT,
                  std::string(fn) + ": frames[" + std::to_string(c) + "] is " +
                      std::to_string(f.width) + "x" + std::to_string(f.height) +
                      " pixels, camera '" + e->impl->rig().cameras[c].name + "' " +
                      std::to_string(cam.width()) + "x" + std::to_string(cam.height()));
    if (f.stride < static_cast<ptrdiff_t>(f.width) * bytes_per_pixel ||
        f.stride % bytes_per_pixel != 0)
      return Fail(SVMS_ERR_INVALID_ARGUMENT, std::string(fn) + ": frames[" + std::to_string(c) +
                                                 "].stride is " + std::to_string(f.stride) +
                                                 " bytes" +
                                                 ExpectedStride(f.width, bytes_per_pixel));
    // Zero-copy views of the caller's pixels.
    (*e->frames)[c] = cv::Mat(f.height, f.width, bytes_per_pixel == 1 ? CV_8UC1 : CV_16UC1,
                              const_cast<void*>(static_cast<const void*>(f.pixels)),
                              static_cast<size_t>(f.stride));
  }
  // What the estimator throws is caught by the caller's Guarded, with the same name, after the
  // claim has released the handle.
  e->impl->Estimate(*e->frames, timestamp, e->scratch);
  bool budget_exceeded = false;
  for (const svms::FrameResult& r : e->scratch->cameras) budget_exceeded |= r.budget_exceeded;
  FillPose(e->scratch->pose, timestamp, e->scratch->latency_ms, budget_exceeded, out);
  return SVMS_OK;
}

}  // namespace

extern "C" {

void svms_options_default(svms_options* options) {
  if (!options) return;
  options->corner_sigma_px = svms::ObjectPoseOptions{}.corner_sigma_px;
  options->budget_ms = 0;
}

namespace {
// svms_create and svms_create_multi: `layout_paths` holds n_layouts non-NULL paths.
svms_status Create(const char* fn, const char* camera_path, const char* const* layout_paths,
                   int n_layouts, const svms_options* options, uint32_t create_flags,
                   svms_estimator** out) {
  try {
    const std::string name = fn;
    svms_options o;
    svms_options_default(&o);
    if (options) o = *options;
    svms::PoseEstimatorOptions po;
    po.fusion.corner_sigma_px = o.corner_sigma_px;
    po.budget_ms = o.budget_ms;
    po.detector.known_ids_only = !(create_flags & SVMS_CREATE_UNKNOWN_IDS);
    if (!(o.corner_sigma_px > 0) || !std::isfinite(o.corner_sigma_px) || !(o.budget_ms >= 0) ||
        !std::isfinite(o.budget_ms))
      return Fail(SVMS_ERR_INVALID_ARGUMENT,
                  name + ": options: expected corner_sigma_px > 0 and budget_ms >= 0, got " +
                      std::to_string(o.corner_sigma_px) + " and " + std::to_string(o.budget_ms));
    if (create_flags & ~SVMS_CREATE_UNKNOWN_IDS)
      return Fail(SVMS_ERR_INVALID_ARGUMENT,
                  name + ": create_flags: unknown bits " +
                      std::to_string(create_flags & ~SVMS_CREATE_UNKNOWN_IDS));
    std::unique_ptr<svms::PoseEstimator> impl;
    const std::vector<std::string> paths(layout_paths, layout_paths + n_layouts);
    if (svms::Status s =
            paths.size() == 1
                ? svms::PoseEstimator::CreateFromFiles(camera_path, paths[0], po, &impl)
                : svms::PoseEstimator::CreateFromFiles(camera_path, paths, po, &impl);
        !s)
      return Fail(SVMS_ERR_FILE, name + ": " + s.message());
    auto e = std::make_unique<svms_estimator>();
    e->impl = std::move(impl);
    e->scratch = new svms::FrameResult;
    {
      std::lock_guard<std::mutex> lock(registry_mutex);
      Live().insert(e.get());
    }
    *out = e.release();
    return SVMS_OK;
  } catch (const std::bad_alloc&) {
    return Fail(SVMS_ERR_INTERNAL, std::string(fn) + ": out of memory");
  } catch (const std::exception& ex) {
    return Fail(SVMS_ERR_INTERNAL, std::string(fn) + ": " + ex.what());
  } catch (...) {
    return Fail(SVMS_ERR_INTERNAL, std::string(fn) + ": unknown failure");
  }
}
}  // namespace

svms_status svms_create(const char* camera_path, const char* layout_path,
                        const svms_options* options, svms_estimator** out) {
  return Guarded("svms_create", [&]() -> svms_status {
    if (!out) return Fail(SVMS_ERR_NULL_ARGUMENT, "svms_create: out is NULL");
    *out = nullptr;
    if (!camera_path || !layout_path)
      return Fail(SVMS_ERR_NULL_ARGUMENT, std::string("svms_create: ") +
                                              (!camera_path ? "camera_path" : "layout_path") +
                                              " is NULL");
    return Create("svms_create", camera_path, &layout_path, 1, options, 0, out);
  });
}

svms_status svms_create_multi(const char* camera_path, const char* const* layout_paths,
                              int n_layouts, const svms_options* options, uint32_t create_flags,
                              svms_estimator** out) {
  return Guarded("svms_create_multi", [&]() -> svms_status {
    if (!out) return Fail(SVMS_ERR_NULL_ARGUMENT, "svms_create_multi: out is NULL");
    *out = nullptr;
    if (!camera_path || !layout_paths)
      return Fail(SVMS_ERR_NULL_ARGUMENT, std::string("svms_create_multi: ") +
                                              (!camera_path ? "camera_path" : "layout_paths") +
                                              " is NULL");
    if (n_layouts < 1)
      return Fail(
          SVMS_ERR_INVALID_ARGUMENT,
          "svms_create_multi: n_layouts is " + std::to_string(n_layouts) + ", expected at least 1");
    for (int i = 0; i < n_layouts; ++i)
      if (!layout_paths[i])
        return Fail(SVMS_ERR_NULL_ARGUMENT,
                    "svms_create_multi: layout_paths[" + std::to_string(i) + "] is NULL");
    return Create("svms_create_multi", camera_path, layout_paths, n_layouts, options, create_flags,
                  out);
  });
}

svms_status svms_layout_count(const svms_estimator* e, int* n_layouts) {
  return Guarded("svms_layout_count", [&]() -> svms_status {
    if (!e || !n_layouts)
      return Fail(SVMS_ERR_NULL_ARGUMENT, std::string("svms_layout_count: ") +
                                              (!e ? "estimator" : "n_layouts") + " is NULL");
    *n_layouts = 0;
    std::lock_guard<std::mutex> lock(registry_mutex);
    if (const svms_status s = CheckLiveLocked("svms_layout_count", e); s != SVMS_OK) return s;
    *n_layouts = static_cast<int>(e->impl->layouts().size());
    return SVMS_OK;
  });
}

svms_status svms_process_frame(svms_estimator* e, const uint8_t* pixels, int width, int height,
                               ptrdiff_t stride, double timestamp, svms_pose* out) {
  return Guarded("svms_process_frame", [&]() -> svms_status {
    return Process("svms_process_frame", e, pixels, width, height, stride, 1, timestamp, out, 1,
                   false, nullptr);
  });
}

svms_status svms_process_frame_u16(svms_estimator* e, const uint16_t* pixels, int width, int height,
                                   ptrdiff_t stride, double timestamp, svms_pose* out) {
  return Guarded("svms_process_frame_u16", [&]() -> svms_status {
    return Process("svms_process_frame_u16", e, pixels, width, height, stride, 2, timestamp, out, 1,
                   false, nullptr);
  });
}

svms_status svms_process_frame_multi(svms_estimator* e, const uint8_t* pixels, int width,
                                     int height, ptrdiff_t stride, double timestamp,
                                     svms_pose* poses, int n_poses, svms_frame_info* info) {
  return Guarded("svms_process_frame_multi", [&]() -> svms_status {
    return Process("svms_process_frame_multi", e, pixels, width, height, stride, 1, timestamp,
                   poses, n_poses, true, info);
  });
}

svms_status svms_process_frame_multi_u16(svms_estimator* e, const uint16_t* pixels, int width,
                                         int height, ptrdiff_t stride, double timestamp,
                                         svms_pose* poses, int n_poses, svms_frame_info* info) {
  return Guarded("svms_process_frame_multi_u16", [&]() -> svms_status {
    return Process("svms_process_frame_multi_u16", e, pixels, width, height, stride, 2, timestamp,
                   poses, n_poses, true, info);
  });
}

svms_status svms_last_bias_factor(svms_estimator* e, int object, double* out, int capacity_columns,
                                  int* columns) {
  return Guarded("svms_last_bias_factor", [&]() -> svms_status {
    return LastBiasFactor<svms_estimator>("svms_last_bias_factor", e, object, out, capacity_columns,
                                          columns);
  });
}

svms_status svms_last_rig_bias_factor(svms_rig_estimator* e, int object, double* out,
                                      int capacity_columns, int* columns) {
  return Guarded("svms_last_rig_bias_factor", [&]() -> svms_status {
    return LastBiasFactor<svms_rig_estimator>("svms_last_rig_bias_factor", e, object, out,
                                              capacity_columns, columns);
  });
}

svms_status svms_set_detection(svms_estimator* e, int decimate, int frame_threads) {
  return Guarded("svms_set_detection", [&]() -> svms_status {
    return SetDetection("svms_set_detection", e, decimate, frame_threads);
  });
}

svms_status svms_set_rig_detection(svms_rig_estimator* e, int decimate, int frame_threads) {
  return Guarded("svms_set_rig_detection", [&]() -> svms_status {
    return SetDetection("svms_set_rig_detection", e, decimate, frame_threads);
  });
}

svms_status svms_destroy(svms_estimator* e) {
  return Guarded("svms_destroy", [&]() -> svms_status {
    if (!e) return SVMS_OK;
    // Claimed for good: a call in progress keeps its handle, and no later call gets it.
    if (const svms_status s = ClaimForDestroy("svms_destroy", e); s != SVMS_OK) return s;
    // Free everything but the shell (see the header): the address is never handed out again.
    e->impl.reset();
    delete e->scratch;
    e->scratch = nullptr;
    e->magic = 0;
    return SVMS_OK;
  });
}

svms_status svms_create_rig(const char* rig_path, const char* layout_path,
                            const svms_options* options, svms_rig_estimator** out) {
  return Guarded("svms_create_rig", [&]() -> svms_status {
    if (!out) return Fail(SVMS_ERR_NULL_ARGUMENT, "svms_create_rig: out is NULL");
    *out = nullptr;
    if (!rig_path || !layout_path)
      return Fail(
          SVMS_ERR_NULL_ARGUMENT,
          std::string("svms_create_rig: ") + (!rig_path ? "rig_path" : "layout_path") + " is NULL");
    try {
      svms_options o;
      svms_options_default(&o);
      if (options) o = *options;
      if (!(o.corner_sigma_px > 0) || !std::isfinite(o.corner_sigma_px) || !(o.budget_ms >= 0) ||
          !std::isfinite(o.budget_ms))
        return Fail(SVMS_ERR_INVALID_ARGUMENT,
                    "svms_create_rig: options: expected corner_sigma_px > 0 and budget_ms >= 0, "
                    "got " +
                        std::to_string(o.corner_sigma_px) + " and " + std::to_string(o.budget_ms));
      svms::PoseEstimatorOptions po;
      po.fusion.corner_sigma_px = o.corner_sigma_px;
      po.budget_ms = o.budget_ms;
      std::unique_ptr<svms::RigPoseEstimator> impl;
      if (svms::Status s =
              svms::RigPoseEstimator::CreateFromFiles(rig_path, {layout_path}, po, &impl);
          !s)
        return Fail(SVMS_ERR_FILE, "svms_create_rig: " + s.message());
      auto e = std::make_unique<svms_rig_estimator>();
      e->impl = std::move(impl);
      e->scratch = new svms::RigFrameResult;
      e->frames = new std::vector<cv::Mat>(e->impl->num_cameras());
      {
        std::lock_guard<std::mutex> lock(registry_mutex);
        LiveRigs().insert(e.get());
      }
      *out = e.release();
      return SVMS_OK;
    } catch (const std::bad_alloc&) {
      return Fail(SVMS_ERR_INTERNAL, "svms_create_rig: out of memory");
    } catch (const std::exception& ex) {
      return Fail(SVMS_ERR_INTERNAL, std::string("svms_create_rig: ") + ex.what());
    } catch (...) {
      return Fail(SVMS_ERR_INTERNAL, "svms_create_rig: unknown failure");
    }
  });
}

svms_status svms_rig_camera_count(const svms_rig_estimator* e, int* n_cameras) {
  return Guarded("svms_rig_camera_count", [&]() -> svms_status {
    if (!e || !n_cameras)
      return Fail(SVMS_ERR_NULL_ARGUMENT, std::string("svms_rig_camera_count: ") +
                                              (!e ? "estimator" : "n_cameras") + " is NULL");
    *n_cameras = 0;
    std::lock_guard<std::mutex> lock(registry_mutex);
    if (const svms_status s = CheckLiveLocked("svms_rig_camera_count", e); s != SVMS_OK) return s;
    *n_cameras = static_cast<int>(e->impl->num_cameras());
    return SVMS_OK;
  });
}

svms_status svms_process_rig_frame(svms_rig_estimator* e, const svms_rig_frame* frames,
                                   int n_frames, double timestamp, svms_pose* out) {
  return Guarded("svms_process_rig_frame", [&]() -> svms_status {
    return ProcessRig("svms_process_rig_frame", e, frames, n_frames, timestamp, out);
  });
}

svms_status svms_process_rig_frame_u16(svms_rig_estimator* e, const svms_rig_frame_u16* frames,
                                       int n_frames, double timestamp, svms_pose* out) {
  return Guarded("svms_process_rig_frame_u16", [&]() -> svms_status {
    return ProcessRig("svms_process_rig_frame_u16", e, frames, n_frames, timestamp, out);
  });
}

svms_status svms_destroy_rig(svms_rig_estimator* e) {
  return Guarded("svms_destroy_rig", [&]() -> svms_status {
    if (!e) return SVMS_OK;
    if (const svms_status s = ClaimForDestroy("svms_destroy_rig", e); s != SVMS_OK) return s;
    e->impl.reset();
    delete e->scratch;
    e->scratch = nullptr;
    delete e->frames;
    e->frames = nullptr;
    e->magic = 0;
    return SVMS_OK;
  });
}

const char* svms_last_error(void) { return last_error.c_str(); }

const char* svms_status_string(svms_status s) {
  switch (s) {
    case SVMS_OK:
      return "SVMS_OK";
    case SVMS_ERR_NULL_ARGUMENT:
      return "SVMS_ERR_NULL_ARGUMENT";
    case SVMS_ERR_INVALID_ARGUMENT:
      return "SVMS_ERR_INVALID_ARGUMENT";
    case SVMS_ERR_FILE:
      return "SVMS_ERR_FILE";
    case SVMS_ERR_BAD_HANDLE:
      return "SVMS_ERR_BAD_HANDLE";
    case SVMS_ERR_BUSY:
      return "SVMS_ERR_BUSY";
    case SVMS_ERR_INTERNAL:
      return "SVMS_ERR_INTERNAL";
  }
  return "SVMS_ERR_UNKNOWN";
}

const char* svms_version(void) { return SVMS_VERSION_STRING; }

}  // extern "C"

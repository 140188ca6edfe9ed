// The survey: where several markers sit on one object, from many images of it.
//
// Steps (RunSurvey):
//   1. Observations: every detection of a marker with a model and a single-marker pose; its
//      four corners and its post tip (one tip per post and image). A marker seen in fewer than
//      two images is named and left out.
//   2. The co-visibility graph (view_graph.h): a disconnected graph is an error naming its
//      components (or, with SurveyConfig::drop_disconnected, only the reference's is kept).
//   3. Initialisation: robust relative-pose averages over a maximum spanning tree from the
//      reference marker; each camera from its best sighting; with control points, the whole
//      initial layout is moved onto them (Kabsch).
//   4. Bundle adjustment with Ceres (SPARSE_SCHUR, cameras eliminated first) under a robust
//      loss; outlier rejection; a second, least-squares solve.
//   5. Covariance of every marker pose and post height: the Gauss-Newton matrix with the
//      camera poses eliminated (Schur complement), inverted (or ceres::Covariance, see
//      SurveyOptions::covariance_algorithm), scaled by the a-posteriori variance factor; a
//      rank-deficient problem is reported with the parameters that are not determined.
// Frames: object_from_marker, cam_from_object (docs/conventions.md). A dual marker's inner
// marker is surveyed as a marker of its own; the shared post belongs to the outer marker.
#pragma once

#include <string>
#include <vector>

#include "svms/bundle/survey_options.h"
#include "svms/camera/camera.h"
#include "svms/detect/detector.h"
#include "svms/marker/layout.h"
#include "svms/marker/marker_model.h"

namespace svms {

// The detections of one image (from svms::Detector with the camera and the marker models:
// detections without cam_from_marker are not used).
struct SurveyImage {
  std::string name;
  std::vector<Detection> detections;
};

struct SurveyResult {
  // The surveyed markers in the order of the models given, each with its covariance
  // ([rotation, translation], object axes) and, for posts, the estimated height (in
  // marker.post->height) and its sigma. A dual marker becomes two entries: the outer marker
  // (without `inner`, with the post) and the inner one (InnerModel(), sharing the post's
  // estimated height). Covariances absent if they could not be computed.
  Layout layout;
  // The initial layout (step 3) in the same object frame, poses only.
  Layout initial_layout;
  // Per input image: whether it was used, and its cam_from_object.
  std::vector<std::string> image_names;
  std::vector<bool> image_used;
  std::vector<Pose> cam_from_object;
  // The camera the layout belongs to: the input camera, or with refine_intrinsics the one with
  // the refined intrinsics and, once the covariance is computed, their covariance
  // (intrinsics_covariance_factor: the intrinsics' block of this survey's covariance, scaled by
  // the a-posteriori variance factor as the layout's; the input calibration is not a prior).
  CameraModel camera;
  SurveySummary summary;
};

// Runs the survey. `models` are the marker models (outer and inner IDs unique); `camera` the
// calibrated camera the detections were made with. Returns an error (one line, also in
// result->summary.message) for bad options or config, a reference or control point naming an
// unknown or left-out marker, a disconnected view graph, nothing to survey, a failed solve, or
// a rank-deficient problem; *result then holds what was computed up to the failure.
Status RunSurvey(const std::vector<SurveyImage>& images, const std::vector<MarkerModel>& models,
                 const CameraModel& camera, const SurveyOptions& options,
                 const SurveyConfig& config, SurveyResult* result);

// The marker-frame position of a named point for a marker model (a tip: (0, 0, post height);
// false if the marker has no post).
bool NamedPointInMarker(const NamedPoint& point, const MarkerModel& model, Eigen::Vector3d* out);

}  // namespace svms

// Survey observations synthesised from a known truth (a layout, a camera and camera poses):
// what the tests and the benchmark's Monte-Carlo and scaling runs feed to RunSurvey. The
// geometry is exact; the only error is the Gaussian noise added to the corners and tips.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "svms/bundle/survey.h"
#include "svms/camera/camera.h"
#include "svms/marker/layout.h"

namespace svms {

struct SyntheticOptions {
  double corner_sigma_px = 0.1;    // standard deviation of each corner coordinate
  double tip_sigma_px = 0.3;       // of each tip coordinate (also written as its sigma_px)
  double min_side_px = 20;         // smaller markers are not "detected"
  double max_view_angle_deg = 75;  // between the marker's normal and the line of sight
  bool tips = true;
};

// Detections of every marker of `truth` (inner markers included) that faces the camera at
// less than max_view_angle_deg, has all four corners in the image and a side of at least
// min_side_px: the projected corners and post tip (a concave well's visible part,
// VisibleTipPoint) plus noise, and a single-marker pose fitted to them (RefinePose from the
// true pose). A dual marker's tip goes with its outer detection (the inner one's when the
// outer is not seen). Deterministic for a seed. Occlusion is not modelled.
// With `only_ids` (one list per camera), exactly those markers are synthesised in each image
// (e.g. what the detector found in rendered images), whatever the criteria above say, as long
// as they project; tips only where `with_tip` (same shape, when given) says so.
std::vector<SurveyImage> SynthesiseImages(
    const Layout& truth, const CameraModel& camera,
    const std::vector<std::pair<std::string, Pose>>& cam_from_object,
    const SyntheticOptions& options, uint64_t seed,
    const std::vector<std::vector<int>>* only_ids = nullptr,
    const std::vector<std::vector<bool>>* with_tip = nullptr);

// A synthetic object for tests and scaling runs: `markers` markers (sizes 0.1 and 0.15 m with
// posts, every fifth a concave well; IDs 100, 101, ...) on grids over the five visible faces
// of a 1.2 x 1.2 x 2 m box (front face z = +1), and `images` cameras 1.5-4 m from points near
// the front of the box, looking from directions in front of it (z > 0.4 of the unit vector).
struct SyntheticScene {
  Layout layout;
  std::vector<std::pair<std::string, Pose>> cam_from_object;
};
SyntheticScene MakeSyntheticScene(int markers, int images, uint64_t seed);

// cam_from_world for a camera at `eye` looking at `target`, image up close to `up`.
Pose LookAtPose(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                const Eigen::Vector3d& up);

}  // namespace svms

// How the comparison benchmark scores one image: every detection matched against the truth
// (truth.h), for any marker system. A detection belongs to the truth marker whose projected
// black square (peer: outer black edge) contains its corners' centroid; with the truth's ID it
// is a hit, else a wrong ID; inside no truth square it is a false positive. A truth marker
// counts toward the detection rate when it faces the camera with all four corners in the
// image (occluded or not: occlusion is what the occlusion sweep measures).
#pragma once

#include <Eigen/Core>
#include <array>
#include <optional>
#include <string>
#include <vector>

#include "svms/geometry/pose.h"
#include "svms/sim/truth.h"

namespace svms {

// One marker reported by any system.
struct FoundMarker {
  int id = -1;
  std::array<Eigen::Vector2d, 4> corners;  // TL, TR, BR, BL as printed, pixels
  std::optional<Pose> cam_from_marker;
  bool pose_ambiguous = false;  // the system flags the pose as possibly its planar twin (SVMS)
  // The pose's covariance, [rotation, translation] about the camera axes (radians, metres;
  // pose.h), when the system gives one (SVMS).
  std::optional<PoseCovariance> covariance;
  // With a flagged pose: the other planar pose the system gives beside it, and the share of
  // the likelihood the system gives that pose (SVMS).
  std::optional<Pose> alternative_pose;
  double alternative_weight = 0;
};

// One truth marker, for one system, in one image.
struct MarkerOutcome {
  int truth_id = -1;
  int nested_in = -1;
  bool eligible = false;                // facing, all four corners in the image
  bool detected = false;                // a detection with its ID
  bool wrong_id = false;                // a detection on it with another ID (and none with its ID)
  double min_side_px = 0, side_px = 0;  // truth
  double view_angle_deg = 0;            // between the marker normal and the line of sight
  double occluded_fraction = 0;         // of its data cells (svms44: 44, peers: 36)
  double distance_m = 0;                // camera centre to marker centre
  // Of the hit (NaN otherwise): RMS over the four corners; |estimated - true| distance to the
  // marker centre; rotation angle between estimated and true orientation.
  double corner_rms_px = NAN, range_err_m = NAN, orientation_err_deg = NAN;
  // Rotation angle between the estimate and the true pose's planar twin (NaN without a pose),
  // degrees (PlanarTwin, ippe.h: twice the view angle from the truth).
  double twin_err_deg = NAN;
  bool pose_ambiguous = false;  // of the hit: the system flagged its pose
  // Of the hit with an alternative pose: that pose's orientation error, degrees (NaN otherwise).
  double alternative_err_deg = NAN;
  // Of the hit with an alternative pose: its share of the likelihood (0 without one) and its
  // rotation angle from the pose, degrees (NaN without one). Where that angle is above kFlipDeg,
  // the share is the system's own probability that the pose is a flip.
  double alternative_weight = 0, alternative_sep_deg = NAN;
  // Of the hit with a covariance: its pose's normalised estimation error squared against the
  // truth (6 dof; chi-square with 6 degrees of freedom, mean 6, when the covariance is right).
  double pose_nees = NAN;
  // A pose flip (orientation error above kFlipDeg) that is the planar ambiguity: nearer the
  // twin than the truth, with the twin itself above kFlipDeg from the truth. The other flips
  // are measurement noise: a head-on marker's twin is its own pose.
  bool planar_flip() const;
};

struct ImageOutcome {
  std::vector<MarkerOutcome> markers;  // in truth order
  int false_positives = 0;
  int wrong_ids = 0;  // detections on a marker with a wrong ID
};

ImageOutcome EvaluateImage(const ViewTruth& truth, const std::vector<FoundMarker>& found);

// Pose flip: orientation error above this (the planar two-fold ambiguity), degrees.
inline constexpr double kFlipDeg = 10;

}  // namespace svms

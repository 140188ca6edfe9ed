// A layout: several markers fixed on one object, each with its pose in the object frame and,
// once surveyed, the covariance of that pose. Written by `svms survey`, read by the pose
// estimator, and (any layout) usable as a calibration board.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "svms/marker_model.h"
#include "svms/pose.h"
#include "svms/status.h"

namespace svms {

struct LayoutEntry {
  MarkerModel marker;
  Pose object_from_marker;
  // Covariance of object_from_marker: [rotation(3), translation(3)], rotation as a small angle
  // about the object frame's axes; radians^2, metres^2. Absent until surveyed.
  std::optional<PoseCovariance> covariance;
  std::optional<double> post_height_sigma;  // metres, from the survey
};

struct Layout {
  std::string name;
  std::vector<LayoutEntry> markers;

  // Every marker valid; IDs (outer and inner) unique; poses finite; covariances symmetric
  // positive semi-definite and finite.
  Status Validate() const;
  // The entry whose outer or inner marker has this ID, or nullptr.
  const LayoutEntry* Find(int id) const;
  // One-line summary: "layout 'mockup': 8 markers, IDs 1 2 3 ..., sizes 0.1-0.432 m".
  std::string Summary() const;
};

}  // namespace svms

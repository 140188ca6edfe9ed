// A layout: several markers fixed on one object, each with its pose in the object frame and,
// once surveyed, the covariance of that pose. Written by `svms survey`, read by the pose
// estimator, and (any layout) usable as a calibration board.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "svms/base/status.h"
#include "svms/geometry/pose.h"
#include "svms/marker/marker_model.h"

namespace svms {

struct LayoutEntry {
  MarkerModel marker;
  Pose object_from_marker;
  // Covariance of object_from_marker: [rotation(3), translation(3)], rotation as a small angle
  // about the object frame's axes; radians^2, metres^2. Absent until surveyed.
  std::optional<PoseCovariance> covariance;
  std::optional<double> post_height_sigma;  // metres, from the survey
};

// Tolerances of the overlap rule in Layout::Validate.
constexpr double kLayoutCoplanarDegrees = 5;
constexpr double kLayoutCoplanarDistance = 0.05;  // fraction of the smaller printed side
constexpr double kLayoutOverlapMargin = 0.01;     // fraction of a printed side, per edge

struct Layout {
  std::string name;
  std::vector<LayoutEntry> markers;

  // Every marker valid; IDs (outer and inner) unique; poses finite; covariances symmetric
  // positive semi-definite and finite; no two markers overlapping. A marker nested in another
  // (on its plane, its printed square inside the other's black square: the two markers of a
  // dual written as two entries, as `svms survey` does) is fine. Otherwise two markers overlap
  // when
  //  - their centres are closer than half the smaller black square's side (whatever their
  //    orientations: two markers cannot share a spot), or
  //  - they lie on one plane (normals within kLayoutCoplanarDegrees, each centre within
  //    kLayoutCoplanarDistance x the smaller printed side of the other's plane) and their
  //    printed squares (to the outer edge of the bit ring, side 2 * half_extent()), each
  //    shrunk by kLayoutOverlapMargin of its side on every edge, intersect.
  // The margin lets markers touch (a board with no gap) and absorbs survey noise; markers on
  // different faces of an object (normals apart) may come close at the edges.
  Status Validate() const;
  // The entry whose outer or inner marker has this ID, or nullptr.
  const LayoutEntry* Find(int id) const;
  // One-line summary: "layout 'mockup': 8 markers, IDs 1 2 3 ..., sizes 0.1-0.432 m".
  std::string Summary() const;
};

}  // namespace svms

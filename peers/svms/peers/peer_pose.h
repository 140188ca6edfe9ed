// Pose of a planar square tag from its four corners, as a peer system computes it: IPPE
// (OpenCV's solvePnP with SOLVEPNP_IPPE_SQUARE) on the corners, undistorted through the same
// camera model the SVMS detector uses (CameraModel::Unproject, mrcal), so lens handling is the
// same for every system and only the pose method differs. IPPE returns the better of the two
// planar solutions by reprojection error; at small sizes and oblique views that choice is often
// the wrong one (the planar pose flip the comparison counts).
#pragma once

#include <array>

#include "svms/camera/camera.h"
#include "svms/geometry/pose.h"

namespace svms {

// cam_from_marker of a square of side `side` (metres) whose corners TL, TR, BR, BL (marker
// frame x right, y up, z toward the viewer; docs/conventions.md) are seen at `corners`
// (pixels). False if a corner cannot be unprojected or solvePnP fails.
bool PeerPose(const CameraModel& camera, const std::array<Eigen::Vector2d, 4>& corners, double side,
              Pose* cam_from_marker);

}  // namespace svms

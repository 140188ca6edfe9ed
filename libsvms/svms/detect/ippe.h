// The two planar-pose candidates of a square marker from its four corners in normalized image
// coordinates, with no heap allocation.
//
// A port of Collins & Bartoli's IPPE ("Infinitesimal Plane-Based Pose Estimation", IJCV 109(3),
// 2014) as OpenCV 4.6 implements it for cv::solvePnPGeneric(..., cv::SOLVEPNP_IPPE_SQUARE) in
// modules/calib3d/src/ippe.cpp (PoseSolver::solveSquare, homographyFromSquarePoints,
// solveCanonicalForm, computeRotations, rotateVec2ZAxis, computeTranslation,
// sortPosesByReprojError, evalReprojError) and modules/calib3d/src/solvepnp.cpp (the order
// solvePnPGeneric returns the two solutions in). That code is Copyright 2017 Toby Collins
// (BSD 3-clause) and the OpenCV project (Apache 2.0).
//
// Why it exists: OpenCV's makes 56 heap allocations per call (cv::Mat temporaries,
// std::vector<cv::Mat> outputs; counted on Debian's 4.6), and the C API promises no allocation
// per frame (docs/flight-interface.md). This one uses only fixed-size Eigen types and
// std::array (0 allocations, counted), and takes ~0.2 us against OpenCV's ~7-11 us.
//
// Agreement with OpenCV: the arithmetic is OpenCV's, operation for operation, so the
// translations and rotation matrices are OpenCV's to the bit (600,000 random poses, tilts 0-80
// degrees, with and without noise; the matrices compared through OpenCV's rot2vec), in the same
// order. Where they differ, deliberately:
//  - OpenCV returns its rotations as rotation vectors from its own rot2vec (acos of the trace,
//    axis from the antisymmetric part), which is ill-conditioned as the angle nears pi, and it
//    sorts by reprojection errors computed from those vectors. A marker facing the camera is a
//    rotation by pi about an axis in the image plane (R = diag(1, -1, -1) when upright). So
//    Rodrigues(OpenCV's rvec) departs from OpenCV's own matrix by up to ~1e-11 / gap^2 (gap =
//    pi - angle; 2e-3 seen for gap < 1e-4); at exactly a half-turn the rvec is (0, 0, 0) or
//    meaningless, and OpenCV can then list the exact solution second. Here the matrices are
//    returned as IPPE computes them and the errors (and so the order) are computed from them.
//  - computeRotations takes sqrt(1 - |column|^2), the root of a slightly negative number when
//    rounding has it so where the two solutions coincide (the normal along the line of sight):
//    OpenCV then returns NaN (3 % of such views); here the argument is clamped at 0.
//  - Non-finite input, coincident corners, three collinear corners: OpenCV returns two NaN or
//    meaningless solutions (no exception); here false, kNonFiniteInput / kDegenerate.
// Mirrored although it depends on units: OpenCV gives up (no solution) when
// |s/2 * cross(diagonals)| < 1e-9 ("Determinant is zero!"; ~ s^3 cos(tilt) / Z^2, e.g. a 1 cm
// square beyond ~30 m: sub-pixel images), and when the homography's scale at the centre is below
// FLT_EPSILON ("gamma is zero.", distances ~1e7 x the side).
// Accuracy (IPPE's, not the port's): the rotation matrices are orthonormal to ~1e-11; where the
// two solutions coincide, the rotation from exact corners is only good to ~3e-4 (a square root of
// rounding errors), to ~1e-9 a degree or more away.
#pragma once

#include <Eigen/Core>
#include <array>

#include "svms/geometry/pose.h"

namespace svms {

// One pose of the square: p_cam = cam_from_marker_R * p_marker + cam_from_marker_t.
// Marker frame: origin at the square's centre, the square in its z = 0 plane, x to the right and
// y up as printed, corners k = 0..3 at (-s/2, s/2, 0), (s/2, s/2, 0), (s/2, -s/2, 0),
// (-s/2, -s/2, 0) (top-left, top-right, bottom-right, bottom-left: MarkerModel::Corners()).
// Camera frame: OpenCV's (x right, y down, z forward); translation in the units of the side.
struct PlanarPoseCandidate {
  Eigen::Matrix3d cam_from_marker_R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d cam_from_marker_t = Eigen::Vector3d::Zero();
  // RMS over the 8 coordinates of the corners' reprojection in normalized image coordinates,
  // sqrt(sum_k |proj_k - normalized_k|^2 / 8): what solvePnPGeneric's reprojectionError output
  // holds with identity intrinsics (computed in double from the rotation matrix).
  double reprojection_error = 0;
  // All four corners at positive depth. IPPE does not enforce it (nor does OpenCV): a candidate
  // can put the square behind the camera, e.g. when the input corners are not the image of a
  // square in front of it.
  bool in_front = false;
};

enum class IppeStatus {
  kOk,
  kInvalidSide,     // side not finite or not > 0
  kNonFiniteInput,  // a corner coordinate is NaN or infinite
  // As OpenCV: |s/2 * cross(p0 - p2, p1 - p3)| < 1e-9 (OpenCV returns no solution).
  kBelowOpenCvDeterminant,
  // Some three corners (nearly) collinear or two (nearly) coincident: twice the area of a
  // triangle of three corners below 1e-9 x the squared largest distance between two corners.
  // No homography maps the square there (OpenCV returns NaN or meaningless poses).
  kDegenerate,
  // As OpenCV: the largest singular value of the canonical Jacobian below FLT_EPSILON.
  kBelowOpenCvScale,
  kNumericalFailure,  // a non-finite result (not expected once the checks above pass)
};

const char* IppeStatusName(IppeStatus status);

// The two IPPE solutions for a square of side `side` whose corners (in the order above) are seen
// at `normalized` (undistorted, on the z = 1 plane: (x/z, y/z) in the camera frame). On
// success, (*out)[0] and (*out)[1] are the two candidates in the order
// cv::solvePnPGeneric(SOLVEPNP_IPPE_SQUARE) returns them: by the reprojection error rounded to
// float as OpenCV's evalReprojError does, lowest first; on a tie (e.g. where the two coincide)
// the first of computeRotations' pair (+sqrt in the canonical frame), as OpenCV's two
// successive sorts end up doing. Returns false, leaving *out unchanged, on failure; `status`
// (optional) says why. No heap allocation; thread-safe (no state).
bool SolveSquareIppe(const std::array<Eigen::Vector2d, 4>& normalized, double side,
                     std::array<PlanarPoseCandidate, 2>* out, IppeStatus* status = nullptr);

// The planar twin of a pose of a small planar target: the orientation that its coplanar points,
// seen under weak perspective, cannot tell from `cam_from_target`'s. Its normal (the target's z
// axis) is mirrored about the line of sight to the target's origin, n' = 2 (n.v) v - n with v
// the unit vector from the camera to the origin, by the smallest rotation taking n to n',
// applied after the pose's own rotation; the translation is kept. IPPE's second solution is this
// pose up to perspective (within 0.5 deg for a 0.1 m square at 15 m, 20 deg off-axis). The twin
// is twice the view angle from the pose: a target seen head-on is its own twin.
Pose PlanarTwin(const Pose& cam_from_target);

}  // namespace svms

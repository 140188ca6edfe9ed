// The rotation between the frames of two models of the same camera, as mrcal's
// projection_diff fits it (its "implied transformation" at infinity: a rotation only).
//
// A calibration fixes the camera frame only up to a small rotation: a rotation of the camera
// is nearly the same as a shift of the principal point plus a change of the distortion, which
// a flexible lens model (mrcal's splined models above all) represents almost exactly. The data
// cannot tell them apart, so the solution's frame is set by the lens model's structure and its
// regularisation, not by the lens. Two calibrations of one camera (or a calibration and the
// true camera of a simulation) then give poses in frames rotated against each other, by a
// fraction of a degree for splined models, a few thousandths for OPENCV8
// (docs/flight-interface.md, "The camera frame").
// Comparing them needs this rotation; removing it leaves the projection difference proper.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "svms/base/status.h"
#include "svms/camera/camera.h"
#include "svms/geometry/alignment.h"

namespace svms {

struct FrameAlignmentOptions {
  int grid = 32;  // grid x grid cell centres over the imager are compared
  // Only cells within this fraction of half the shorter image side from the image centre
  // (1: the inscribed circle, where a calibration usually has data; mrcal's projection_diff
  // defaults to a sixth of the shorter side for its fit). In (0, 1.5].
  double radius_fraction = 1.0;
};

struct FrameAlignment {
  // Maps directions of camera a's frame into camera b's frame: a point p_a seen by a is seen
  // by b at b_from_a * p_a.
  Eigen::Matrix3d b_from_a = Eigen::Matrix3d::Identity();
  double angle_deg = 0;         // the rotation's angle, degrees
  int cells = 0;                // cell centres compared (both models unproject them)
  double rms_px = 0;            // after the fit: |b.Project(b_from_a * a.Unproject(q)) - q|, RMS
  double worst_px = 0;          // ... and the largest
  double rms_unaligned_px = 0;  // the same without the rotation (b_from_a = identity)
};

// Fits b_from_a minimising sum |b_from_a * a.Unproject(q) - b.Unproject(q)|^2 over the cell
// centres q (FitRotation, svms/geometry/alignment.h), then measures the pixel differences. Both
// models must have the same image size. Errors name the field: "lensmodel" (an empty model),
// "imagersize" (sizes differ), "grid" / "radius_fraction" (out of range), "cells" (fewer than 10
// cell centres both models unproject, e.g. CAHVORE, which mrcal 2.2 cannot unproject). `out` must
// not be null; it is unchanged on error.
Status AlignCameraFrames(const CameraModel& a, const CameraModel& b,
                         const FrameAlignmentOptions& options, FrameAlignment* out);

}  // namespace svms

// Detector step 8: sub-pixel corners. Along each side of a quad, the edge is located across
// the side (the peak of the intensity derivative along the normal, interpolated by a parabola),
// a line is fitted to those edge points -- in the undistorted image plane when a lens model
// is given, so that the curved image of a straight side is handled exactly -- and the corners
// are the intersections of consecutive lines, projected back to pixels.
#pragma once

#include <Eigen/Core>
#include <array>
#include <opencv2/core.hpp>
#include <optional>

#include "svms/camera.h"

namespace svms {

struct CornerRefineOptions {
  int iterations = 2;
  double search_px = 2.5;    // half-width of the search across each side, pixels
  double end_margin = 0.12;  // fraction of each side left out next to the corners
  int max_points = 64;       // edge points per side
};

struct RefinedCorners {
  std::array<Eigen::Vector2d, 4> corners;  // same order as the input
  std::array<double, 4> side_rms{};  // RMS distance of each side's edge points to its line, px
  std::array<int, 4> side_points{};  // edge points used per side
  // Standard deviation of each corner (pixels, each axis) propagated from its two side lines'
  // fits: each line's offset and slope from its edge points' scatter (side_rms, side_points),
  // evaluated at the corner, then the intersection at the lines' angle.
  std::array<double, 4> corner_sigma{};
  bool ok = false;
};

// `corners` go clockwise on screen around a dark quad on a brighter surround. `image` is
// CV_8UC1 or CV_16UC1. `camera` may be null (lines fitted in pixels).
RefinedCorners RefineCorners(const cv::Mat& image, const std::array<Eigen::Vector2d, 4>& corners,
                             const CameraModel* camera, const CornerRefineOptions& options);

// Bilinear sample at pixel-centre coordinates (clamped to the image).
double SampleImage(const cv::Mat& image, double u, double v);

}  // namespace svms

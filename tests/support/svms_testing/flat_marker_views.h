// The views of the flat-marker ambiguity tests (the detector's and the fused pose's): a 0.1 m
// marker without a post, ID 200 + v, seen from 5.5 m (about 20 px through a 320 x 240 pinhole
// of f = 1111.1 px), 5 + 2 v degrees off its normal, from azimuth v x 45 degrees; v = 0..11.
#pragma once

#include <Eigen/Core>
#include <cmath>

#include "svms/marker/marker_model.h"

namespace svms_testing {

constexpr int kFlatMarkerViews = 12;

inline svms::MarkerModel FlatMarker(int v) {
  svms::MarkerModel m = svms::MarkerModel::Standard(200 + v, 0.1, 0.02);
  m.post.reset();
  return m;
}

// The camera centre of view v in the marker's frame (it looks at the marker's centre).
inline Eigen::Vector3d FlatMarkerEye(int v) {
  const double a = (5 + 2 * v) * M_PI / 180, b = v * M_PI / 4;
  return 5.5 * Eigen::Vector3d(std::sin(a) * std::cos(b), std::sin(a) * std::sin(b), std::cos(a));
}

}  // namespace svms_testing

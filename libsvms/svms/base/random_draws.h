// Random vectors drawn in a fixed order (internal: not installed).
//
// The arguments of one call are unsequenced in C++: gcc evaluates them last to first, clang
// first to last, so `Eigen::Vector2d(g(rng), g(rng))` gives different data from the same seed
// with each compiler. These helpers draw in separate statements, the last component first
// (gcc's order for the one-expression form), so every seeded dataset, test and benchmark gives
// the same numbers with gcc and with clang.
#pragma once

#include <Eigen/Core>

namespace svms {

// (x, y) from `dist`, y drawn first.
template <class Dist, class Rng>
Eigen::Vector2d DrawVector2(Dist& dist, Rng& rng) {
  const double y = dist(rng);
  const double x = dist(rng);
  return Eigen::Vector2d(x, y);
}

// (x, y, z) from `dist`, z drawn first, then y, then x.
template <class Dist, class Rng>
Eigen::Vector3d DrawVector3(Dist& dist, Rng& rng) {
  const double z = dist(rng);
  const double y = dist(rng);
  const double x = dist(rng);
  return Eigen::Vector3d(x, y, z);
}

}  // namespace svms

// The renderer's small fixed-size vector arithmetic, written out: the hot loops call these per
// ray, and Eigen's generic products are not always inlined there. Each gives bit for bit what
// the Eigen expression in its comment gives (the same operations in the same order), so that
// the images do not change by a single bit whichever a piece of the renderer uses. Internal
// to sim (not installed).
#pragma once

#include <Eigen/Core>
#include <cmath>

namespace svms::render {

using Vec3 = Eigen::Vector3d;
using Mat3 = Eigen::Matrix3d;

inline double Dot(const Vec3& a, const Vec3& b) {
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}  // a.dot(b)
inline Vec3 Mul(const Mat3& R, const Vec3& v) {  // R * v
  return Vec3(R(0, 0) * v[0] + R(0, 1) * v[1] + R(0, 2) * v[2],
              R(1, 0) * v[0] + R(1, 1) * v[1] + R(1, 2) * v[2],
              R(2, 0) * v[0] + (R(2, 1) * v[1] + R(2, 2) * v[2]));
}
inline Vec3 MulT(const Mat3& R, const Vec3& v) {  // R.transpose() * v
  return Vec3(R(0, 0) * v[0] + R(1, 0) * v[1] + R(2, 0) * v[2],
              R(0, 1) * v[0] + R(1, 1) * v[1] + R(2, 1) * v[2],
              R(0, 2) * v[0] + R(1, 2) * v[1] + R(2, 2) * v[2]);
}
inline Vec3 Normalized(const Vec3& v) {  // v.normalized()
  const double n = Dot(v, v);
  if (!(n > 0)) return v;
  const double s = std::sqrt(n);
  return Vec3(v[0] / s, v[1] / s, v[2] / s);
}
// Squared distance from `oc` (a point relative to the ray origin) to the line along unit `d`:
// (oc - oc.dot(d) * d).squaredNorm(), given along = oc.dot(d).
inline double PerpSquared(const Vec3& oc, double along, const Vec3& d) {
  const Vec3 r(oc[0] - along * d[0], oc[1] - along * d[1], oc[2] - along * d[2]);
  return Dot(r, r);
}
// The bilinear blend of four float corner rays at (fx, fy) in [0, 1]^2, as the Eigen expression
// (1 - fy) * ((1 - fx) * c00 + fx * c10) + fy * ((1 - fx) * c01 + fx * c11) evaluates it.
inline Eigen::Vector3f Blend(const Eigen::Vector3f& c00, const Eigen::Vector3f& c10,
                             const Eigen::Vector3f& c01, const Eigen::Vector3f& c11, double fx,
                             double fy) {
  const float a = static_cast<float>(1 - fy), b = static_cast<float>(1 - fx),
              c = static_cast<float>(fx), e = static_cast<float>(fy);
  Eigen::Vector3f r;
  for (int i = 0; i < 3; ++i) r[i] = a * (b * c00[i] + c * c10[i]) + e * (b * c01[i] + c * c11[i]);
  return r;
}

}  // namespace svms::render

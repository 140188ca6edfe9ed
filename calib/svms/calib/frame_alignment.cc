#include "svms/calib/frame_alignment.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

namespace svms {

Status AlignCameraFrames(const CameraModel& a, const CameraModel& b,
                         const FrameAlignmentOptions& options, FrameAlignment* out) {
  if (a.empty() || b.empty())
    return Status::Error(std::string("lensmodel: camera model ") + (a.empty() ? "a" : "b") +
                         " is empty; expected a camera model to compare");
  if (a.width() != b.width() || a.height() != b.height())
    return Status::Error("imagersize: the models differ (" + std::to_string(a.width()) + "x" +
                         std::to_string(a.height()) + " and " + std::to_string(b.width()) + "x" +
                         std::to_string(b.height()) + "); expected the same camera");
  if (options.grid < 4 || options.grid > 1000)
    return Status::Error("grid: " + std::to_string(options.grid) + ", expected 4 to 1000");
  if (!(options.radius_fraction > 0 && options.radius_fraction <= 1.5))
    return Status::Error("radius_fraction: " + std::to_string(options.radius_fraction) +
                         ", expected in (0, 1.5]");

  // 1. Cell centres within the radius that both models unproject.
  const Eigen::Vector2d centre(0.5 * (a.width() - 1), 0.5 * (a.height() - 1));
  const double radius = options.radius_fraction * 0.5 * std::min(a.width(), a.height());
  std::vector<Eigen::Vector2d> pixels;
  std::vector<Eigen::Vector3d> in_a, in_b;
  for (int i = 0; i < options.grid; ++i) {
    for (int j = 0; j < options.grid; ++j) {
      const Eigen::Vector2d q((j + 0.5) * a.width() / options.grid - 0.5,
                              (i + 0.5) * a.height() / options.grid - 0.5);
      Eigen::Vector3d va, vb;
      if ((q - centre).norm() > radius || !a.Unproject(q, &va) || !b.Unproject(q, &vb)) continue;
      pixels.push_back(q);
      in_a.push_back(va);
      in_b.push_back(vb);
    }
  }
  if (pixels.size() < 10)
    return Status::Error("cells: only " + std::to_string(pixels.size()) +
                         " cell centres unproject through both models; expected at least 10");

  // 2. The rotation taking the directions of a onto those of b (unit vectors, so no centring:
  // a rotation about the camera centre).
  const Eigen::Matrix3d b_from_a = FitRotation(in_a, in_b);

  // 3. Pixel differences with and without the rotation.
  double sum = 0, sum_unaligned = 0, worst = 0;
  int n = 0;
  for (size_t k = 0; k < pixels.size(); ++k) {
    Eigen::Vector2d aligned, unaligned;
    if (!b.Project(b_from_a * in_a[k], &aligned) || !b.Project(in_a[k], &unaligned)) continue;
    const double d = (aligned - pixels[k]).norm();
    sum += d * d;
    sum_unaligned += (unaligned - pixels[k]).squaredNorm();
    worst = std::max(worst, d);
    ++n;
  }
  if (n < 10)
    return Status::Error("cells: only " + std::to_string(n) +
                         " cell centres project back through the second model; expected at "
                         "least 10");
  out->b_from_a = b_from_a;
  out->angle_deg = Eigen::AngleAxisd(b_from_a).angle() * 180 / M_PI;
  out->cells = n;
  out->rms_px = std::sqrt(sum / n);
  out->worst_px = worst;
  out->rms_unaligned_px = std::sqrt(sum_unaligned / n);
  return Status::Ok();
}

}  // namespace svms

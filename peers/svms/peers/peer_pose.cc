#include "svms/peers/peer_pose.h"

#include <opencv2/calib3d.hpp>

namespace svms {

bool PeerPose(const CameraModel& camera, const std::array<Eigen::Vector2d, 4>& corners, double side,
              Pose* cam_from_marker) {
  std::vector<cv::Point2d> normalised;
  for (const Eigen::Vector2d& c : corners) {
    Eigen::Vector3d d;
    if (!camera.Unproject(c, &d) || !(d.z() > 0)) return false;
    normalised.emplace_back(d.x() / d.z(), d.y() / d.z());
  }
  // SOLVEPNP_IPPE_SQUARE's required object points: TL, TR, BR, BL with y up.
  const double h = 0.5 * side;
  const std::vector<cv::Point3d> object = {{-h, h, 0}, {h, h, 0}, {h, -h, 0}, {-h, -h, 0}};
  cv::Mat rvec, tvec;
  bool ok = false;
  try {
    ok = cv::solvePnP(object, normalised, cv::Mat::eye(3, 3, CV_64F), cv::Mat(), rvec, tvec, false,
                      cv::SOLVEPNP_IPPE_SQUARE);
  } catch (const cv::Exception&) {
    return false;
  }
  if (!ok) return false;
  cam_from_marker->rvec =
      Eigen::Vector3d(rvec.at<double>(0), rvec.at<double>(1), rvec.at<double>(2));
  cam_from_marker->tvec =
      Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  return cam_from_marker->rvec.allFinite() && cam_from_marker->tvec.allFinite();
}

}  // namespace svms

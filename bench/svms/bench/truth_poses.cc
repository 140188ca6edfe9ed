#include "svms/bench/truth_poses.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>

#include "svms/base/file_io.h"

namespace svms {

Status ReadTruthPoses(const std::string& truth_json, const std::string& object,
                      std::vector<std::pair<std::string, Pose>>* out) {
  std::string text;
  if (Status s = ReadTextFile(truth_json, &text); !s) return s;
  out->clear();
  try {
    const nlohmann::json tj = nlohmann::json::parse(text);
    for (const auto& v : tj.at("views")) {
      const auto& p = v.at("cam_from_object").at(object);
      Pose pose;
      for (int i = 0; i < 3; ++i) {
        pose.rvec[i] = p.at("rvec").at(i).get<double>();
        pose.tvec[i] = p.at("tvec").at(i).get<double>();
      }
      out->emplace_back(v.at("name").get<std::string>(), pose);
    }
  } catch (const std::exception& e) {
    return Status::Error(truth_json + ": expected views with a name and cam_from_object." + object +
                         " {rvec, tvec}: " + e.what());
  }
  return Status::Ok();
}

double ViewAngleDeg(const Pose& cam_from_marker) {
  const Eigen::Vector3d n = cam_from_marker.Rotation().col(2);
  const Eigen::Vector3d to_cam = -cam_from_marker.tvec.normalized();
  return std::acos(std::clamp(n.dot(to_cam), -1.0, 1.0)) * 180 / M_PI;
}

}  // namespace svms

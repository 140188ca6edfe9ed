#include "json_lines.h"

#include <Eigen/Geometry>
#include <vector>

namespace svms::cli {
namespace {

// {rvec, tvec} of a pose.
nlohmann::json PoseJson(const Pose& p) {
  return {{"rvec", {p.rvec(0), p.rvec(1), p.rvec(2)}}, {"tvec", {p.tvec(0), p.tvec(1), p.tvec(2)}}};
}

// {rvec, tvec, quaternion [w, x, y, z]} of a pose.
nlohmann::json PoseWithQuaternionJson(const Pose& pose) {
  const Eigen::Quaterniond q(pose.Rotation());
  return {{"rvec", {pose.rvec(0), pose.rvec(1), pose.rvec(2)}},
          {"tvec", {pose.tvec(0), pose.tvec(1), pose.tvec(2)}},
          {"quaternion", {q.w(), q.x(), q.y(), q.z()}}};
}

// A square matrix's entries, row-major (what every covariance in the JSON Lines is).
template <typename Matrix>
std::vector<double> RowMajor(const Matrix& m) {
  std::vector<double> v;
  v.reserve(m.size());
  for (int r = 0; r < m.rows(); ++r)
    for (int c = 0; c < m.cols(); ++c) v.push_back(m(r, c));
  return v;
}

// The share of a pose's covariance common to every frame (ObjectPose::bias_factor times its
// transpose), row-major; null when the covariance has none (no calibration's or extrinsics'
// uncertainty in it).
nlohmann::json CommonCovarianceJson(const ObjectPose& p) {
  if (p.bias_columns() == 0) return nullptr;
  return RowMajor(Eigen::Matrix<double, 6, 6>(p.bias_factor() * p.bias_factor().transpose()));
}

// Its factor B (ObjectPose::bias_factor), 6 rows of k numbers: column j is the same error in
// every line of the stream, so two frames' common errors are correlated by B_f B_g^T. Null
// without columns.
nlohmann::json BiasFactorJson(const ObjectPose& p) {
  if (p.bias_columns() == 0) return nullptr;
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 6; ++r) {
    std::vector<double> row(static_cast<size_t>(p.bias_columns()));
    for (int c = 0; c < p.bias_columns(); ++c) row[static_cast<size_t>(c)] = p.bias_factor()(r, c);
    rows.push_back(row);
  }
  return rows;
}

// How well one object's fit went: the fields every pose line carries after its markers.
void AddFitQuality(const ObjectPose& p, nlohmann::json* j) {
  (*j)["points_rejected"] = p.points_rejected;
  (*j)["markers_seen"] = p.markers_seen;
  (*j)["points"] = p.points_used;
  (*j)["rms"] = p.rms_px;
  (*j)["chi2"] = p.chi2;
  (*j)["dof"] = p.dof;
}

}  // namespace

nlohmann::json DetectionJson(const Detection& d) {
  nlohmann::json c = nlohmann::json::array();
  for (const auto& p : d.corners) c.push_back({p.x(), p.y()});
  nlohmann::json j = {{"id", d.id}, {"corners", c}, {"bit_errors", d.bit_errors}};
  if (d.corner_sigma[0] > 0)
    j["corner_sigma"] = {d.corner_sigma[0], d.corner_sigma[1], d.corner_sigma[2],
                         d.corner_sigma[3]};
  if (d.corner_covariance(0, 0) > 0) j["corner_covariance"] = RowMajor(d.corner_covariance);
  if (d.penumbra_sides[0] || d.penumbra_sides[1] || d.penumbra_sides[2] || d.penumbra_sides[3]) {
    nlohmann::json sides = nlohmann::json::array();
    for (int k = 0; k < 4; ++k)
      if (d.penumbra_sides[k]) sides.push_back(k);
    j["penumbra_sides"] = sides;
  }
  j["tip"] = d.tip ? nlohmann::json{d.tip->pixel.x(), d.tip->pixel.y()} : nlohmann::json();
  if (d.tip) j["tip_sigma"] = d.tip->sigma_px;
  if (d.cam_from_marker) {
    j["cam_from_marker"] = PoseJson(*d.cam_from_marker);
    j["covariance"] = RowMajor(d.covariance);
    j["pose_ambiguous"] = d.pose_ambiguous;
    if (d.alternative_pose) {
      j["alternative_pose"] = PoseJson(*d.alternative_pose);
      j["alternative_pose"]["weight"] = d.alternative_weight;
    }
    j["calibration_in_covariance"] = d.calibration_in_covariance;
    j["edge_points"] = d.edge_points;
  }
  if (!d.pose_error.empty()) j["pose_error"] = d.pose_error;
  if (d.nested_in >= 0) j["nested_in"] = d.nested_in;
  return j;
}

nlohmann::json FrameJson(const FrameResult& r, size_t object) {
  const ObjectPose& p = r.object(object);
  nlohmann::json j;
  j["timestamp"] = r.timestamp;
  j["valid"] = p.valid;
  if (p.valid) {
    j["cam_from_object"] = PoseWithQuaternionJson(p.cam_from_object);
    j["covariance"] = RowMajor(p.covariance);
    j["covariance_common"] = CommonCovarianceJson(p);
    j["bias_factor"] = BiasFactorJson(p);
    if (p.alternative_cam_from_object) {
      j["alternative"] = PoseWithQuaternionJson(*p.alternative_cam_from_object);
      j["alternative"]["weight"] = p.alternative_weight;
    }
  } else {
    j["cam_from_object"] = nullptr;
    j["covariance"] = nullptr;
    j["covariance_common"] = nullptr;
    j["bias_factor"] = nullptr;
    j["message"] = p.message;
  }
  j["markers"] = p.ids_used;
  j["markers_rejected"] = p.ids_rejected;
  AddFitQuality(p, &j);
  j["flags"] = {{"ambiguous", p.ambiguous},
                {"poorly_conditioned", p.poorly_conditioned},
                {"budget_exceeded", r.budget_exceeded},
                {"calibration_in_covariance", p.calibration_in_covariance},
                {"marker_pose_with_edges", p.from_marker_pose}};
  j["latency_ms"] = r.latency_ms;
  j["detect_ms"] = r.detect_ms;
  return j;
}

nlohmann::json RigFrameJson(const RigFrameResult& r, const CameraRig& rig, size_t object) {
  const ObjectPose& p = r.object(object);
  nlohmann::json j;
  j["timestamp"] = r.timestamp;
  j["valid"] = p.valid;
  if (p.valid) {
    j["rig_from_object"] = PoseWithQuaternionJson(p.cam_from_object);
    j["covariance"] = RowMajor(p.covariance);
    j["covariance_common"] = CommonCovarianceJson(p);
    j["bias_factor"] = BiasFactorJson(p);
  } else {
    j["rig_from_object"] = nullptr;
    j["covariance"] = nullptr;
    j["covariance_common"] = nullptr;
    j["bias_factor"] = nullptr;
    j["message"] = p.message;
  }
  nlohmann::json cameras = nlohmann::json::array();
  for (size_t c = 0; c < rig.cameras.size(); ++c) {
    std::vector<int> used, rejected;
    for (size_t k = 0; k < p.ids_used.size(); ++k)
      if (p.cameras_used[k] == static_cast<int>(c)) used.push_back(p.ids_used[k]);
    for (size_t k = 0; k < p.ids_rejected.size(); ++k)
      if (p.cameras_rejected[k] == static_cast<int>(c)) rejected.push_back(p.ids_rejected[k]);
    const FrameResult& f = r.cameras.at(c);
    cameras.push_back({{"name", rig.cameras[c].name},
                       {"markers", used},
                       {"markers_rejected", rejected},
                       {"markers_seen", f.object(object).markers_seen},
                       {"valid_alone", f.object(object).valid},
                       {"detect_ms", f.detect_ms}});
  }
  j["cameras"] = cameras;
  AddFitQuality(p, &j);
  j["flags"] = {{"poorly_conditioned", p.poorly_conditioned},
                {"calibration_in_covariance", p.calibration_in_covariance},
                {"extrinsics_in_covariance", p.extrinsics_in_covariance}};
  j["latency_ms"] = r.latency_ms;
  return j;
}

}  // namespace svms::cli

#include "svms/bundle/synthetic.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "svms/base/random_draws.h"
#include "svms/detect/marker_pose.h"

namespace svms {
namespace {

struct Candidate {
  MarkerModel model;
  int outer_id = -1;
  Pose object_from_marker;
};

}  // namespace

Pose LookAtPose(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                const Eigen::Vector3d& up) {
  const Eigen::Vector3d z = (target - eye).normalized();
  const Eigen::Vector3d y = (-up + up.dot(z) * z).normalized();
  const Eigen::Vector3d x = y.cross(z);
  Eigen::Matrix3d R;
  R.row(0) = x;
  R.row(1) = y;
  R.row(2) = z;
  return Pose::FromRotation(R, -R * eye);
}

std::vector<SurveyImage> SynthesiseImages(
    const Layout& truth, const CameraModel& camera,
    const std::vector<std::pair<std::string, Pose>>& cam_from_object, const SyntheticOptions& o,
    uint64_t seed, const std::vector<std::vector<int>>* only_ids,
    const std::vector<std::vector<bool>>* with_tip) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g(0, 1);
  std::vector<Candidate> cands;
  for (const LayoutEntry& e : truth.markers) {
    MarkerModel outer = e.marker;
    outer.inner.reset();
    cands.push_back({outer, -1, e.object_from_marker});
    if (e.marker.inner)
      cands.push_back({*e.marker.InnerModel(), e.marker.id, e.object_from_marker});
  }
  const double cos_max = std::cos(o.max_view_angle_deg * M_PI / 180);
  std::vector<SurveyImage> out;
  for (size_t view = 0; view < cam_from_object.size(); ++view) {
    const auto& [name, cam_from_obj] = cam_from_object[view];
    SurveyImage im;
    im.name = name;
    std::vector<int> outer_seen;
    for (const Candidate& c : cands) {
      const Pose cam_from_marker = cam_from_obj * c.object_from_marker;
      const Eigen::Vector3d cam_in_marker = cam_from_marker.Inverse().tvec;
      int listed = -1;  // index in only_ids, or -1
      if (only_ids) {
        const std::vector<int>& ids = (*only_ids)[view];
        const auto it = std::find(ids.begin(), ids.end(), c.model.id);
        if (it == ids.end()) continue;
        listed = static_cast<int>(it - ids.begin());
      } else if (cam_in_marker.z() <= cos_max * cam_in_marker.norm()) {
        continue;
      }
      Detection d;
      d.id = c.model.id;
      bool ok = true;
      for (int k = 0; k < 4 && ok; ++k) {
        Eigen::Vector2d px;
        ok = camera.Project(cam_from_marker * c.model.Corners()[k], &px) &&
             (only_ids || (px.x() >= 0 && px.y() >= 0 && px.x() <= camera.width() - 1 &&
                           px.y() <= camera.height() - 1));
        d.corners[k] = px;
      }
      if (!ok || (!only_ids && d.side_px() < o.min_side_px)) continue;
      // Vectors of draws through DrawVector*: a fixed order whatever the compiler.
      for (auto& p : d.corners) p += o.corner_sigma_px * DrawVector2(g, rng);
      const std::array<Eigen::Vector3d, 4> corners = c.model.Corners();
      std::vector<Eigen::Vector3d> X(corners.begin(), corners.end());
      std::vector<Eigen::Vector2d> px(d.corners.begin(), d.corners.end());
      std::vector<double> sig(4, o.corner_sigma_px);
      const bool tip_here = c.outer_id < 0 || std::find(outer_seen.begin(), outer_seen.end(),
                                                        c.outer_id) == outer_seen.end();
      const bool tip_listed = !with_tip || (listed >= 0 && (*with_tip)[view][listed]);
      if (o.tips && c.model.post && tip_here && tip_listed) {
        double fraction = 0;
        const Eigen::Vector3d tip = VisibleTipPoint(c.model, cam_in_marker, &fraction);
        Eigen::Vector2d t;
        if ((fraction >= 0.25 || with_tip) && camera.Project(cam_from_marker * tip, &t)) {
          d.tip = TipObservation{t + o.tip_sigma_px * DrawVector2(g, rng), o.tip_sigma_px};
          X.push_back(tip);
          px.push_back(d.tip->pixel);
          sig.push_back(o.tip_sigma_px);
        }
      }
      Pose pose = cam_from_marker;
      double rms = 0;
      if (!RefinePose(camera, X, px, sig, &pose, &d.covariance, &rms)) continue;
      d.cam_from_marker = pose;
      d.pose_rms_px = rms;
      d.nested_in = c.outer_id;
      if (c.outer_id < 0) outer_seen.push_back(c.model.id);
      im.detections.push_back(d);
    }
    out.push_back(im);
  }
  return out;
}

SyntheticScene MakeSyntheticScene(int markers, int images, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  const Eigen::Vector3d half(0.6, 0.6, 1.0);
  SyntheticScene s;
  s.layout.name = "synthetic";
  // Faces: front (+z), +x, -x, +y, -y; normal axis and sign.
  const int face_axis[5] = {2, 0, 0, 1, 1}, face_sign[5] = {1, 1, -1, 1, -1};
  const int per_face = (markers + 4) / 5;
  const int k = static_cast<int>(std::ceil(std::sqrt(per_face)));
  for (int m = 0; m < markers; ++m) {
    const int f = m % 5, slot = m / 5;
    const int axis = face_axis[f], sign = face_sign[f];
    const int a1 = (axis + 1) % 3, a2 = (axis + 2) % 3;
    const double size = m % 2 ? 0.15 : 0.1;
    const double post = (m % 5 == 4 ? -0.2 : 0.25) * size;
    MarkerModel model = MarkerModel::Standard(100 + m, size, post);
    Eigen::Vector3d centre = Eigen::Vector3d::Zero();
    centre[axis] = sign * half[axis];
    centre[a1] = half[a1] * (-0.8 + 1.6 * ((slot % k) + 0.5) / k);
    centre[a2] = half[a2] * (-0.8 + 1.6 * ((slot / k) + 0.5) / k);
    Eigen::Vector3d z = Eigen::Vector3d::Zero();
    z[axis] = sign;
    Eigen::Vector3d x = Eigen::Vector3d::Zero();
    x[a1] = 1;
    const double spin = 0.5 * u(rng);
    x = Eigen::AngleAxisd(spin, z) * x;
    Eigen::Matrix3d R;
    R.col(0) = x;
    R.col(1) = z.cross(x);
    R.col(2) = z;
    s.layout.markers.push_back(
        LayoutEntry{model, Pose::FromRotation(R, centre), std::nullopt, std::nullopt});
  }
  for (int i = 0; i < images; ++i) {
    Eigen::Vector3d d, eye, target;
    do {
      d = DrawVector3(u, rng).normalized();  // a fixed order whatever the compiler
      const Eigen::Vector3d t = DrawVector3(u, rng);
      target = Eigen::Vector3d(0.3 * t.x(), 0.3 * t.y(), 0.5 + 0.5 * t.z());
      const double dist = 1.5 + 1.25 * (u(rng) + 1);
      eye = target + dist * d;
    } while (d.z() < 0.4 || (eye.cwiseAbs() - half).maxCoeff() < 0.3);
    const Eigen::Vector3d up = Eigen::Vector3d(u(rng), 1, 0).normalized();
    char name[32];
    std::snprintf(name, sizeof(name), "synthetic_%04d", i);
    s.cam_from_object.emplace_back(name, LookAtPose(eye, target, up));
  }
  return s;
}

}  // namespace svms

#include "svms/bench/survey_errors.h"

#include <array>
#include <cmath>

#include "svms/base/format.h"
#include "svms/bench/report_numbers.h"

namespace svms {

std::vector<MarkerError> Errors(const Layout& layout, const Layout& truth, int ref) {
  const Pose ref_from_truth = truth.Find(ref)->object_from_marker.Inverse();
  std::vector<MarkerError> out;
  for (const LayoutEntry& e : layout.markers) {
    const LayoutEntry* t = truth.Find(e.marker.id);
    if (!t || e.marker.id == ref) continue;
    const Pose true_pose = ref_from_truth * t->object_from_marker;
    MarkerError m;
    m.id = e.marker.id;
    const Eigen::AngleAxisd aa(e.object_from_marker.Rotation() * true_pose.Rotation().transpose());
    Eigen::Matrix<double, 6, 1> err;
    err << aa.axis() * aa.angle(), e.object_from_marker.tvec - true_pose.tvec;
    m.position_mm = 1000 * err.tail<3>().norm();
    m.orientation_deg = aa.angle() * 180 / M_PI;
    if (e.covariance && !e.covariance->isZero()) m.nees = err.dot(e.covariance->ldlt().solve(err));
    const MarkerModel true_model =
        t->marker.id == e.marker.id ? t->marker : *t->marker.InnerModel();
    if (e.marker.post && true_model.post) {
      m.has_post = true;
      m.post_error_mm = 1000 * (e.marker.post->height - true_model.post->height);
      if (e.post_height_sigma) m.post_sigma_mm = 1000 * *e.post_height_sigma;
    }
    out.push_back(m);
  }
  return out;
}

double Rms(const std::vector<MarkerError>& v, double MarkerError::*f) {
  double s = 0;
  for (const MarkerError& m : v) s += (m.*f) * (m.*f);
  return v.empty() ? 0 : std::sqrt(s / v.size());
}

Layout LayoutFromPoses(const std::map<int, Pose>& poses, const Layout& like) {
  Layout l;
  for (const LayoutEntry& e : like.markers)
    if (poses.count(e.marker.id))
      l.markers.push_back(LayoutEntry{e.marker, poses.at(e.marker.id), std::nullopt, std::nullopt});
  return l;
}

std::vector<ImageSightings> Sightings(const std::vector<SurveyImage>& images,
                                      const std::set<int>& ids) {
  std::vector<ImageSightings> out;
  for (const SurveyImage& im : images) {
    ImageSightings s;
    for (const Detection& d : im.detections)
      if (d.cam_from_marker && ids.count(d.id))
        s.push_back({d.id, *d.cam_from_marker, d.side_px(), d.pose_ambiguous});
    out.push_back(s);
  }
  return out;
}

std::map<int, std::vector<double>> OutwardCornerErrors(
    const std::vector<SurveyImage>& images,
    const std::vector<std::pair<std::string, Pose>>& cam_from_object, const Layout& truth,
    const CameraModel& camera) {
  std::map<int, std::vector<double>> out;
  for (size_t i = 0; i < images.size(); ++i) {
    for (const Detection& d : images[i].detections) {
      const LayoutEntry* t = truth.Find(d.id);
      if (!t) continue;
      const MarkerModel model = t->marker.id == d.id ? t->marker : *t->marker.InnerModel();
      const Pose cam_from_marker = cam_from_object[i].second * t->object_from_marker;
      std::array<Eigen::Vector2d, 4> q;
      bool ok = true;
      for (int k = 0; k < 4 && ok; ++k)
        ok = camera.Project(cam_from_marker * model.Corners()[k], &q[k]);
      if (!ok) continue;
      const Eigen::Vector2d centre = 0.25 * (q[0] + q[1] + q[2] + q[3]);
      for (int k = 0; k < 4; ++k) {
        const Eigen::Vector2d e = d.corners[k] - q[k];
        if (e.norm() < 3) out[d.id].push_back(e.dot((q[k] - centre).normalized()));
      }
    }
  }
  return out;
}

std::string MeanAndStandardError(const std::vector<double>& v) {
  if (v.size() < 2) return "-";
  const double m = Mean(v);
  double ss = 0;
  for (double x : v) ss += (x - m) * (x - m);
  return Fixed(m, 4) + " +- " + Fixed(std::sqrt(ss / (v.size() - 1) / v.size()), 4);
}

}  // namespace svms

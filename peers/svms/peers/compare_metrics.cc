#include "svms/peers/compare_metrics.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "svms/detect/ippe.h"
#include "svms/fusion/object_pose.h"
#include "svms/geometry/pose.h"

namespace svms {
namespace {

// Point in a (convex or not) quadrilateral, by ray crossing.
bool InQuad(const std::array<PointTruth, 4>& q, const Eigen::Vector2d& p) {
  bool in = false;
  for (int i = 0, j = 3; i < 4; j = i++) {
    const Eigen::Vector2d& a = q[i].pixel;
    const Eigen::Vector2d& b = q[j].pixel;
    if ((a.y() > p.y()) != (b.y() > p.y()) &&
        p.x() < (b.x() - a.x()) * (p.y() - a.y()) / (b.y() - a.y()) + a.x())
      in = !in;
  }
  return in;
}

}  // namespace

bool MarkerOutcome::planar_flip() const {
  return orientation_err_deg > kFlipDeg && twin_err_deg < orientation_err_deg &&
         2 * view_angle_deg > kFlipDeg;
}

ImageOutcome EvaluateImage(const ViewTruth& truth, const std::vector<FoundMarker>& found) {
  ImageOutcome out;
  for (const MarkerTruth& t : truth.markers) {
    MarkerOutcome m;
    m.truth_id = t.id;
    m.nested_in = t.nested_in;
    m.eligible = t.facing;
    for (const PointTruth& c : t.corners) m.eligible = m.eligible && c.projects && c.in_image;
    m.min_side_px = t.min_side_px;
    m.side_px = t.side_px;
    const Eigen::Matrix3d R = t.cam_from_marker.Rotation();
    const Eigen::Vector3d& pos = t.cam_from_marker.tvec;
    m.distance_m = pos.norm();
    m.view_angle_deg =
        std::acos(std::clamp(R.col(2).dot(-pos) / m.distance_m, -1.0, 1.0)) * 180 / M_PI;
    const int cells = t.family == "svms44" ? 44 : 36;
    m.occluded_fraction = static_cast<double>(t.bits_occluded) / cells;
    out.markers.push_back(m);
  }
  // Each detection to the smallest truth square holding its centroid (a dual marker's inner
  // square lies inside the outer one); the truth's ID is preferred when several hold it.
  for (const FoundMarker& f : found) {
    Eigen::Vector2d c = Eigen::Vector2d::Zero();
    for (const auto& p : f.corners) c += 0.25 * p;
    int best = -1;
    for (size_t i = 0; i < truth.markers.size(); ++i) {
      const MarkerTruth& t = truth.markers[i];
      bool projects = true;
      for (const PointTruth& q : t.corners) projects = projects && q.projects;
      if (!projects || !InQuad(t.corners, c)) continue;
      if (best < 0 || (t.id == f.id && truth.markers[best].id != f.id) ||
          ((t.id == f.id) == (truth.markers[best].id == f.id) &&
           t.side_px < truth.markers[best].side_px))
        best = static_cast<int>(i);
    }
    if (best < 0) {
      ++out.false_positives;
      continue;
    }
    const MarkerTruth& t = truth.markers[best];
    MarkerOutcome& m = out.markers[best];
    if (f.id != t.id) {
      ++out.wrong_ids;
      if (!m.detected) m.wrong_id = true;
      continue;
    }
    if (m.detected) continue;  // a duplicate: the first one counts
    m.detected = true;
    m.wrong_id = false;
    double ss = 0;
    for (int k = 0; k < 4; ++k) ss += (f.corners[k] - t.corners[k].pixel).squaredNorm();
    m.corner_rms_px = std::sqrt(ss / 4);
    if (f.cam_from_marker) {
      m.range_err_m = std::abs(f.cam_from_marker->tvec.norm() - t.cam_from_marker.tvec.norm());
      m.orientation_err_deg =
          AngleBetweenDeg(f.cam_from_marker->Rotation(), t.cam_from_marker.Rotation());
      m.pose_ambiguous = f.pose_ambiguous;
      m.twin_err_deg =
          AngleBetweenDeg(f.cam_from_marker->Rotation(), PlanarTwin(t.cam_from_marker).Rotation());
      if (f.covariance) m.pose_nees = Nees(t.cam_from_marker, *f.cam_from_marker, *f.covariance);
      if (f.alternative_pose) {
        m.alternative_err_deg =
            AngleBetweenDeg(f.alternative_pose->Rotation(), t.cam_from_marker.Rotation());
        m.alternative_sep_deg =
            AngleBetweenDeg(f.alternative_pose->Rotation(), f.cam_from_marker->Rotation());
        m.alternative_weight = f.alternative_weight;
      }
    }
  }
  return out;
}

}  // namespace svms

#include "svms/bench/detect_scoring.h"

#include <algorithm>
#include <cmath>

#include "svms/base/format.h"
#include "svms/bench/truth_poses.h"
#include "svms/geometry/pose.h"

namespace svms {

void Score(const std::string& set, const ViewTruth& truth, const std::vector<Detection>& found,
           std::vector<MarkerRow>* rows, ViewRow* view) {
  std::vector<bool> used(found.size(), false);
  for (const MarkerTruth& m : truth.markers) {
    MarkerRow r;
    r.set = set;
    r.view = truth.name;
    r.id = m.id;
    r.nested_in = m.nested_in;
    r.min_side_px = m.min_side_px;
    r.side_px = m.side_px;
    r.view_angle_deg = ViewAngleDeg(m.cam_from_marker);
    r.distance_m = m.cam_from_marker.tvec.norm();
    r.bits_occluded = m.bits_occluded;
    r.bits_in_shadow = m.bits_in_shadow;
    // A marker seen beyond 75 degrees is a sliver whatever its side lengths: it counts in the
    // angle table, not in the size targets.
    r.fully_visible = m.fully_visible();
    r.within_75 = r.view_angle_deg <= 75.0 + 1e-6;
    r.corners_visible = m.facing;
    for (const PointTruth& c : m.corners) r.corners_visible &= c.in_image && !c.occluded;
    r.has_tip = m.has_tip && m.tip.in_image && !m.tip.occluded;
    for (size_t i = 0; i < found.size(); ++i) {
      const Detection& d = found[i];
      if (d.id != m.id || used[i]) continue;
      double sum2 = 0, worst = 0;
      for (int k = 0; k < 4; ++k) {
        const double e = (d.corners[k] - m.corners[k].pixel).norm();
        sum2 += e * e;
        worst = std::max(worst, e);
      }
      // The right ID far from the true marker is a false positive, not a find.
      if (worst > std::max(3.0, 0.1 * m.side_px)) continue;
      used[i] = true;
      r.found = true;
      r.bit_errors = d.bit_errors;
      r.corner_rms_px = std::sqrt(sum2 / 4);
      r.corner_max_px = worst;
      r.tip_found = d.tip.has_value();
      r.ambiguous = d.pose_ambiguous;
      if (d.cam_from_marker) {
        const Eigen::Vector3d t_est = d.cam_from_marker->tvec, t_true = m.cam_from_marker.tvec;
        r.range_err_m = t_est.norm() - t_true.norm();
        r.orient_err_deg = AngleBetweenDeg(*d.cam_from_marker, m.cam_from_marker);
        const Eigen::Vector3d los = t_true.normalized();
        r.range_sigma_m = std::sqrt(los.dot(d.covariance.block<3, 3>(3, 3) * los));
        r.trace_t = d.covariance.block<3, 3>(3, 3).trace();
        r.orient_sigma_deg = std::sqrt(d.covariance.block<3, 3>(0, 0).trace()) * 180 / M_PI;
      }
      break;
    }
    if (r.fully_visible && !r.found)
      view->problems.push_back("missed " + std::to_string(r.id) + " (" + Fixed(r.min_side_px, 1) +
                               " px, " + Fixed(r.view_angle_deg, 1) + " deg, " +
                               std::to_string(r.bits_in_shadow) + " bits in shadow)");
    rows->push_back(r);
  }
  view->detections = static_cast<int>(found.size());
  for (size_t i = 0; i < found.size(); ++i) {
    if (used[i]) continue;
    // An inner marker whose outer one is in the view but not fully visible is matched above;
    // anything left over names a marker that is not there.
    ++view->false_positives;
    view->problems.push_back("false " + std::to_string(found[i].id) + " at (" +
                             Fixed(found[i].corners[0].x(), 0) + ", " +
                             Fixed(found[i].corners[0].y(), 0) + "), " +
                             std::to_string(found[i].bit_errors) + " bits corrected");
  }
}

}  // namespace svms

#include "svms/calib/observations.h"

#include <cmath>

#include "svms/geometry/quad_sides.h"

namespace svms {

std::array<Eigen::Vector2d, 4> QuadEdgeShifts(const std::array<Eigen::Vector2d, 4>& c) {
  // Outward normal of the side from corner k to k + 1, whichever way the quad winds.
  const std::array<Eigen::Vector2d, 4> normal = QuadOutwardNormals(c);
  std::array<Eigen::Vector2d, 4> shift;
  for (int k = 0; k < 4; ++k) {
    // Corner k is where side k - 1 (ending there) meets side k (starting there): the point v
    // with n1.v = n2.v = 1 is (n1 + n2) / (1 + n1.n2) when |n1| = |n2| = 1.
    const Eigen::Vector2d& n1 = normal[(k + 3) % 4];
    const Eigen::Vector2d& n2 = normal[k];
    const double denom = 1 + n1.dot(n2);
    // Sides within about 8 degrees of parallel (or a zero normal): no stable intersection.
    shift[k] = std::abs(n1.x() * n2.y() - n1.y() * n2.x()) > 0.14 && denom > 1e-6
                   ? Eigen::Vector2d((n1 + n2) / denom)
                   : Eigen::Vector2d::Zero();
  }
  return shift;
}

ViewObservations ObservationsFromDetections(const std::vector<Detection>& detections,
                                            const Layout& layout, const std::string& name,
                                            double corner_sigma_px) {
  ViewObservations view;
  view.name = name;
  for (const Detection& d : detections) {
    const LayoutEntry* e = layout.Find(d.id);
    if (e == nullptr) {
      view.unknown_ids.push_back(d.id);
      continue;
    }
    const bool inner = e->marker.id != d.id;
    const MarkerModel model = inner ? *e->marker.InnerModel() : e->marker;
    const std::array<Eigen::Vector3d, 4> corners = model.Corners();
    const std::array<Eigen::Vector2d, 4> shift = QuadEdgeShifts(d.corners);
    for (int k = 0; k < 4; ++k) {
      view.points.push_back(PointObservation{e->object_from_marker * corners[k], d.corners[k],
                                             corner_sigma_px, d.id, k, shift[k]});
    }
    if (d.tip && !inner) {
      if (const auto tip = e->marker.PostTip()) {
        view.points.push_back(PointObservation{e->object_from_marker * *tip, d.tip->pixel,
                                               d.tip->sigma_px, d.id, PointObservation::kTip,
                                               Eigen::Vector2d::Zero()});
      }
    }
    ++view.markers;
  }
  return view;
}

}  // namespace svms

#include "svms/calib/observations.h"

namespace svms {

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
    for (int k = 0; k < 4; ++k) {
      view.points.push_back(PointObservation{e->object_from_marker * corners[k], d.corners[k],
                                             corner_sigma_px, d.id, k});
    }
    if (d.tip && !inner) {
      if (const auto tip = e->marker.PostTip()) {
        view.points.push_back(PointObservation{e->object_from_marker * *tip, d.tip->pixel,
                                               d.tip->sigma_px, d.id, PointObservation::kTip});
      }
    }
    ++view.markers;
  }
  return view;
}

}  // namespace svms

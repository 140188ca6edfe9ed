#include "svms/layout.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

namespace svms {

Status Layout::Validate() const {
  if (markers.empty()) return Status::Error("markers: expected at least one marker, got none");
  std::map<int, size_t> seen;
  for (size_t i = 0; i < markers.size(); ++i) {
    const std::string path = "markers[" + std::to_string(i) + "].";
    const LayoutEntry& e = markers[i];
    if (Status s = e.marker.Validate(path + "marker."); !s) return s;
    std::vector<int> ids{e.marker.id};
    if (e.marker.inner) ids.push_back(e.marker.inner->id);
    for (int id : ids) {
      auto [it, fresh] = seen.emplace(id, i);
      if (!fresh) {
        return Status::Error(path + "marker.id: ID " + std::to_string(id) +
                             " appears twice (also in markers[" + std::to_string(it->second) +
                             "]); expected unique IDs");
      }
    }
    if (!e.object_from_marker.rvec.allFinite() || !e.object_from_marker.tvec.allFinite())
      return Status::Error(path + "object_from_marker: expected finite rvec and tvec");
    if (e.covariance) {
      const PoseCovariance& C = *e.covariance;
      if (!C.allFinite()) return Status::Error(path + "covariance: expected 36 finite numbers");
      if ((C - C.transpose()).cwiseAbs().maxCoeff() > 1e-9 * std::max(1.0, C.cwiseAbs().maxCoeff()))
        return Status::Error(path + "covariance: expected a symmetric 6x6 matrix");
      const double min_eig = Eigen::SelfAdjointEigenSolver<PoseCovariance>(C).eigenvalues()(0);
      if (min_eig < -1e-12 * std::max(1e-30, C.diagonal().maxCoeff()))
        return Status::Error(path + "covariance: expected a positive semi-definite matrix, its " +
                             "smallest eigenvalue is " + std::to_string(min_eig));
    }
    if (e.post_height_sigma && !(std::isfinite(*e.post_height_sigma) && *e.post_height_sigma >= 0))
      return Status::Error(path + "post_height_sigma: expected a non-negative number of metres");
  }
  return Status::Ok();
}

const LayoutEntry* Layout::Find(int id) const {
  for (const LayoutEntry& e : markers) {
    if (e.marker.id == id || (e.marker.inner && e.marker.inner->id == id)) return &e;
  }
  return nullptr;
}

std::string Layout::Summary() const {
  std::string ids;
  double lo = 1e300, hi = 0;
  int surveyed = 0;
  for (const LayoutEntry& e : markers) {
    ids += (ids.empty() ? "" : " ") + std::to_string(e.marker.id);
    if (e.marker.inner) ids += "/" + std::to_string(e.marker.inner->id);
    lo = std::min(lo, e.marker.inner ? e.marker.inner->size : e.marker.size);
    hi = std::max(hi, e.marker.size);
    surveyed += e.covariance.has_value();
  }
  char buf[160];
  std::snprintf(buf, sizeof buf,
                "layout '%s': %zu markers (IDs %s), sizes %.4g-%.4g m, %d with covariance",
                name.c_str(), markers.size(), ids.c_str(), lo, hi, surveyed);
  return buf;
}

}  // namespace svms

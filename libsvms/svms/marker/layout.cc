#include "svms/marker/layout.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>

#include "svms/base/format.h"
#include "svms/geometry/pose_matrix.h"

namespace svms {
namespace {

// A marker's printed footprint in the object frame: the outer edge of its bit ring (a square of
// side 2 * half_extent() on the marker's plane z = 0), its centre and normal.
struct Footprint {
  Eigen::Vector3d centre, normal;
  std::array<Eigen::Vector3d, 4> corners;
  double side = 0;  // of the printed square, metres
};

Footprint FootprintOf(const LayoutEntry& e) {
  Footprint f;
  const Eigen::Matrix3d R = e.object_from_marker.Rotation();
  const double h = e.marker.half_extent();
  f.centre = e.object_from_marker.tvec;
  f.normal = R.col(2);
  const double xs[4] = {-h, h, h, -h}, ys[4] = {h, h, -h, -h};
  for (int k = 0; k < 4; ++k) f.corners[k] = R * Eigen::Vector3d(xs[k], ys[k], 0) + f.centre;
  f.side = 2 * h;
  return f;
}

// Whether two convex polygons (in order) are separated by a line along one of their edges'
// normals (the separating axis theorem): then they do not intersect.
bool Separated(const std::array<Eigen::Vector2d, 4>& a, const std::array<Eigen::Vector2d, 4>& b) {
  for (const auto* poly : {&a, &b}) {
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector2d edge = (*poly)[(k + 1) % 4] - (*poly)[k];
      const Eigen::Vector2d axis(-edge.y(), edge.x());
      double amin = 1e300, amax = -1e300, bmin = 1e300, bmax = -1e300;
      for (int i = 0; i < 4; ++i) {
        amin = std::min(amin, axis.dot(a[i]));
        amax = std::max(amax, axis.dot(a[i]));
        bmin = std::min(bmin, axis.dot(b[i]));
        bmax = std::max(bmax, axis.dot(b[i]));
      }
      if (amax <= bmin || bmax <= amin) return true;
    }
  }
  return false;
}

// "" if the two markers can both be where the layout puts them, or why they cannot (see
// Layout::Validate for the rule).
// Whether all of `inner`'s printed square lies inside `outer`'s black square (with a margin of
// kLayoutOverlapMargin of the inner's printed side), in outer's plane: a nested (dual) marker
// written as two entries, as `svms survey` writes the two markers of a dual.
bool NestedIn(const LayoutEntry& inner, const Footprint& fi, const LayoutEntry& outer) {
  const Eigen::Matrix3d Ro = outer.object_from_marker.Rotation();
  const double limit = 0.5 * outer.marker.size + kLayoutOverlapMargin * fi.side;
  for (const Eigen::Vector3d& c : fi.corners) {
    const Eigen::Vector3d p = Ro.transpose() * (c - outer.object_from_marker.tvec);
    if (std::abs(p.x()) > limit || std::abs(p.y()) > limit) return false;
  }
  return true;
}

std::string Overlap(const LayoutEntry& a, const LayoutEntry& b) {
  const Footprint fa = FootprintOf(a), fb = FootprintOf(b);
  const double min_side = std::min(fa.side, fb.side);
  const bool coplanar =
      fa.normal.dot(fb.normal) > std::cos(kLayoutCoplanarDegrees * M_PI / 180) &&
      std::abs(fa.normal.dot(fb.centre - fa.centre)) <= kLayoutCoplanarDistance * min_side &&
      std::abs(fb.normal.dot(fa.centre - fb.centre)) <= kLayoutCoplanarDistance * min_side;
  if (coplanar && (NestedIn(a, fa, b) || NestedIn(b, fb, a))) return "";
  const double smaller = std::min(a.marker.size, b.marker.size);
  const double distance = (a.object_from_marker.tvec - b.object_from_marker.tvec).norm();
  if (distance < 0.5 * smaller) {
    return "its centre is " + Significant(distance, 4) + " m from that of marker " +
           std::to_string(b.marker.id) + ", closer than half the smaller black square (" +
           Significant(0.5 * smaller, 4) + " m)";
  }
  if (!coplanar) return "";
  // Both squares in a's plane (x, y of a's marker frame), each shrunk toward its centre.
  const Eigen::Matrix3d Ra = a.object_from_marker.Rotation();
  auto in_a = [&](const Eigen::Vector3d& p) -> Eigen::Vector2d {
    return (Ra.transpose() * (p - fa.centre)).head<2>();
  };
  std::array<Eigen::Vector2d, 4> qa, qb;
  const Eigen::Vector2d ca = in_a(fa.centre), cb = in_a(fb.centre);
  for (int k = 0; k < 4; ++k) {
    qa[k] = ca + (1 - 2 * kLayoutOverlapMargin) * (in_a(fa.corners[k]) - ca);
    qb[k] = cb + (1 - 2 * kLayoutOverlapMargin) * (in_a(fb.corners[k]) - cb);
  }
  if (Separated(qa, qb)) return "";
  return "its printed square (" + Significant(fa.side, 4) +
         " m, to the outer edge of the bit ring) " + "overlaps that of marker " +
         std::to_string(b.marker.id) + " (" + Significant(fb.side, 4) + " m) on the same plane";
}

}  // namespace

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
      const double min_eig = SymmetricEigenvalues(C)(0);
      if (min_eig < -1e-12 * std::max(1e-30, C.diagonal().maxCoeff()))
        return Status::Error(path + "covariance: expected a positive semi-definite matrix, its " +
                             "smallest eigenvalue is " + std::to_string(min_eig));
    }
    if (e.post_height_sigma && !(std::isfinite(*e.post_height_sigma) && *e.post_height_sigma >= 0))
      return Status::Error(path + "post_height_sigma: expected a non-negative number of metres");
  }
  for (size_t i = 0; i < markers.size(); ++i) {
    for (size_t j = 0; j < i; ++j) {
      if (std::string why = Overlap(markers[i], markers[j]); !why.empty()) {
        return Status::Error("markers[" + std::to_string(i) + "].object_from_marker: marker " +
                             std::to_string(markers[i].marker.id) + " overlaps markers[" +
                             std::to_string(j) + "]: " + why +
                             "; expected markers apart (docs/markers.md, Layouts)");
      }
    }
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

#include "svms/quads.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <unordered_map>

namespace svms {
namespace {

double Cross(const Eigen::Vector2d& a, const Eigen::Vector2d& b) {
  return a.x() * b.y() - a.y() * b.x();
}

}  // namespace

double Quad::min_side() const {
  double m = 1e300;
  for (int k = 0; k < 4; ++k) m = std::min(m, (corners[(k + 1) % 4] - corners[k]).norm());
  return m;
}

double Quad::area() const {
  double a = 0;
  for (int k = 0; k < 4; ++k) a += Cross(corners[k], corners[(k + 1) % 4]);
  return 0.5 * std::abs(a);
}

bool Intersect(const Eigen::Vector3d& l1, const Eigen::Vector3d& l2, Eigen::Vector2d* p) {
  const Eigen::Vector3d h = l1.cross(l2);
  if (std::abs(h.z()) < 1e-12) return false;
  *p = h.head<2>() / h.z();
  return true;
}

std::vector<Quad> FindQuads(const std::vector<Segment>& segs, const QuadOptions& o, int width,
                            int height) {
  const int n = static_cast<int>(segs.size());
  const double sin_min_turn = std::sin(o.min_turn_deg * M_PI / 180);
  // Spatial hash of start points `a`, cells of `cell` pixels.
  double max_len = 0;
  for (const Segment& s : segs) max_len = std::max(max_len, s.length());
  const double cell = std::max(8.0, o.join_min_px * 2);
  std::unordered_multimap<int64_t, int> starts;
  auto key = [&](double x, double y) {
    return (static_cast<int64_t>(std::floor(x / cell)) << 32) ^
           static_cast<int64_t>(std::floor(y / cell) + 1e6);
  };
  for (int i = 0; i < n; ++i) starts.emplace(key(segs[i].a.x(), segs[i].a.y()), i);

  // follows[i]: segments j that may come after i, with the corner where they meet.
  std::vector<std::vector<std::pair<int, Eigen::Vector2d>>> follows(n);
  for (int i = 0; i < n; ++i) {
    const Segment& s = segs[i];
    const Eigen::Vector2d di = (s.b - s.a) / s.length();
    // Candidates: starts within the largest join radius of this end.
    const double reach = std::max(o.join_min_px, o.join_fraction * s.length());
    const int r = static_cast<int>(std::ceil(reach / cell));
    const int64_t cx = static_cast<int64_t>(std::floor(s.b.x() / cell)),
                  cy = static_cast<int64_t>(std::floor(s.b.y() / cell));
    for (int64_t gx = cx - r; gx <= cx + r; ++gx) {
      for (int64_t gy = cy - r; gy <= cy + r; ++gy) {
        auto range = starts.equal_range((gx << 32) ^ static_cast<int64_t>(gy + 1e6));
        for (auto it = range.first; it != range.second; ++it) {
          const int j = it->second;
          if (j == i) continue;
          const Segment& t = segs[j];
          const Eigen::Vector2d dj = (t.b - t.a) / t.length();
          if (Cross(di, dj) < sin_min_turn) continue;  // must turn right (clockwise on screen)
          Eigen::Vector2d corner;
          if (!Intersect(s.line, t.line, &corner)) continue;
          const double join =
              std::max(o.join_min_px, o.join_fraction * std::min(s.length(), t.length()));
          if ((corner - s.b).norm() > join || (corner - t.a).norm() > join) continue;
          // The corner must lie beyond the middle of both segments (not a crossing).
          if ((corner - s.a).dot(di) < 0.5 * s.length() ||
              (t.b - corner).dot(dj) < 0.5 * t.length())
            continue;
          follows[i].emplace_back(j, corner);
        }
      }
    }
  }
  std::vector<Quad> quads;
  for (int i = 0; i < n && static_cast<int>(quads.size()) < o.max_quads; ++i) {
    for (const auto& [j, c1] : follows[i]) {
      if (j <= i) continue;  // i is the smallest index of its cycle
      for (const auto& [k, c2] : follows[j]) {
        if (k <= i) continue;
        for (const auto& [l, c3] : follows[k]) {
          if (l <= i || l == j) continue;
          for (const auto& [m, c0] : follows[l]) {
            if (m != i) continue;
            Quad q;
            q.corners = {c0, c1, c2, c3};
            q.sides = {i, j, k, l};
            bool ok = q.min_side() >= o.min_side;
            for (int e = 0; e < 4 && ok; ++e) {
              const Eigen::Vector2d& p = q.corners[e];
              ok = p.x() > -0.5 && p.y() > -0.5 && p.x() < width - 0.5 && p.y() < height - 0.5;
              // Convex and clockwise on screen.
              ok = ok && Cross(q.corners[(e + 1) % 4] - p,
                               q.corners[(e + 2) % 4] - q.corners[(e + 1) % 4]) > 0;
            }
            if (ok) quads.push_back(q);
          }
        }
      }
    }
  }
  return quads;
}

}  // namespace svms

#include "svms/detect/quads.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>

#include "svms/base/thread_scratch.h"

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

namespace {

// Buffers of FindQuads, kept per thread between calls (no allocation once grown).
struct QuadScratch {
  // Start points `a` binned on a grid: cell c holds segments by_cell[cell_begin[c],
  // cell_begin[c + 1]).
  std::vector<int> cell_begin, by_cell;
  struct Follow {
    int next;                // a segment that may come after this one
    Eigen::Vector2d corner;  // where they meet
  };
  std::vector<Follow> follows;  // segment i's: follows[follow_begin[i], follow_begin[i + 1])
  std::vector<int> follow_begin;
  // By segment: its unit direction from a to b and its length, computed once rather than for
  // every pair (a textured photograph gives tens of thousands, each meeting dozens of starts).
  std::vector<Eigen::Vector2d> direction;
  std::vector<double> length;
};

}  // namespace

std::vector<Quad> FindQuads(const std::vector<Segment>& segs, const QuadOptions& o, int width,
                            int height) {
  std::vector<Quad> quads;
  FindQuads(segs, o, width, height, &quads);
  return quads;
}

bool FindQuads(const std::vector<Segment>& segs, const QuadOptions& o, int width, int height,
               std::vector<Quad>* quads_out, std::chrono::steady_clock::time_point deadline) {
  const bool has_deadline = deadline != std::chrono::steady_clock::time_point::max();
  auto past = [&] { return has_deadline && std::chrono::steady_clock::now() >= deadline; };
  quads_out->clear();
  QuadScratch& sc = ThreadScratch<QuadScratch>();
  const int n = static_cast<int>(segs.size());
  const double sin_min_turn = std::sin(o.min_turn_deg * M_PI / 180);
  // Start points `a` binned on a grid of `cell` pixels (with two cells of margin around the
  // image; anything beyond goes to the border cells), by a counting sort. A sorted array of
  // cell keys searched for every cell a long segment's reach covers takes a tenth of the time
  // on cluttered frames. Cells are stored column by column (cell gx * gh + gy), so that a
  // column's cells in a window are one run of by_cell, read in one loop.
  const double cell = std::max(8.0, o.join_min_px * 2);
  const int margin = 2;
  const int gw = static_cast<int>(std::ceil(width / cell)) + 2 * margin;
  const int gh = static_cast<int>(std::ceil(height / cell)) + 2 * margin;
  auto cell_of = [&](double v, int size) {
    const double c = std::floor(v / cell) + margin;
    return static_cast<int>(std::clamp(c, 0.0, size - 1.0));
  };
  sc.cell_begin.assign(static_cast<size_t>(gw) * gh + 1, 0);
  for (int i = 0; i < n; ++i)
    ++sc.cell_begin[cell_of(segs[i].a.x(), gw) * gh + cell_of(segs[i].a.y(), gh) + 1];
  for (size_t c = 1; c < sc.cell_begin.size(); ++c) sc.cell_begin[c] += sc.cell_begin[c - 1];
  sc.by_cell.resize(n);
  for (int i = 0; i < n; ++i) {
    const int c = cell_of(segs[i].a.x(), gw) * gh + cell_of(segs[i].a.y(), gh);
    sc.by_cell[sc.cell_begin[c]++] = i;
  }
  for (size_t c = sc.cell_begin.size() - 1; c > 0; --c) sc.cell_begin[c] = sc.cell_begin[c - 1];
  sc.cell_begin[0] = 0;

  sc.direction.resize(n);
  sc.length.resize(n);
  for (int i = 0; i < n; ++i) {
    sc.length[i] = segs[i].length();
    sc.direction[i] = (segs[i].b - segs[i].a) / sc.length[i];
  }

  // Segments j that may come after i, with the corner where they meet.
  sc.follows.clear();
  sc.follow_begin.assign(1, 0);
  for (int i = 0; i < n; ++i) {
    if (i % 256 == 255 && past()) return false;
    const Segment& s = segs[i];
    const Eigen::Vector2d& di = sc.direction[i];
    const double length_i = sc.length[i];
    // Candidates: starts within the largest join radius of this end.
    const double reach = std::max(o.join_min_px, o.join_fraction * length_i);
    const int r = static_cast<int>(std::ceil(reach / cell));
    const int cx = cell_of(s.b.x(), gw), cy = cell_of(s.b.y(), gh);
    const int gy0 = std::max(0, cy - r), gy1 = std::min(gh - 1, cy + r);
    for (int gx = std::max(0, cx - r); gx <= std::min(gw - 1, cx + r); ++gx) {
      for (int m = sc.cell_begin[gx * gh + gy0]; m < sc.cell_begin[gx * gh + gy1 + 1]; ++m) {
        const int j = sc.by_cell[m];
        if (j == i) continue;
        const Segment& t = segs[j];
        const Eigen::Vector2d& dj = sc.direction[j];
        if (Cross(di, dj) < sin_min_turn) continue;  // must turn right (clockwise on screen)
        const double length_j = sc.length[j];
        const double join = std::max(o.join_min_px, o.join_fraction * std::min(length_i, length_j));
        // A corner within `join` of both ends needs the ends within 2 join of each other (the
        // slack covers rounding): most starts in the window fail this before the intersection.
        const double ends = 2 * join + 1e-9;
        if ((t.a - s.b).squaredNorm() > ends * ends) continue;
        Eigen::Vector2d corner;
        if (!Intersect(s.line, t.line, &corner)) continue;
        if ((corner - s.b).norm() > join || (corner - t.a).norm() > join) continue;
        // The corner must lie beyond the middle of both segments (not a crossing).
        if ((corner - s.a).dot(di) < 0.5 * length_i || (t.b - corner).dot(dj) < 0.5 * length_j)
          continue;
        sc.follows.push_back({j, corner});
      }
    }
    sc.follow_begin.push_back(static_cast<int>(sc.follows.size()));
  }
  const QuadScratch::Follow* f = sc.follows.data();
  auto begin = [&](int i) { return f + sc.follow_begin[i]; };
  auto end = [&](int i) { return f + sc.follow_begin[i + 1]; };
  std::vector<Quad>& quads = *quads_out;
  quads.clear();
  // Sides long enough, corners inside the image, convex and clockwise on screen. Of a completed
  // quad only the middle side is measured (4b checks it): where the rounded corners tilt its
  // first and third sides toward each other (up to 31 degrees on the small sets) the guessed
  // side comes out short, 5.5 px on a 9 px square, and step 8's fit still finds the square.
  auto acceptable = [&](const Quad& q) {
    if (!q.completed && q.min_side() < o.min_side) return false;
    for (int e = 0; e < 4; ++e) {
      const Eigen::Vector2d& p = q.corners[e];
      if (!(p.x() > -0.5 && p.y() > -0.5 && p.x() < width - 0.5 && p.y() < height - 0.5))
        return false;
      if (Cross(q.corners[(e + 1) % 4] - p, q.corners[(e + 2) % 4] - q.corners[(e + 1) % 4]) <= 0)
        return false;
    }
    return true;
  };
  for (int i = 0; i < n && static_cast<int>(quads.size()) < o.max_quads; ++i) {
    if (i % 256 == 255 && past()) return false;
    for (const auto* a = begin(i); a != end(i); ++a) {
      const int j = a->next;
      if (j <= i) continue;  // i is the smallest index of its cycle
      for (const auto* b = begin(j); b != end(j); ++b) {
        const int k = b->next;
        if (k <= i) continue;
        for (const auto* c = begin(k); c != end(k); ++c) {
          const int l = c->next;
          if (l <= i || l == j) continue;
          for (const auto* d = begin(l); d != end(l); ++d) {
            if (d->next != i) continue;
            Quad q;
            q.corners = {d->corner, a->corner, b->corner, c->corner};
            q.sides = {i, j, k, l};
            if (acceptable(q)) quads.push_back(q);
          }
        }
      }
    }
  }
  // 4b. Three small sides i -> j -> k that no fourth closes: the missing corners lie along i
  // and k at the middle side's length from the known ones (a parallelogram). A fourth side that
  // closes them into a quad the search above turned away (too small, concave, off the image)
  // also counts: such a square is not completed either.
  auto closes = [&](int i, int j, int k) {
    for (const auto* c = begin(k); c != end(k); ++c) {
      const int l = c->next;
      if (l == i || l == j) continue;
      for (const auto* d = begin(l); d != end(l); ++d)
        if (d->next == i) return true;
    }
    return false;
  };
  const double small = o.complete_below_px;
  const double cos_max_skew = std::cos(o.complete_max_skew_deg * M_PI / 180);
  for (int i = 0; i < n && small > 0 && static_cast<int>(quads.size()) < o.max_quads; ++i) {
    if (i % 256 == 255 && past()) return false;
    if (sc.length[i] >= small) continue;
    for (const auto* a = begin(i); a != end(i); ++a) {
      const int j = a->next;
      if (sc.length[j] >= small) continue;
      for (const auto* b = begin(j); b != end(j); ++b) {
        const int k = b->next;
        if (k == i || sc.length[k] >= small) continue;
        if (-sc.direction[i].dot(sc.direction[k]) < cos_max_skew) continue;
        const double side = (b->corner - a->corner).norm();
        if (side >= small || side < o.min_side || closes(i, j, k)) continue;
        Quad q;
        q.corners = {a->corner - side * sc.direction[i], a->corner, b->corner,
                     b->corner + side * sc.direction[k]};
        q.sides = {i, j, k, -1};
        q.completed = true;
        if (acceptable(q)) quads.push_back(q);
      }
    }
  }
  return true;
}

}  // namespace svms

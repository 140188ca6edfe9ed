#include "svms/detect/quads.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>

#include "svms/base/thread_scratch.h"
#include "svms/detect/worker_pool.h"

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

struct Follow {
  int next;                // a segment that may come after this one
  Eigen::Vector2d corner;  // where they meet
};

// Buffers of FindQuads, kept per thread between calls (no allocation once grown).
struct QuadScratch {
  // Start points `a` binned on a grid: cell c holds segments by_cell[cell_begin[c],
  // cell_begin[c + 1]).
  std::vector<int> cell_begin, by_cell;
  std::vector<Follow> follows;  // segment i's: follows[follow_begin[i], follow_begin[i + 1])
  std::vector<int> follow_begin;
  // By segment: its unit direction from a to b and its length, computed once rather than for
  // every pair (a textured photograph gives tens of thousands, each meeting dozens of starts).
  std::vector<Eigen::Vector2d> direction;
  std::vector<double> length;
  // With a worker pool, by part of the segments (part k: segments part_begin[k] ..
  // part_begin[k + 1] - 1): their follows, each segment's count of them, and the quads and
  // completed quads whose first side is theirs. Worker threads fill the calling thread's.
  std::vector<int> part_begin;
  std::vector<std::vector<Follow>> part_follows;
  std::vector<std::vector<int>> part_counts;
  std::vector<std::vector<Quad>> part_quads, part_completed;
};

// Appends the quads of `from` to *out in order, as a search over first sides i in increasing
// order that starts no further i once *out holds max_quads does (the serial FindQuads' rule:
// an i's quads are taken whole). `from` is ordered by first side (Quad::sides[0]). False when
// the rule stopped it.
bool AppendQuadsUpToCap(const std::vector<Quad>& from, int max_quads, int* current_i,
                        int* count_before_i, std::vector<Quad>* out) {
  for (const Quad& q : from) {
    if (q.sides[0] != *current_i) {
      *current_i = q.sides[0];
      *count_before_i = static_cast<int>(out->size());
    }
    if (*count_before_i >= max_quads) return false;
    out->push_back(q);
  }
  return true;
}

}  // namespace

std::vector<Quad> FindQuads(const std::vector<Segment>& segs, const QuadOptions& o, int width,
                            int height) {
  std::vector<Quad> quads;
  FindQuads(segs, o, width, height, &quads);
  return quads;
}

bool FindQuads(const std::vector<Segment>& segs, const QuadOptions& o, int width, int height,
               std::vector<Quad>* quads_out, std::chrono::steady_clock::time_point deadline,
               WorkerPool* pool) {
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

  // The segments in parts, searched from each part's segments on their own and put together
  // in the order of the segments: on several threads the same follows and quads, in the same
  // order, as on one. Few segments are not worth a pool's hand-over.
  const bool parallel = pool && pool->threads() > 1 && n >= 512;
  const int parts = parallel ? std::min(n, 4 * pool->threads()) : 1;
  sc.part_begin.resize(parts + 1);
  for (int k = 0; k <= parts; ++k)
    sc.part_begin[k] = static_cast<int>(static_cast<int64_t>(n) * k / parts);
  if (sc.part_follows.size() < static_cast<size_t>(parts)) {
    sc.part_follows.resize(parts);
    sc.part_counts.resize(parts);
    sc.part_quads.resize(parts);
    sc.part_completed.resize(parts);
  }
  auto run = [&](const auto& task) {
    if (parallel)
      pool->Run(parts, task);
    else
      task(0);
  };
  std::atomic<bool> stopped{false};

  // Segments j that may come after i, with the corner where they meet.
  run([&](int part) {
    std::vector<Follow>& follows = sc.part_follows[part];
    std::vector<int>& counts = sc.part_counts[part];
    follows.clear();
    counts.clear();
    for (int i = sc.part_begin[part]; i < sc.part_begin[part + 1]; ++i) {
      if (i % 256 == 255 && past()) {
        stopped = true;
        return;
      }
      const Segment& s = segs[i];
      const Eigen::Vector2d& di = sc.direction[i];
      const double length_i = sc.length[i];
      const size_t before = follows.size();
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
          const double join =
              std::max(o.join_min_px, o.join_fraction * std::min(length_i, length_j));
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
          follows.push_back({j, corner});
        }
      }
      counts.push_back(static_cast<int>(follows.size() - before));
    }
  });
  if (stopped) return false;
  sc.follows.clear();
  sc.follow_begin.assign(1, 0);
  for (int part = 0; part < parts; ++part) {
    if (parts == 1)
      std::swap(sc.follows, sc.part_follows[0]);  // both keep their capacity: no copy
    else
      sc.follows.insert(sc.follows.end(), sc.part_follows[part].begin(),
                        sc.part_follows[part].end());
    for (const int count : sc.part_counts[part])
      sc.follow_begin.push_back(sc.follow_begin.back() + count);
  }
  const Follow* f = sc.follows.data();
  auto begin = [&](int i) { return f + sc.follow_begin[i]; };
  auto end = [&](int i) { return f + sc.follow_begin[i + 1]; };
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
  // Each part's quads (i the smallest index of its cycle) and completed quads (i the first
  // side), i in the part's range. A part stops starting new i once it alone holds max_quads
  // (its completed quads counting its quads, as the serial search counts them): put together,
  // the search keeps no further i past that count either (AppendQuadsUpToCap). With one part
  // this is the serial search itself.
  run([&](int part) {
    std::vector<Quad>& quads = sc.part_quads[part];
    std::vector<Quad>& completed = sc.part_completed[part];
    quads.clear();
    completed.clear();
    const int i0 = sc.part_begin[part], i1 = sc.part_begin[part + 1];
    for (int i = i0; i < i1 && static_cast<int>(quads.size()) < o.max_quads; ++i) {
      if (i % 256 == 255 && past()) {
        stopped = true;
        return;
      }
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
    for (int i = i0;
         i < i1 && small > 0 && static_cast<int>(quads.size() + completed.size()) < o.max_quads;
         ++i) {
      if (i % 256 == 255 && past()) {
        stopped = true;
        return;
      }
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
          if (acceptable(q)) completed.push_back(q);
        }
      }
    }
  });
  // The quads of every part in order, then the completed ones, each list cut where a search
  // from i = 0 upward would have stopped at max_quads (the first list's count counting toward
  // the second's). What the parts found before a deadline stopped them is returned.
  std::vector<Quad>& quads = *quads_out;
  int current_i = -1, count_before_i = 0;
  for (int part = 0; part < parts; ++part)
    if (!AppendQuadsUpToCap(sc.part_quads[part], o.max_quads, &current_i, &count_before_i, &quads))
      break;
  current_i = -1;
  for (int part = 0; part < parts && static_cast<int>(quads.size()) < o.max_quads; ++part)
    if (!AppendQuadsUpToCap(sc.part_completed[part], o.max_quads, &current_i, &count_before_i,
                            &quads))
      break;
  return !stopped;
}

}  // namespace svms

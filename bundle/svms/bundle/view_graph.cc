#include "svms/bundle/view_graph.h"

#include <algorithm>
#include <deque>
#include <functional>
#include <numeric>
#include <queue>
#include <set>

#include "svms/geometry/alignment.h"
#include "svms/geometry/so3.h"

namespace svms {
namespace {

// Adjacency: marker -> neighbours (ascending).
std::map<int, std::set<int>> Adjacency(const std::vector<ImageSightings>& images) {
  std::map<int, std::set<int>> adj;
  for (const ImageSightings& im : images)
    for (const MarkerSighting& a : im) {
      adj[a.marker_id];
      for (const MarkerSighting& b : im)
        if (a.marker_id != b.marker_id) adj[a.marker_id].insert(b.marker_id);
    }
  return adj;
}

}  // namespace

std::vector<std::vector<int>> ConnectedComponents(const std::vector<ImageSightings>& images) {
  const std::map<int, std::set<int>> adj = Adjacency(images);
  std::set<int> seen;
  std::vector<std::vector<int>> out;
  for (const auto& [start, unused] : adj) {
    if (seen.count(start)) continue;
    std::vector<int> comp;
    std::deque<int> queue{start};
    seen.insert(start);
    while (!queue.empty()) {
      const int m = queue.front();
      queue.pop_front();
      comp.push_back(m);
      for (int n : adj.at(m))
        if (seen.insert(n).second) queue.push_back(n);
    }
    std::sort(comp.begin(), comp.end());
    out.push_back(comp);
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const auto& a, const auto& b) { return a.size() > b.size(); });
  return out;
}

std::string DescribeComponents(const std::vector<std::vector<int>>& components,
                               const std::vector<ImageSightings>& images) {
  std::string s;
  for (size_t c = 0; c < components.size(); ++c) {
    const std::set<int> ids(components[c].begin(), components[c].end());
    int n = 0;
    for (const ImageSightings& im : images)
      n += std::any_of(im.begin(), im.end(),
                       [&](const MarkerSighting& m) { return ids.count(m.marker_id) > 0; });
    if (c) s += ", ";
    s += "{";
    for (size_t i = 0; i < components[c].size(); ++i)
      s += (i ? " " : "") + std::to_string(components[c][i]);
    s += "} (" + std::to_string(n) + (n == 1 ? " image)" : " images)");
  }
  return s;
}

Pose PlainAverage(const std::vector<Pose>& samples) {
  Eigen::Matrix3d M = Eigen::Matrix3d::Zero();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  for (const Pose& p : samples) {
    M += p.Rotation();
    t += p.tvec;
  }
  return Pose::FromRotation(NearestRotation(M), t / static_cast<double>(samples.size()));
}

RelativePoseAverage RobustAverage(const std::vector<Pose>& samples, double inlier_angle_rad,
                                  double inlier_distance) {
  const size_t n = samples.size();
  RelativePoseAverage out;
  out.samples = static_cast<int>(n);
  // Medoid: the sample with the least summed (capped) distance to the others, distances in
  // units of the inlier thresholds. Beyond 200 samples, 200 evenly spaced candidates.
  // The angle between two samples is AngleBetweenRad's, through their unit quaternions
  // (AngleBetweenUnitQuaternionsRad): this loop makes up to 200 n pairs, and the inlier angle
  // it is compared with is degrees.
  std::vector<Eigen::Quaterniond> q(n);
  for (size_t i = 0; i < n; ++i) q[i] = Eigen::Quaterniond(samples[i].Rotation()).normalized();
  auto angle = [&](size_t i, size_t j) { return AngleBetweenUnitQuaternionsRad(q[i], q[j]); };
  auto dist = [&](size_t i, size_t j) {
    const double d = angle(i, j) / inlier_angle_rad +
                     (samples[i].tvec - samples[j].tvec).norm() / inlier_distance;
    return std::min(d, 10.0);
  };
  const size_t step = std::max<size_t>(1, n / 200);
  size_t best = 0;
  double best_sum = 1e300;
  for (size_t i = 0; i < n; i += step) {
    double sum = 0;
    for (size_t j = 0; j < n; ++j) sum += dist(i, j);
    if (sum < best_sum) {
      best_sum = sum;
      best = i;
    }
  }
  std::vector<Pose> inliers;
  for (size_t i = 0; i < n; ++i)
    if (angle(i, best) <= inlier_angle_rad &&
        (samples[i].tvec - samples[best].tvec).norm() <= inlier_distance)
      inliers.push_back(samples[i]);
  out.inliers = static_cast<int>(inliers.size());
  out.a_from_b = PlainAverage(inliers);
  return out;
}

std::map<std::pair<int, int>, std::vector<Pose>> RelativePoseSamples(
    const std::vector<ImageSightings>& images) {
  std::map<std::pair<int, int>, std::vector<Pose>> out;
  for (const ImageSightings& im : images)
    for (const MarkerSighting& a : im)
      for (const MarkerSighting& b : im)
        if (a.marker_id < b.marker_id)
          out[{a.marker_id, b.marker_id}].push_back(a.cam_from_marker.Inverse() *
                                                    b.cam_from_marker);
  return out;
}

std::map<int, Pose> SpanningTreeLayout(const std::vector<ImageSightings>& images, int root,
                                       double inlier_angle_rad, double inlier_distance) {
  const auto samples = RelativePoseSamples(images);
  std::map<std::pair<int, int>, RelativePoseAverage> edges;
  std::map<int, std::vector<int>> adj;
  for (const auto& [key, s] : samples) {
    edges[key] = RobustAverage(s, inlier_angle_rad, inlier_distance);
    adj[key.first].push_back(key.second);
    adj[key.second].push_back(key.first);
  }
  // Prim's algorithm for a maximum spanning tree from the root; weight = inliers, then
  // samples; composing root_from_marker as each marker joins.
  std::map<int, Pose> out;
  bool root_seen = false;
  for (const ImageSightings& im : images)
    for (const MarkerSighting& s : im) root_seen |= s.marker_id == root;
  if (!root_seen) return out;
  out[root] = Pose();
  using Item = std::tuple<int, int, int, int>;  // inliers, samples, -to, from
  std::priority_queue<Item> heap;
  auto push_edges = [&](int from) {
    for (int to : adj[from]) {
      if (out.count(to)) continue;
      const RelativePoseAverage& e = edges.at({std::min(from, to), std::max(from, to)});
      heap.emplace(e.inliers, e.samples, -to, from);
    }
  };
  push_edges(root);
  while (!heap.empty()) {
    const auto [inl, smp, neg_to, from] = heap.top();
    heap.pop();
    const int to = -neg_to;
    if (out.count(to)) continue;
    const RelativePoseAverage& e = edges.at({std::min(from, to), std::max(from, to)});
    const Pose from_to = from < to ? e.a_from_b : e.a_from_b.Inverse();
    out[to] = out.at(from) * from_to;
    push_edges(to);
  }
  return out;
}

std::map<int, Pose> PairwiseAverageLayout(const std::vector<ImageSightings>& images, int root) {
  const auto samples = RelativePoseSamples(images);
  const std::map<int, std::set<int>> adj = Adjacency(images);
  std::map<int, Pose> out;
  if (!adj.count(root)) return out;
  out[root] = Pose();
  std::deque<int> queue{root};
  while (!queue.empty()) {
    const int from = queue.front();
    queue.pop_front();
    for (int to : adj.at(from)) {
      if (out.count(to)) continue;
      const Pose mean = PlainAverage(samples.at({std::min(from, to), std::max(from, to)}));
      out[to] = out.at(from) * (from < to ? mean : mean.Inverse());
      queue.push_back(to);
    }
  }
  return out;
}

bool InitialCameraPose(const ImageSightings& image, const std::map<int, Pose>& object_from_marker,
                       Pose* cam_from_object) {
  const MarkerSighting* best = nullptr;
  for (const MarkerSighting& s : image) {
    if (!object_from_marker.count(s.marker_id)) continue;
    if (!best || (best->ambiguous && !s.ambiguous) ||
        (best->ambiguous == s.ambiguous && s.side_px > best->side_px))
      best = &s;
  }
  if (!best) return false;
  *cam_from_object = best->cam_from_marker * object_from_marker.at(best->marker_id).Inverse();
  return true;
}

}  // namespace svms

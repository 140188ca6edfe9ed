// The co-visibility graph of a survey and the initial layout drawn from it.
//
// Nodes are markers; two markers share an edge when some image sees both. Along an edge, each
// such image gives one sample of the relative pose a_from_b = (cam_from_a)^-1 cam_from_b from
// the detector's single-marker poses. The initial layout averages every edge robustly (the
// medoid of the samples on rotation and translation together, then the mean of the samples
// close to it, so that one bad view - a flipped planar pose, a wrong ID - cannot poison it), and
// chains the averaged edges over a maximum spanning tree (weight: the number of agreeing
// samples) from the root marker. The naive approach a user would otherwise take (plain means
// of the relative poses, chained along the fewest hops) is here too, as the benchmark's
// baseline.
#pragma once

#include <map>
#include <string>
#include <vector>

#include "svms/geometry/pose.h"

namespace svms {

// One marker's single-image pose.
struct MarkerSighting {
  int marker_id = -1;
  Pose cam_from_marker;
  double side_px = 0;      // mean side of the square in the image, pixels
  bool ambiguous = false;  // the detector could not tell the two planar poses apart
};
// Every sighting in one image.
using ImageSightings = std::vector<MarkerSighting>;

// Connected components of the co-visibility graph (marker IDs, ascending), largest first
// (ties: smallest ID first). Every marker sighted at least once is in one component.
std::vector<std::vector<int>> ConnectedComponents(const std::vector<ImageSightings>& images);

// "{10 11 12} (120 images), {17 18} (30 images)": components with the number of images that
// see them, for messages.
std::string DescribeComponents(const std::vector<std::vector<int>>& components,
                               const std::vector<ImageSightings>& images);

struct RelativePoseAverage {
  Pose a_from_b;
  int samples = 0;  // images that see both
  int inliers = 0;  // samples close to the medoid, averaged
};

// Robust average of relative-pose samples (see above). A sample is an inlier when its rotation
// is within `inlier_angle_rad` and its translation within `inlier_distance` (metres) of the
// medoid. Requires at least one sample.
RelativePoseAverage RobustAverage(const std::vector<Pose>& samples, double inlier_angle_rad,
                                  double inlier_distance);

// The plain mean (chordal mean of the rotations, mean of the translations) of all samples.
Pose PlainAverage(const std::vector<Pose>& samples);

// Relative-pose samples for every pair of markers seen together: key (a, b) with a < b,
// value the samples of a_from_b.
std::map<std::pair<int, int>, std::vector<Pose>> RelativePoseSamples(
    const std::vector<ImageSightings>& images);

// The initial layout: root_from_marker for every marker connected to `root`, from robust
// edge averages over a maximum spanning tree. Markers not connected to the root are absent.
std::map<int, Pose> SpanningTreeLayout(const std::vector<ImageSightings>& images, int root,
                                       double inlier_angle_rad, double inlier_distance);

// The naive baseline: root_from_marker as the plain mean of the relative poses of each pair,
// chained along a shortest (fewest hops) path from the root; no robust step, no adjustment.
std::map<int, Pose> PairwiseAverageLayout(const std::vector<ImageSightings>& images, int root);

// cam_from_object for one image from its sightings and a layout (object_from_marker): the
// sighting of a marker in the layout with the largest side in pixels, preferring unambiguous
// poses. false if no sighted marker is in the layout.
bool InitialCameraPose(const ImageSightings& image, const std::map<int, Pose>& object_from_marker,
                       Pose* cam_from_object);

}  // namespace svms

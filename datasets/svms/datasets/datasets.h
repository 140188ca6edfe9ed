// The standard simulated datasets that the tests and benchmarks measure on: scene definitions
// generated deterministically from a seed. `svms dataset NAME --out DIR` writes them and
// renders them; images are never committed.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "svms/marker/layout.h"
#include "svms/sim/scene.h"

namespace svms {

struct DatasetOptions {
  uint64_t seed = 1;
  bool quick = false;  // a small subset of the views, for smoke tests
};

struct Dataset {
  std::string name;
  std::string description;
  // Scenes to render, each into its own sub-directory (empty: DIR itself).
  std::vector<std::pair<std::string, Scene>> scenes;
  // Companion files (relative path, contents): true camera models, layouts.
  std::vector<std::pair<std::string, std::string>> files;
};

// The names of the standard datasets, in order: range, angle, small, sun, occlusion, mockup,
// approach, calibration, clutter; and gallery (the documentation's pictures).
std::vector<std::string> DatasetNames();
std::string DatasetDescription(const std::string& name);

// Builds a dataset; false with a message for an unknown name.
Status MakeDataset(const std::string& name, const DatasetOptions& options, Dataset* out);
// Puts every scene of `dataset` through the sensor profile `profile` (scene.h,
// ApplySensorProfile): the camera pipeline changes, the light and the views do not. An unknown
// name is an error that lists the names, and changes nothing.
Status ApplySensorProfile(const std::string& profile, Dataset* dataset);

// Helpers shared by the generators (and useful for tests):
// cam_from_world for a camera at `eye` looking at `target`, image "up" close to `up`.
Pose LookAt(const Eigen::Vector3d& eye, const Eigen::Vector3d& target, const Eigen::Vector3d& up);
// The pose on a box of half extents `half` that puts a marker on the face whose outward normal
// is +/- axis `axis` (0 x, 1 y, 2 z), at (u, v) along the face's other two axes (in increasing
// axis order), turned by `spin` radians about the face normal.
Pose OnBoxFace(const Eigen::Vector3d& half, int axis, int sign, double u, double v, double spin);
// One marker, its frame the world's, on a dark 2 m plate (object "plate", its front at world
// z = 0, its frame 1 cm behind), sunlit from above and to one side, seen once from
// `cam_from_world` ("v"): end-to-end tests of a lone marker. The plate's layout entry is
// `LoneMarkerLayout(marker)`.
Scene LoneMarkerScene(const CameraModel& camera, const MarkerModel& marker,
                      const Pose& cam_from_world);
Layout LoneMarkerLayout(const MarkerModel& marker);
// The 1024 x 1024 camera of the range geometry: a pinhole whose focal length makes 0.432 m
// 30 px wide at 16 m (f = 1111.1 px).
CameraModel RangeCamera();
// A 1024 x 1024 camera with real distortion (LENSMODEL_OPENCV8), used for calibration and
// the mockup.
CameraModel DistortedCamera();

}  // namespace svms

// Ground truth of a rendered scene, computed from geometry (never from pixels): camera and
// marker poses, the projected corners and post tip with visibility flags, and how many of the
// 44 data bits are occluded or in shadow. Written as DIR/truth.json (docs/simulator.md).
#pragma once

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

#include "svms/geometry/pose.h"
#include "svms/sim/render.h"

namespace svms {

struct PointTruth {
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();  // mrcal projection; NaN if it cannot project
  bool projects = false;   // mrcal could project it (in front of the camera)
  bool in_image = false;   // within the image: [-0.5, W - 0.5] x [-0.5, H - 0.5]
  bool occluded = false;   // something lies between the camera and the point
  bool in_shadow = false;  // the centre of the sun is hidden from the point
};

struct MarkerTruth {
  int id = -1;
  std::string family = "svms44";  // what is printed (scene.h PrintedTag): svms44 or a peer tag
  int nested_in = -1;             // the outer marker's ID for an inner marker, else -1
  std::string object;             // the object carrying it
  Pose cam_from_marker;
  // Black-square corners, order of docs/conventions.md. For a peer tag: its outer black
  // edge's corners, which are the same points (the tag is printed on the black square).
  std::array<PointTruth, 4> corners;
  bool has_tip = false;
  PointTruth tip;  // the post tip (white top or well bottom)
  // Of the 44 cell centres (a peer tag: of its (n - 2)^2 data cell centres).
  int bits_occluded = 0;
  int bits_in_shadow = 0;
  int bits_outside = 0;    // cell centres outside the image (or behind the camera)
  double side_px = 0;      // mean side of the projected square, pixels
  double min_side_px = 0;  // its shortest side (what "a 30 x 30 px marker" means)
  bool facing = false;     // the marker's front faces the camera
  // Facing the camera, with all four corners and all data cell centres in the image and
  // unoccluded: everything the detector needs to identify it.
  bool fully_visible() const;
};

struct ViewTruth {
  std::string name;  // image file is name + ViewFileExtension(sensor): ".png" or ".jpg"
  Pose cam_from_world;
  std::vector<std::pair<std::string, Pose>> cam_from_object;
  std::vector<MarkerTruth> markers;
};

// Truth of view `view` of the renderer's scene.
ViewTruth ComputeTruth(const Renderer& renderer, int view);

// The whole truth.json document: the scene's camera model (inline), the scene's settings, the
// photometry the images were stored with ("photometry": response, bits, signal_bits,
// black_level, white_level, bayer, format, and channel_gain or jpeg_quality where they apply),
// and every view.
std::string TruthToJson(const Scene& scene, const std::vector<ViewTruth>& views);

}  // namespace svms

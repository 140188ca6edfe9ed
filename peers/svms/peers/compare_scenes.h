// The scenes of the comparison benchmark (svms bench compare): one SVMS marker per image on a
// dark plate, in four sweeps (size, viewing angle, occlusion, sun and shadow), plus the
// standard clutter set (no markers: false positives) and the range set (the paper's Fig. 9).
//
// Every sweep is built once with SVMS markers; PeerScene() then prints a peer tag in place of
// every marker (peer_tags.h: its outer black edge on the SVMS black square). Camera, poses,
// light, occluders, sensor, noise seed and rays per pixel stay the same, so the three images
// of a view differ only in what is printed. Views carry their sweep and condition in their
// name: "size_030px_02", "angle_60deg_01", "occl_60_0007", "sun_e45_a045", "lowsun_e10_a045",
// "edge_40deg_03", "shadow_e30_00".
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "svms/sim/scene.h"

namespace svms {

struct CompareOptions {
  uint64_t seed = 1;
  bool quick = false;        // a few views per sweep (smoke test, < 2 min in all)
  int size_views = 8;        // views per marker size in the size sweep (quick: 1)
  double marker_size = 0.1;  // black square side (= a peer's outer black edge), metres
  // The SVMS post's height over the black square's side (the size sweep's 8 px markers: a
  // 2 px lever at 0.25).
  double post_height_fraction = 0.25;
  // Rays per pixel where a pixel differs from a neighbour (Sensor::edge_rays_per_pixel), in
  // every scene of the comparison, the clutter and range sets included: 0 (off) or a square
  // number of at most 4096. At the datasets' 16 rays an edge pixel's coverage is 5 % of the
  // edge's contrast off, several times a sunlit white's shot noise, and it sets every system's
  // corner error on small markers (docs/simulator.md); 256 takes it to 0.6 %.
  int edge_rays_per_pixel = 256;
};

struct CompareSweep {
  std::string name;         // "size", "angle", "occlusion", "sun"
  std::string description;  // one line, for the report
  Scene scene;              // SVMS markers
};

// The four sweeps (1024 x 1024 pinhole of the range set, f = 1111.1 px; the standard sensor).
std::vector<CompareSweep> MakeCompareSweeps(const CompareOptions& options);

// `scene` with every marker printed as the peer tag of `family` ("svms44": unchanged). Marker
// k of the scene (in object order) gets peer ID (7 + 37 k) mod the family's size.
Status PeerScene(const Scene& scene, const std::string& family, Scene* out);

}  // namespace svms

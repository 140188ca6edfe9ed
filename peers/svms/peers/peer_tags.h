// The peer marker systems' tags, printed into simulator scenes for the comparison benchmark
// (svms bench compare): AprilTag tag36h11 (libapriltag 3.3's own code table) and OpenCV 4.6
// ArUco DICT_6X6_1000 (the dictionary's own drawMarker).
//
// Fairness, "the same physical size by the outer black border": a peer tag is printed so that
// its outer black edge is exactly the SVMS marker's black square (side MarkerModel::size). The
// four corners every detector reports, and every pose is computed from, are then the same
// points in space, seen by the same camera from the same poses: the comparison is of detectors
// and codes on the same pose reference. Both peers are 8 x 8 cells at that edge (a 1-cell black
// border around 6 x 6 data), so a cell is size / 8, against the SVMS data cell of size / 6; but
// the SVMS marker's data ring lies outside the square, so its whole decal is 2 x size wide
// (4x the area) while a peer tag is size wide plus its white quiet zone. A reader who prefers
// "the same footprint" reads the SVMS curves at twice the size in pixels (docs/bench).
// Around a peer tag the rest of the SVMS decal is printed white (a quiet zone of size / 2, more
// than the 1 cell both peers ask for). Peer tags carry no post and no nested marker.
#pragma once

#include <string>
#include <vector>

#include "svms/base/status.h"
#include "svms/sim/scene.h"

namespace svms {

inline constexpr const char* kTag36h11 = "tag36h11";  // AprilTag 3, 587 IDs, distance 11
inline constexpr const char* kAruco6x6 = "aruco6x6";  // OpenCV DICT_6X6_1000, 1000 IDs

// "tag36h11", "aruco6x6".
std::vector<std::string> PeerFamilies();
// IDs in the family (587, 1000), or 0 for an unknown family.
int PeerIdCount(const std::string& family);

// The printed grid of tag `id` of `family`: 8 x 8 cells, outer black border included, row 0 at
// the top as printed (the tag's own upright orientation). Fails for an unknown family or ID.
Status MakePeerTag(const std::string& family, int id, PrintedTag* out);

// The scene marker `svms` with the peer tag `id` printed in its place: same pose, black-square
// side and print reflectances; no post, no nested marker; model.id = id (the peer ID).
Status AsPeerMarker(const SceneMarker& svms, const std::string& family, int id, SceneMarker* out);

}  // namespace svms

// Two objects in one frame, for the tests of estimating several objects from one detection pass:
// the approach's scene (the "module", a box with 8 markers, IDs 10-18) with a second object, a
// flat "fixture" plate with three markers (IDs 30-32, 0.12 m, with posts), standing in front of
// the camera of one view, beside the module: in view 6 (the module at 4.5 m, in the middle of
// the frame) the plate is 3.6 m away in the lower left, its markers about 37 px wide, facing the
// camera but turned 25 degrees about the camera's y axis (the sun lights it in that view).
#pragma once

#include <Eigen/Geometry>
#include <cmath>

#include "svms/marker/layout.h"
#include "svms/sim/scene.h"

namespace svms_testing {

constexpr int kTwoObjectsView = 6;  // the approach's view in which both objects are seen
constexpr int kFixtureIds[3] = {30, 31, 32};

// The fixture's true layout (object frame: the plate's centre, z out of its face), named
// "fixture", with no covariance.
inline svms::Layout FixtureLayout() {
  svms::Layout layout;
  layout.name = "fixture";
  for (int i = 0; i < 3; ++i) {
    svms::LayoutEntry e;
    e.marker = svms::MarkerModel::Standard(kFixtureIds[i], 0.12, 0.02);
    e.object_from_marker.tvec = Eigen::Vector3d(-0.33 + 0.33 * i, i == 1 ? 0.04 : -0.02, 0);
    e.object_from_marker.rvec = Eigen::Vector3d(0, 0, 0.15 * (i - 1));  // turned in the plane
    layout.markers.push_back(e);
  }
  return layout;
}

// cam_from_fixture in view kTwoObjectsView: 3.6 m ahead, to the lower left, its face toward the
// camera (z of the plate about -z of the camera) and turned 25 degrees about the camera's y.
inline svms::Pose CamFromFixture() {
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(25 * M_PI / 180, Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(10 * M_PI / 180, Eigen::Vector3d::UnitX()) *
                             Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX()))
                                .toRotationMatrix();
  return svms::Pose::FromRotation(R, Eigen::Vector3d(-0.75, 0.8, 3.6));
}

// `approach` (the approach dataset's scene) with the fixture added as the object "fixture".
inline svms::Scene WithFixture(const svms::Scene& approach) {
  svms::Scene scene = approach;
  svms::SceneObject plate;
  plate.name = "fixture";
  plate.shape = svms::SceneObject::Shape::kPlane;
  plate.size = Eigen::Vector3d(1.05, 0.4, 0);
  plate.material.reflectance = 0.35;
  plate.world_from_object =
      scene.views.at(kTwoObjectsView).cam_from_world.Inverse() * CamFromFixture();
  for (const svms::LayoutEntry& e : FixtureLayout().markers) {
    svms::SceneMarker m;
    m.model = e.marker;
    m.object_from_marker = e.object_from_marker;
    plate.markers.push_back(m);
  }
  scene.objects.push_back(plate);
  return scene;
}

}  // namespace svms_testing

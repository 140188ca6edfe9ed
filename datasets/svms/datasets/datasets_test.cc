#include "svms/datasets/datasets.h"

#include <gtest/gtest.h>

#include <set>

#include "svms/marker/model_io.h"

namespace svms {
namespace {

TEST(Datasets, EveryDatasetBuildsValidScenesThatRoundTrip) {
  for (const std::string& name : DatasetNames()) {
    for (bool quick : {true, false}) {
      Dataset d;
      ASSERT_TRUE(MakeDataset(name, DatasetOptions{3, quick}, &d).ok()) << name;
      ASSERT_FALSE(d.scenes.empty()) << name;
      EXPECT_FALSE(d.description.empty());
      for (const auto& [sub, scene] : d.scenes) {
        EXPECT_TRUE(scene.Validate().ok()) << name;
        Scene back;
        const Status s = ParseSceneJson(SceneToJson(scene), name, "", &back);
        ASSERT_TRUE(s.ok()) << s.message();
        EXPECT_EQ(back.views.size(), scene.views.size());
        // Edge pixels at 256 rays, as in the compare scenes: one simulator for calibration,
        // test and comparison.
        EXPECT_EQ(scene.sensor.edge_rays_per_pixel, 256) << name << "/" << sub;
        EXPECT_EQ(back.sensor.edge_rays_per_pixel, 256) << name << "/" << sub;
      }
    }
  }
  Dataset d;
  EXPECT_FALSE(MakeDataset("moon", DatasetOptions{}, &d).ok());
}

TEST(Datasets, ASensorProfileChangesEveryScenesPipelineAndNothingElse) {
  Dataset plain, raw;
  ASSERT_TRUE(MakeDataset("calibration", DatasetOptions{2, true}, &plain).ok());
  ASSERT_TRUE(MakeDataset("calibration", DatasetOptions{2, true}, &raw).ok());
  ASSERT_GE(raw.scenes.size(), 2u);
  ASSERT_TRUE(ApplySensorProfile("raw12_bayer", &raw).ok());
  for (size_t i = 0; i < raw.scenes.size(); ++i) {
    const Sensor& s = raw.scenes[i].second.sensor;
    EXPECT_EQ(s.bits, 16);
    EXPECT_EQ(s.signal_bits, 12);
    EXPECT_EQ(s.black_level, 256);
    EXPECT_EQ(s.bayer, "RGGB");
    // The light and the sampling stay the standard sensor's.
    const Sensor& p = plain.scenes[i].second.sensor;
    EXPECT_EQ(s.exposure, p.exposure);
    EXPECT_EQ(s.full_well, p.full_well);
    EXPECT_EQ(s.edge_rays_per_pixel, 256);
    // Only the sensor differs, and the scene file carries it.
    Scene back;
    ASSERT_TRUE(ParseSceneJson(SceneToJson(raw.scenes[i].second), "x", "", &back).ok());
    EXPECT_EQ(back.sensor.bayer, "RGGB");
    back.sensor = p;
    EXPECT_EQ(SceneToJson(back), SceneToJson(plain.scenes[i].second));
  }
  // An unknown name changes nothing and names the choices.
  const std::string before = SceneToJson(raw.scenes[0].second);
  const Status st = ApplySensorProfile("raw16", &raw);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("\"raw16\": unknown; expected linear, srgb8"), std::string::npos)
      << st.message();
  EXPECT_EQ(SceneToJson(raw.scenes[0].second), before);
}

TEST(Datasets, AreDeterministicFromTheSeed) {
  Dataset a, b, c;
  ASSERT_TRUE(MakeDataset("mockup", DatasetOptions{5, false}, &a).ok());
  ASSERT_TRUE(MakeDataset("mockup", DatasetOptions{5, false}, &b).ok());
  ASSERT_TRUE(MakeDataset("mockup", DatasetOptions{6, false}, &c).ok());
  EXPECT_EQ(SceneToJson(a.scenes[0].second), SceneToJson(b.scenes[0].second));
  EXPECT_NE(SceneToJson(a.scenes[0].second), SceneToJson(c.scenes[0].second));
  EXPECT_EQ(a.scenes[0].second.views.size(), 200u);
}

TEST(Datasets, MockupHasEightMarkersOfThreeSizesWithADualAndAConcave) {
  Dataset d;
  ASSERT_TRUE(MakeDataset("mockup", DatasetOptions{}, &d).ok());
  const SceneObject& box = d.scenes[0].second.objects.at(0);
  ASSERT_EQ(box.markers.size(), 8u);
  std::set<double> sizes;
  int duals = 0, concave = 0;
  for (const SceneMarker& m : box.markers) {
    sizes.insert(m.model.size);
    duals += m.model.inner.has_value();
    concave += m.model.post && m.model.post->concave();
    // Each marker lies on a face of the box: its centre on the surface, its z along the
    // face's outward normal.
    const Eigen::Vector3d c = m.object_from_marker.tvec, n = m.object_from_marker.Rotation().col(2);
    const Eigen::Vector3d half = 0.5 * box.size;
    int axis;
    n.cwiseAbs().maxCoeff(&axis);
    EXPECT_NEAR(std::abs(n[axis]), 1, 1e-12);
    EXPECT_NEAR(c[axis], n[axis] * half[axis], 1e-12);
    for (int k = 0; k < 3; ++k) {
      if (k != axis) {
        EXPECT_LE(std::abs(c[k]) + m.model.half_extent(), half[k] + 1e-9) << m.model.id;
      }
    }
  }
  EXPECT_EQ(sizes.size(), 3u);
  EXPECT_EQ(duals, 1);
  EXPECT_EQ(concave, 1);
  // The true layout companion file parses and matches.
  bool found = false;
  for (const auto& [rel, text] : d.files) {
    if (rel != "true_layout.json") continue;
    ModelFile f;
    ASSERT_TRUE(ParseModelJson(text, rel, &f).ok());
    EXPECT_EQ(f.layout.markers.size(), 8u);
    found = true;
  }
  EXPECT_TRUE(found);
}

// The range set's true layout (what `svms bench pose --object plate --reference 1` reads):
// its dual marker where the scene prints it on the plate, inner marker included.
TEST(Datasets, TheRangeSetsTrueLayoutIsWhereTheSceneHasItsMarker) {
  Dataset d;
  ASSERT_TRUE(MakeDataset("range", DatasetOptions{1, true}, &d).ok());
  const SceneObject& plate = d.scenes.at(0).second.objects.at(0);
  ASSERT_EQ(plate.name, "plate");
  ASSERT_EQ(plate.markers.size(), 1u);
  bool found = false;
  for (const auto& [rel, text] : d.files) {
    if (rel != "true_layout.json") continue;
    ModelFile f;
    ASSERT_TRUE(ParseModelJson(text, rel, &f).ok());
    ASSERT_EQ(f.layout.markers.size(), 1u);
    const LayoutEntry& e = f.layout.markers[0];
    EXPECT_EQ(e.marker.id, 1);
    ASSERT_TRUE(e.marker.inner);
    EXPECT_EQ(e.marker.inner->id, 2);
    EXPECT_NEAR(e.marker.size, 0.432, 1e-12);
    EXPECT_LT((e.object_from_marker.tvec - plate.markers[0].object_from_marker.tvec).norm(), 1e-12);
    EXPECT_LT((e.object_from_marker.rvec - plate.markers[0].object_from_marker.rvec).norm(), 1e-12);
    found = true;
  }
  EXPECT_TRUE(found);
}

TEST(Datasets, LookAtPutsTheTargetOnTheOpticalAxis) {
  const Eigen::Vector3d eye(1, -2, 3), target(0.2, 0.1, -0.3);
  const Pose cam_from_world = LookAt(eye, target, Eigen::Vector3d(0, 0, 1));
  const Eigen::Vector3d t = cam_from_world * target;
  EXPECT_NEAR(t.x(), 0, 1e-12);
  EXPECT_NEAR(t.y(), 0, 1e-12);
  EXPECT_NEAR(t.z(), (target - eye).norm(), 1e-12);
  // World up appears up in the image (negative camera y).
  EXPECT_LT((cam_from_world.Rotation() * Eigen::Vector3d(0, 0, 1)).y(), 0);
}

TEST(Datasets, RangeCameraMakesTheOuterSquare30PixelsAt16Metres) {
  const CameraModel cam = RangeCamera();
  Eigen::Vector2d a, b;
  ASSERT_TRUE(cam.Project(Eigen::Vector3d(-0.216, 0, 16), &a));
  ASSERT_TRUE(cam.Project(Eigen::Vector3d(0.216, 0, 16), &b));
  EXPECT_NEAR((b - a).norm(), 30.0, 1e-9);
}

// The small set is there to put hundreds of markers into the size buckets below 30 px: every
// marker of every view in the image, and most of them between 8 and 24 px.
TEST(Datasets, TheSmallSetsMarkersAreSmallAndInTheImage) {
  Dataset d;
  ASSERT_TRUE(MakeDataset("small", DatasetOptions{1, false}, &d).ok());
  const Scene& s = d.scenes.at(0).second;
  ASSERT_EQ(s.objects.size(), 1u);
  ASSERT_EQ(s.objects[0].markers.size(), 25u);
  EXPECT_EQ(s.views.size(), 24u);
  int total = 0, in_band = 0;
  double smallest = 1e9, largest = 0;
  for (const View& v : s.views)
    for (const SceneMarker& m : s.objects[0].markers) {
      const Pose cam_from_marker =
          v.cam_from_world * s.objects[0].world_from_object * m.object_from_marker;
      std::array<Eigen::Vector2d, 4> px;
      for (int k = 0; k < 4; ++k) {
        ASSERT_TRUE(s.camera.Project(cam_from_marker * m.model.Corners()[k], &px[k]));
        EXPECT_TRUE(px[k].x() > 10 && px[k].y() > 10 && px[k].x() < s.camera.width() - 10 &&
                    px[k].y() < s.camera.height() - 10)
            << v.name << " marker " << m.model.id;
      }
      double side = 1e9;
      for (int k = 0; k < 4; ++k) side = std::min(side, (px[(k + 1) % 4] - px[k]).norm());
      smallest = std::min(smallest, side), largest = std::max(largest, side);
      ++total, in_band += side >= 8 && side < 24;
    }
  EXPECT_GT(smallest, 5.0);
  EXPECT_LT(largest, 30.0);
  EXPECT_GE(in_band, 0.75 * total) << in_band << " of " << total;
}

}  // namespace
}  // namespace svms

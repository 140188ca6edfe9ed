#include "svms/calib/board.h"

#include <gtest/gtest.h>

#include "svms/datasets/datasets.h"
#include "svms/marker/model_io.h"

namespace svms {
namespace {

TEST(Board, GridGeometryAndIds) {
  const BoardSpec spec{3, 4, 0.05, 0.01, 7};
  ASSERT_TRUE(spec.Validate().ok());
  const Layout layout = MakeBoardLayout(spec);
  ASSERT_EQ(layout.markers.size(), 12u);
  ASSERT_TRUE(layout.Validate().ok()) << layout.Validate().message();
  // Row 0 at the top, column 0 at the left, pitch 2 * size + gap, centred.
  EXPECT_EQ(layout.markers[0].marker.id, 7);
  EXPECT_NEAR(layout.markers[0].object_from_marker.tvec.x(), -1.5 * 0.11, 1e-12);
  EXPECT_NEAR(layout.markers[0].object_from_marker.tvec.y(), 0.11, 1e-12);
  EXPECT_EQ(layout.markers[11].marker.id, 18);
  EXPECT_NEAR(layout.markers[11].object_from_marker.tvec.x(), 1.5 * 0.11, 1e-12);
  EXPECT_NEAR(layout.markers[11].object_from_marker.tvec.y(), -0.11, 1e-12);
  for (const LayoutEntry& e : layout.markers) EXPECT_FALSE(e.marker.post.has_value());
  // Neighbouring rings are exactly `gap` apart.
  const double ring = 2 * layout.markers[0].marker.half_extent();
  EXPECT_NEAR(layout.markers[1].object_from_marker.tvec.x() -
                  layout.markers[0].object_from_marker.tvec.x() - ring,
              0.01, 1e-12);
}

TEST(Board, ReproducesTheCalibrationDatasetsBoard) {
  Dataset d;
  ASSERT_TRUE(MakeDataset("calibration", DatasetOptions{1, true}, &d).ok());
  std::string dataset_json;
  for (const auto& [name, text] : d.files)
    if (name == "board_layout.json") dataset_json = text;
  ASSERT_FALSE(dataset_json.empty());
  const Layout layout = MakeBoardLayout(BoardSpec{5, 6, 0.06, 0.015, 100});
  EXPECT_EQ(LayoutToJson(layout), dataset_json);
  // And it reads back with the standard reader.
  ModelFile f;
  ASSERT_TRUE(ParseModelJson(LayoutToJson(layout), "board", &f).ok());
  EXPECT_EQ(f.kind, ModelFile::Kind::kLayout);
  EXPECT_EQ(f.layout.markers.size(), 30u);
}

TEST(Board, RejectsBadSpecs) {
  EXPECT_NE(BoardSpec({0, 4, 0.05, 0.01, 0}).Validate().message().find("--rows"),
            std::string::npos);
  EXPECT_NE(BoardSpec({2, 4, -1, 0.01, 0}).Validate().message().find("--size"), std::string::npos);
  EXPECT_NE(BoardSpec({2, 4, 0.05, -0.01, 0}).Validate().message().find("--gap"),
            std::string::npos);
  EXPECT_NE(BoardSpec({2, 4, 0.05, 0.01, 32765}).Validate().message().find("--first-id"),
            std::string::npos);
}

}  // namespace
}  // namespace svms

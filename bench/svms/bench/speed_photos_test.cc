#include "svms/bench/speed_photos.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>

namespace svms {
namespace {

namespace fs = std::filesystem;

// A temporary root laid out like the packages' directories.
class SpeedPhotosTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ =
        fs::temp_directory_path() /
        ("svms_speed_photos_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
         "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(root_);
  }
  void TearDown() override { fs::remove_all(root_); }
  // A grey gradient JPEG of w x h at `path` (directories made).
  static void Jpeg(const fs::path& path, int w, int h) {
    fs::create_directories(path.parent_path());
    cv::Mat img(h, w, CV_8UC3);
    for (int y = 0; y < h; ++y)
      for (int x = 0; x < w; ++x) img.at<cv::Vec3b>(y, x) = cv::Vec3b(x % 256, y % 256, 128);
    ASSERT_TRUE(cv::imwrite(path.string(), img));
  }
  fs::path root_;
};

TEST_F(SpeedPhotosTest, FindsTheLargestWallpaperJpegAndLeavesOutLogosAndPngs) {
  const fs::path wall = root_ / "usr/share/wallpapers";
  Jpeg(wall / "Hills/contents/images/800x600.jpg", 80, 60);
  Jpeg(wall / "Hills/contents/images/1920x1080.jpg", 80, 60);
  fs::create_directories(wall / "Drawn/contents/images");
  std::ofstream(wall / "Drawn/contents/images/1920x1080.png") << "png";
  const fs::path data = root_ / "usr/share/doc/opencv-doc/examples/data";
  Jpeg(data / "fruits.jpg", 80, 60);
  Jpeg(data / "LinuxLogo.jpg", 80, 60);
  Jpeg(data / "aruco_board.jpg", 80, 60);
  const std::vector<PhotoSource> s = FindPhotoSources(root_.string());
  ASSERT_EQ(s.size(), 3u);
  EXPECT_EQ(s[0].package, "plasma-workspace-wallpapers");
  ASSERT_TRUE(s[0].present);
  ASSERT_EQ(s[0].files.size(), 1u);
  EXPECT_EQ(fs::path(s[0].files[0]).filename(), "1920x1080.jpg");
  EXPECT_FALSE(s[1].present);  // ukui-wallpapers: not laid out
  EXPECT_TRUE(s[1].files.empty());
  ASSERT_EQ(s[2].files.size(), 1u);
  EXPECT_EQ(fs::path(s[2].files[0]).filename(), "fruits.jpg");
}

TEST_F(SpeedPhotosTest, CropsAreSizedDeterministicAndOnceWhereThePhotoIsTheCropsSize) {
  Jpeg(root_ / "big.jpg", 1300, 1100);
  Jpeg(root_ / "exact.jpg", 640, 480);
  Jpeg(root_ / "small.jpg", 600, 400);
  const std::vector<cv::Size> sizes = {{1024, 1024}, {640, 480}};
  std::vector<PhotoCrop> a, b, c;
  ASSERT_TRUE(CutCrops((root_ / "big.jpg").string(), "opencv-doc", sizes, 3, 7, &a));
  ASSERT_TRUE(CutCrops((root_ / "big.jpg").string(), "opencv-doc", sizes, 3, 7, &b));
  ASSERT_EQ(a.size(), 6u);
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].name, b[k].name);
    EXPECT_EQ(a[k].x, b[k].x);
    EXPECT_EQ(a[k].y, b[k].y);
    EXPECT_EQ(a[k].image.type(), CV_8UC1);
    EXPECT_EQ(cv::norm(a[k].image, b[k].image, cv::NORM_INF), 0);
  }
  EXPECT_EQ(a[0].image.size(), cv::Size(1024, 1024));
  EXPECT_EQ(a[3].image.size(), cv::Size(640, 480));
  ASSERT_TRUE(CutCrops((root_ / "exact.jpg").string(), "opencv-doc", sizes, 3, 7, &c));
  EXPECT_EQ(c.size(), 1u);  // 640 x 480 once; too small for 1024 x 1024
  std::vector<PhotoCrop> none;
  ASSERT_TRUE(CutCrops((root_ / "small.jpg").string(), "opencv-doc", sizes, 3, 7, &none));
  EXPECT_TRUE(none.empty());
}

TEST_F(SpeedPhotosTest, AnUnreadableFileIsAnErrorThatNamesIt) {
  fs::create_directories(root_);
  std::ofstream(root_ / "broken.jpg") << "not a jpeg";
  std::vector<PhotoCrop> out;
  const Status s =
      CutCrops((root_ / "broken.jpg").string(), "opencv-doc", {{640, 480}}, 1, 1, &out);
  EXPECT_FALSE(s);
  EXPECT_NE(s.message().find("broken.jpg"), std::string::npos) << s.message();
}

}  // namespace
}  // namespace svms

#include "svms/camera/opencv_camera.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "svms/camera/camera_covariance.h"
#include "svms_testing/scratch_dir.h"

namespace svms {
namespace {

const svms_testing::ScratchDir& Dir() {
  static const svms_testing::ScratchDir dir("svms_opencv_camera_test");
  return dir;
}

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f << text;
  ASSERT_TRUE(f.good()) << path;
}

// A camera file as OpenCV's own writer makes it (cv::FileStorage, the field names of OpenCV's
// calibration sample).
std::string WriteWithOpenCv(const std::string& name, const cv::Matx33d& K,
                            const std::vector<double>& dist, int w, int h) {
  const std::string path = Dir().File(name);
  cv::FileStorage fs(path, cv::FileStorage::WRITE);
  fs << "image_width" << w << "image_height" << h << "camera_matrix" << cv::Mat(K);
  // No coefficients: an empty sequence (cv::FileStorage cannot write an empty matrix).
  if (dist.empty()) {
    fs << "distortion_coefficients" << "[" << "]";
  } else {
    fs << "distortion_coefficients" << cv::Mat(dist).t();
  }
  fs.release();
  return path;
}

const cv::Matx33d kK(1210.5, 0, 639.25, 0, 1205.75, 481.5, 0, 0, 1);

// Distortion of a real wide lens (rational model, thin prism) for each OpenCV length.
std::vector<double> Dist(int n) {
  const std::vector<double> all = {-0.28, 0.11, 1.2e-3, -7e-4, -0.021, 0.05,
                                   0.012, -0.004, 2e-3, -1e-4, 1.5e-3, 3e-5};
  return std::vector<double>(all.begin(), all.begin() + n);
}

void ExpectErrorWith(const Status& s, std::initializer_list<std::string> parts) {
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.message().find('\n'), std::string::npos) << s.message();
  for (const std::string& p : parts) {
    EXPECT_NE(s.message().find(p), std::string::npos) << "'" << p << "' in: " << s.message();
  }
}

// Known answer: the coefficients land in mrcal's intrinsics in OpenCV's order, bit for bit.
TEST(OpenCvCamera, ImportsOpenCvFileAsTheMatchingMrcalModel) {
  for (const int n : {4, 5, 8, 12}) {
    const std::string path = WriteWithOpenCv("cam" + std::to_string(n) + ".yml", kK, Dist(n),
                                             1280, 960);
    CameraModel cam;
    ASSERT_TRUE(ImportOpenCvCamera(path, 0, 0, &cam).ok());
    EXPECT_EQ(cam.lensmodel(), "LENSMODEL_OPENCV" + std::to_string(n));
    std::vector<double> expected = {kK(0, 0), kK(1, 1), kK(0, 2), kK(1, 2)};
    for (double d : Dist(n)) expected.push_back(d);
    EXPECT_EQ(cam.intrinsics(), expected);
    EXPECT_EQ(cam.width(), 1280);
    EXPECT_EQ(cam.height(), 960);
  }
}

// OpenCV's projection (cv::projectPoints) and the imported camera's (mrcal_project) agree on a
// grid of points over a 100-degree field, for every distortion length.
TEST(OpenCvCamera, ProjectsAsOpenCvDoes) {
  for (const int n : {0, 4, 5, 8, 12, 14}) {
    std::vector<double> dist = n == 14 ? Dist(12) : Dist(n);
    if (n == 14) dist.insert(dist.end(), {0.0, 0.0});
    const std::string path =
        WriteWithOpenCv("proj" + std::to_string(n) + ".yml", kK, dist, 1280, 960);
    CameraModel cam;
    ASSERT_TRUE(ImportOpenCvCamera(path, 0, 0, &cam).ok()) << n;
    std::vector<cv::Point3d> pts;
    for (double x = -1; x <= 1.0001; x += 0.125) {
      for (double y = -0.8; y <= 0.8001; y += 0.1) pts.emplace_back(x, y, 1.7);
    }
    std::vector<cv::Point2d> cv_px;
    cv::projectPoints(pts, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), kK, dist, cv_px);
    double worst = 0;
    for (size_t i = 0; i < pts.size(); ++i) {
      Eigen::Vector2d px;
      ASSERT_TRUE(cam.Project({pts[i].x, pts[i].y, pts[i].z}, &px));
      worst = std::max(worst, std::hypot(px.x() - cv_px[i].x, px.y() - cv_px[i].y));
    }
    EXPECT_LT(worst, 1e-9) << cam.lensmodel() << " (" << n << " coefficients)";
  }
}

// import -> export -> import gives the same model, and export -> import -> export the same
// text, in each of cv::FileStorage's formats.
TEST(OpenCvCamera, RoundTripsExactly) {
  for (const char* ext : {".yml", ".xml", ".json"}) {
    for (const int n : {0, 4, 5, 8, 12}) {
      const std::string in =
          WriteWithOpenCv("rt" + std::to_string(n) + ext, kK, Dist(n), 1280, 960);
      CameraModel a, b;
      const Status sa = ImportOpenCvCamera(in, 0, 0, &a);
      ASSERT_TRUE(sa.ok()) << sa.message();
      const std::string out = Dir().File("rt_out" + std::to_string(n) + ext);
      ASSERT_TRUE(WriteOpenCvCameraFile(out, a).ok());
      const Status sb = ImportOpenCvCamera(out, 0, 0, &b);
      ASSERT_TRUE(sb.ok()) << sb.message();
      EXPECT_EQ(a.lensmodel(), b.lensmodel());
      EXPECT_EQ(a.intrinsics(), b.intrinsics()) << ext << " " << n;
      EXPECT_EQ(a.width(), b.width());
      EXPECT_EQ(a.height(), b.height());
      std::string t1, t2;
      ASSERT_TRUE(OpenCvCameraText(out, a, &t1).ok());
      ASSERT_TRUE(OpenCvCameraText(out, b, &t2).ok());
      EXPECT_EQ(t1, t2);
      // ... and through the mrcal file as well.
      const std::string model = Dir().File("rt" + std::to_string(n) + ".cameramodel");
      ASSERT_TRUE(a.Write(model).ok());
      CameraModel c;
      ASSERT_TRUE(CameraModel::Read(model, &c).ok());
      EXPECT_EQ(a.intrinsics(), c.intrinsics());
    }
  }
}

// Values that need all 17 digits survive (OpenCV writes %.16e).
TEST(OpenCvCamera, KeepsEveryDigit) {
  CameraModel cam;
  ASSERT_TRUE(CameraModel::Create("LENSMODEL_OPENCV5",
                                  {1000.0 / 3, 2000.0 / 7, 319.5 + 1e-13, 239.5 - 1e-12, -1e-17,
                                   0.1 + 0.2, 1.0 / 3e5, -2.0 / 3e7, 5e-300},
                                  640, 480, &cam)
                  .ok());
  const std::string path = Dir().File("digits.yml");
  ASSERT_TRUE(WriteOpenCvCameraFile(path, cam).ok());
  CameraModel back;
  ASSERT_TRUE(ImportOpenCvCamera(path, 0, 0, &back).ok());
  EXPECT_EQ(back.intrinsics(), cam.intrinsics());
  // cv::FileStorage reads the file it wrote to the same values.
  cv::FileStorage fs(path, cv::FileStorage::READ);
  cv::Mat K;
  fs["camera_matrix"] >> K;
  EXPECT_EQ(K.at<double>(0, 0), 1000.0 / 3);
  EXPECT_EQ(static_cast<int>(fs["image_width"]), 640);
}

// No distortion is LENSMODEL_PINHOLE; exported as OpenCV's five zeros.
TEST(OpenCvCamera, ZeroDistortionIsPinhole) {
  for (const int n : {0, 5, 8}) {
    const std::string path = WriteWithOpenCv("zero" + std::to_string(n) + ".yml", kK,
                                             std::vector<double>(n, 0.0), 640, 480);
    CameraModel cam;
    ASSERT_TRUE(ImportOpenCvCamera(path, 0, 0, &cam).ok());
    EXPECT_EQ(cam.lensmodel(), "LENSMODEL_PINHOLE");
    EXPECT_EQ(cam.intrinsics(), (std::vector<double>{kK(0, 0), kK(1, 1), kK(0, 2), kK(1, 2)}));
    OpenCvCamera cv_cam;
    ASSERT_TRUE(OpenCvFromCamera(cam, &cv_cam).ok());
    EXPECT_EQ(cv_cam.dist, std::vector<double>(5, 0.0));
  }
}

// Field spellings: cameraMatrix / distCoeffs / imageSize as cv::Size writes it, K / D with
// plain sequences, nested rows, XML.
TEST(OpenCvCamera, ReadsOtherSpellings) {
  const std::string a = Dir().File("spell_a.yml");
  WriteText(a,
            "%YAML:1.0\n---\nimageSize: [ 640, 480 ]\ncameraMatrix: [[500, 0, 320], [0, 510, "
            "240], [0, 0, 1]]\ndistCoeffs: [ -0.1, 0.01, 0, 0, 0.002 ]\n");
  const std::string b = Dir().File("spell_b.yaml");
  WriteText(b,
            "%YAML 1.2\n---\nK: [500, 0, 320, 0, 510, 240, 0, 0, 1]\nD: [-0.1, 0.01, 0, 0, "
            "0.002]\nimage_size: [640, 480]\n");
  const std::string c = Dir().File("spell_c.xml");
  WriteText(c,
            "<?xml version=\"1.0\"?>\n<opencv_storage>\n<image_width>640</image_width>"
            "<image_height>480</image_height>\n<camera_matrix type_id=\"opencv-matrix\"><rows>3"
            "</rows><cols>3</cols><dt>d</dt><data>500 0 320 0 510 240 0 0 1</data>"
            "</camera_matrix>\n<dist_coeffs type_id=\"opencv-matrix\"><rows>5</rows><cols>1"
            "</cols><dt>f</dt><data>-0.125 0.0625 0 0 0.5</data></dist_coeffs>\n"
            "</opencv_storage>\n");
  for (const std::string& path : {a, b, c}) {
    CameraModel cam;
    const Status s = ImportOpenCvCamera(path, 0, 0, &cam);
    ASSERT_TRUE(s.ok()) << s.message();
    EXPECT_EQ(cam.lensmodel(), "LENSMODEL_OPENCV5");
    EXPECT_EQ(cam.intrinsics()[1], 510);
    EXPECT_EQ(cam.width(), 640);
    EXPECT_EQ(cam.height(), 480);
  }
  CameraModel cam;
  ASSERT_TRUE(ImportOpenCvCamera(c, 0, 0, &cam).ok());
  EXPECT_EQ(cam.intrinsics(),
            (std::vector<double>{500, 510, 320, 240, -0.125, 0.0625, 0, 0, 0.5}));
}

// ROS's camera_calibration_parsers YAML: no %YAML:1.0 line, {rows, cols, data} matrices.
constexpr char kRosYaml[] = R"(image_width: 640
image_height: 480
camera_name: narrow_stereo
camera_matrix:
  rows: 3
  cols: 3
  data: [500.25, 0, 320.5, 0, 501.75, 240.25, 0, 0, 1]
distortion_model: %s
distortion_coefficients:
  rows: 1
  cols: %d
  data: [%s]
rectification_matrix:
  rows: 3
  cols: 3
  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]
)";

std::string RosYaml(const std::string& name, const char* model, int n, const char* data) {
  char buf[2048];
  std::snprintf(buf, sizeof buf, kRosYaml, model, n, data);
  const std::string path = Dir().File(name);
  WriteText(path, buf);
  return path;
}

TEST(OpenCvCamera, ReadsRosCalibrationYaml) {
  CameraModel cam;
  const std::string path =
      RosYaml("ros.yaml", "plumb_bob", 5, "-0.25, 0.125, 0.001, -0.002, 0.0");
  const Status s = ImportOpenCvCamera(path, 0, 0, &cam);
  ASSERT_TRUE(s.ok()) << s.message();
  EXPECT_EQ(cam.lensmodel(), "LENSMODEL_OPENCV5");
  EXPECT_EQ(cam.intrinsics(),
            (std::vector<double>{500.25, 501.75, 320.5, 240.25, -0.25, 0.125, 0.001, -0.002, 0}));
}

TEST(OpenCvCamera, RefusesFisheyeNamingKannalaBrandt) {
  CameraModel cam;
  const std::string path = RosYaml("fish.yaml", "equidistant", 4, "0.1, -0.01, 0.002, -1e-4");
  ExpectErrorWith(ImportOpenCvCamera(path, 0, 0, &cam),
                  {path + ": distortion_model", "Kannala-Brandt", "mrcal 2.2"});
}

TEST(OpenCvCamera, MissingImageSizeNamesFieldAndOption) {
  const std::string path = Dir().File("nosize.yml");
  WriteText(path, "%YAML:1.0\n---\nK: [500, 0, 320, 0, 510, 240, 0, 0, 1]\nD: [0.1, 0, 0, 0]\n");
  CameraModel cam;
  ExpectErrorWith(ImportOpenCvCamera(path, 0, 0, &cam),
                  {path + ": ", "image_width", "image_height", "--image-size WxH"});
  ASSERT_TRUE(ImportOpenCvCamera(path, 640, 480, &cam).ok());
  EXPECT_EQ(cam.width(), 640);
  EXPECT_EQ(cam.lensmodel(), "LENSMODEL_OPENCV4");
  // A size that disagrees with the file's is refused.
  const std::string sized = WriteWithOpenCv("sized.yml", kK, Dist(5), 1280, 960);
  ExpectErrorWith(ImportOpenCvCamera(sized, 640, 480, &cam), {sized + ": ", "1280x960", "640x480"});
}

TEST(OpenCvCamera, RefusesWhatMrcalCannotRepresent) {
  CameraModel cam;
  cv::Matx33d skewed = kK;
  skewed(0, 1) = 0.5;
  const std::string skew = WriteWithOpenCv("skew.yml", skewed, Dist(5), 640, 480);
  ExpectErrorWith(ImportOpenCvCamera(skew, 0, 0, &cam), {skew + ": camera_matrix", "skew"});

  std::vector<double> tilt = Dist(12);
  tilt.insert(tilt.end(), {0.01, 0.0});
  const std::string tilted = WriteWithOpenCv("tilt.yml", kK, tilt, 640, 480);
  ExpectErrorWith(ImportOpenCvCamera(tilted, 0, 0, &cam), {tilted + ": ", "tilted", "tx"});

  const std::string six = WriteWithOpenCv("six.yml", kK, Dist(6), 640, 480);
  ExpectErrorWith(ImportOpenCvCamera(six, 0, 0, &cam),
                  {six + ": distortion_coefficients", "0, 4, 5, 8, 12 or 14", "got 6"});

  const std::string nok = Dir().File("nok.yml");
  WriteText(nok, "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\nD: [0, 0, 0, 0]\n");
  ExpectErrorWith(ImportOpenCvCamera(nok, 0, 0, &cam),
                  {nok + ": no camera matrix", "camera_matrix", "cameraMatrix", "K"});

  const std::string garbage = Dir().File("garbage.yml");
  WriteText(garbage, "%YAML:1.0\n---\n[[[ : this is not yaml\n");
  ExpectErrorWith(ImportOpenCvCamera(garbage, 0, 0, &cam),
                  {garbage + ": OpenCV cannot parse the file (line 3: "});
  // Without the directive (supplied, one line) the line is still the file's own.
  const std::string garbage_ros = Dir().File("garbage_ros.yaml");
  WriteText(garbage_ros, "image_width: 640\nK: [1, 2\n");
  ExpectErrorWith(ImportOpenCvCamera(garbage_ros, 0, 0, &cam),
                  {garbage_ros + ": OpenCV cannot parse the file (line "});

  const std::string halfsize = Dir().File("halfsize.yml");
  WriteText(halfsize, "%YAML:1.0\n---\nimage_width: 640\nK: [500, 0, 320, 0, 510, 240, 0, 0, 1]\n");
  ExpectErrorWith(ImportOpenCvCamera(halfsize, 0, 0, &cam), {halfsize + ": image_height"});

  const std::string fraction = Dir().File("fraction.yml");
  WriteText(fraction,
            "%YAML:1.0\n---\nimage_width: 640.5\nimage_height: 480\nK: [500, 0, 320, 0, 510, "
            "240, 0, 0, 1]\n");
  ExpectErrorWith(ImportOpenCvCamera(fraction, 0, 0, &cam),
                  {fraction + ": image_width", "whole number"});

  const std::string missing = Dir().File("missing.yml");
  ExpectErrorWith(ImportOpenCvCamera(missing, 0, 0, &cam), {missing});
}

TEST(OpenCvCamera, ExportRefusesModelsOpenCvLacks) {
  CameraModel cam;
  ASSERT_TRUE(CameraModel::Create("LENSMODEL_STEREOGRAPHIC", {500, 500, 320, 240}, 640, 480, &cam)
                  .ok());
  std::string text;
  ExpectErrorWith(OpenCvCameraText("x.yml", cam, &text),
                  {"x.yml: lensmodel: LENSMODEL_STEREOGRAPHIC", "no OpenCV equivalent"});
}

// Other commands read cameras with CameraModel::Read: an OpenCV file is refused with a pointer
// to `svms camera import`, whatever its name.
TEST(OpenCvCamera, CameraModelReadPointsAtImport) {
  const std::string yml = WriteWithOpenCv("cmd.yml", kK, Dist(5), 640, 480);
  const std::string renamed = Dir().File("cmd_yaml.cameramodel");
  std::ifstream in(yml);
  WriteText(renamed, std::string(std::istreambuf_iterator<char>(in), {}));
  const std::string ros = RosYaml("cmd_ros.yaml", "plumb_bob", 5, "0, 0, 0, 0, 0");
  const std::string xml = Dir().File("cmd.xml");
  {
    CameraModel cam;
    ASSERT_TRUE(ImportOpenCvCamera(yml, 0, 0, &cam).ok());
    ASSERT_TRUE(WriteOpenCvCameraFile(xml, cam).ok());
  }
  for (const std::string& path : {yml, renamed, ros, xml}) {
    CameraModel cam;
    ExpectErrorWith(CameraModel::Read(path, &cam),
                    {path + ": an OpenCV camera file", "svms camera import " + path});
    ExpectErrorWith(ReadCameraWithSidecar(path, &cam), {"svms camera import"});
  }
  // An mrcal model named .yml is still an mrcal model.
  CameraModel pin = CameraModel::Pinhole(500, 640, 480), back;
  const std::string odd = Dir().File("mrcal.yml");
  ASSERT_TRUE(pin.Write(odd).ok());
  EXPECT_TRUE(CameraModel::Read(odd, &back).ok());
}

}  // namespace
}  // namespace svms

#include "svms/camera/camera.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <limits>
#include <sstream>

#include "svms_testing/scratch_dir.h"

namespace svms {
namespace {

namespace fs = std::filesystem;

constexpr char kPython[] = "/usr/bin/python3";  // the Debian python that has python3-mrcal

// A per-process scratch directory, removed when the test program ends.
const fs::path& TempDir() {
  static const svms_testing::ScratchDir dir("svms_camera_test");
  return dir.path();
}

std::string TempPath(const std::string& name) { return (TempDir() / name).string(); }

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary | std::ios::trunc);
  f << text;
  ASSERT_TRUE(f.good()) << path;
}

// Runs a shell command; returns its exit status and puts stdout (and stderr) in *output.
int RunCommand(const std::string& command, std::string* output) {
  output->clear();
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return -1;
  char buf[4096];
  std::size_t n;
  while ((n = std::fread(buf, 1, sizeof(buf), pipe)) > 0) output->append(buf, n);
  const int status = ::pclose(pipe);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

bool PythonMrcalAvailable() {
  static const bool available = [] {
    std::string out;
    return RunCommand(std::string(kPython) + " -c 'import mrcal'", &out) == 0;
  }();
  return available;
}

std::string Digits17(double v) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.17g", v);
  return buf;
}

std::vector<double> SplitNumbers(const std::string& line) {
  std::vector<double> v;
  std::istringstream in(line);
  std::string tok;
  while (in >> tok) v.push_back(std::strtod(tok.c_str(), nullptr));
  return v;
}

// Failure whose message is one line, starts with `prefix`, and contains every one of `parts`.
void ExpectError(const Status& s, const std::string& prefix,
                 std::initializer_list<std::string> parts) {
  ASSERT_FALSE(s.ok()) << "expected an error starting with " << prefix;
  EXPECT_EQ(s.message().find('\n'), std::string::npos) << "one line: " << s.message();
  EXPECT_EQ(s.message().rfind(prefix, 0), 0u) << s.message();
  for (const std::string& p : parts) {
    EXPECT_NE(s.message().find(p), std::string::npos) << "'" << p << "' in: " << s.message();
  }
}

CameraModel MustCreate(const std::string& lensmodel, const std::vector<double>& intrinsics,
                       int width, int height) {
  CameraModel c;
  const Status s = CameraModel::Create(lensmodel, intrinsics, width, height, &c);
  EXPECT_TRUE(s.ok()) << s.message();
  return c;
}

CameraModel OpenCv4() {
  return MustCreate("LENSMODEL_OPENCV4", {900, 905, 511.5, 383.5, -0.3, 0.1, 1e-3, -2e-3}, 1024,
                    768);
}

// A wide-angle lens with strong barrel distortion (k1 = -0.3) and every OpenCV8 term non-zero.
CameraModel OpenCv8() {
  return MustCreate("LENSMODEL_OPENCV8",
                    {900, 905, 511.5, 383.5, -0.3, 0.1, 1e-3, -2e-3, 0.01, 0.05, -0.01, 0.002},
                    1024, 768);
}

// A spline of 16 x 12 control points over a 100 degree field; the image lies inside its domain.
// Every control point is non-zero (a smooth ripple of up to 1 % of the normalized coordinate).
std::vector<double> SplinedIntrinsics() {
  std::vector<double> v = {600, 602, 511.5, 383.5};
  const int nx = 16, ny = 12;
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      v.push_back(0.01 * std::sin(0.5 * i + 0.2 * j));   // delta u_x
      v.push_back(0.008 * std::cos(0.3 * i - 0.4 * j));  // delta u_y
    }
  }
  return v;
}
std::string SplinedName() {
  return "LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=12_fov_x_deg=100";
}
CameraModel Splined() { return MustCreate(SplinedName(), SplinedIntrinsics(), 1024, 768); }

// Every pixel of a 13 x 11 grid over the whole image (corners included) unprojects to a unit
// direction that projects back onto it; UnprojectMany agrees with Unproject.
void ExpectRoundTrip(const CameraModel& cam) {
  SCOPED_TRACE(cam.Summary());
  std::vector<Eigen::Vector2d> pixels;
  for (int j = 0; j <= 10; ++j) {
    for (int i = 0; i <= 12; ++i) {
      pixels.emplace_back((cam.width() - 1) * i / 12.0, (cam.height() - 1) * j / 10.0);
    }
  }
  std::vector<Eigen::Vector3d> many;
  ASSERT_TRUE(cam.UnprojectMany(pixels, &many));
  ASSERT_EQ(many.size(), pixels.size());
  double worst = 0;
  for (std::size_t k = 0; k < pixels.size(); ++k) {
    Eigen::Vector3d d;
    ASSERT_TRUE(cam.Unproject(pixels[k], &d)) << pixels[k].transpose();
    EXPECT_NEAR(d.norm(), 1.0, 1e-12);
    EXPECT_LT((d - many[k]).norm(), 1e-12) << pixels[k].transpose();
    Eigen::Vector2d back;
    ASSERT_TRUE(cam.Project(d, &back)) << pixels[k].transpose();
    worst = std::max(worst, (back - pixels[k]).norm());
    EXPECT_LT((back - pixels[k]).norm(), 1e-6) << pixels[k].transpose();
    // The depth along the ray does not matter.
    ASSERT_TRUE(cam.Project(3.7 * d, &back));
    EXPECT_LT((back - pixels[k]).norm(), 1e-6);
  }
  ::testing::Test::RecordProperty("worst_round_trip_px", std::to_string(worst));
}

// |analytic - numeric| <= 1e-5 max(|analytic|, 1): relative 1e-5, absolute for small entries.
void ExpectClose(double analytic, double numeric, const std::string& what) {
  EXPECT_NEAR(analytic, numeric, 1e-5 * std::max(std::abs(analytic), 1.0)) << what;
}

// Both Jacobians against central finite differences of Project.
void ExpectJacobiansMatch(const CameraModel& cam) {
  SCOPED_TRACE(cam.Summary());
  const int n = static_cast<int>(cam.intrinsics().size());
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(0.3, -0.2, 1.5), Eigen::Vector3d(-0.5, 0.35, 2),
                                   Eigen::Vector3d(0.05, 0.02, 3)}) {
    Eigen::Vector2d px;
    Eigen::Matrix<double, 2, 3> dp;
    Eigen::Matrix<double, 2, Eigen::Dynamic> di;
    ASSERT_TRUE(cam.Project(p, &px, &dp, &di));
    ASSERT_EQ(di.cols(), n);
    for (int k = 0; k < 3; ++k) {
      const double h = 1e-6 * p.norm();
      Eigen::Vector2d plus, minus;
      ASSERT_TRUE(cam.Project(p + h * Eigen::Vector3d::Unit(k), &plus));
      ASSERT_TRUE(cam.Project(p - h * Eigen::Vector3d::Unit(k), &minus));
      const Eigen::Vector2d fd = (plus - minus) / (2 * h);
      for (int r = 0; r < 2; ++r)
        ExpectClose(dp(r, k), fd(r), "dpx_dp " + std::to_string(r) + "," + std::to_string(k));
    }
    int nonzero = 0;
    for (int k = 0; k < n; ++k) {
      std::vector<double> plus = cam.intrinsics(), minus = cam.intrinsics();
      const double h = 1e-6 * std::max(1.0, std::abs(plus[k]));
      plus[k] += h;
      minus[k] -= h;
      CameraModel cp, cm;
      ASSERT_TRUE(CameraModel::Create(cam.lensmodel(), plus, cam.width(), cam.height(), &cp).ok());
      ASSERT_TRUE(CameraModel::Create(cam.lensmodel(), minus, cam.width(), cam.height(), &cm).ok());
      Eigen::Vector2d qp, qm;
      ASSERT_TRUE(cp.Project(p, &qp));
      ASSERT_TRUE(cm.Project(p, &qm));
      const Eigen::Vector2d fd = (qp - qm) / (2 * h);
      for (int r = 0; r < 2; ++r) {
        ExpectClose(di(r, k), fd(r),
                    "dpx_dintrinsics " + std::to_string(r) + "," + std::to_string(k));
        nonzero += di(r, k) != 0;
      }
    }
    EXPECT_GT(nonzero, 0);
  }
}

TEST(CameraModel, UnusableModelsSayWhy) {
  EXPECT_EQ(CameraModel::Pinhole(1000, 1024, 768).UnusableReason(), "");
  EXPECT_EQ(OpenCv8().UnusableReason(), "");
  EXPECT_EQ(Splined().UnusableReason(), "");
  EXPECT_EQ(CameraModel().UnusableReason(), "an empty camera model");
  CameraModel c;
  ASSERT_TRUE(
      CameraModel::Create("LENSMODEL_PINHOLE", {1e-300, 1000, 511.5, 383.5}, 1024, 768, &c).ok());
  EXPECT_EQ(
      c.UnusableReason(),
      "intrinsics[0]: fx 1e-300 pixels is not a focal length a lens has; expected 1 to 1e+08");
  ASSERT_TRUE(
      CameraModel::Create("LENSMODEL_PINHOLE", {1000, 1e300, 511.5, 383.5}, 1024, 768, &c).ok());
  EXPECT_NE(c.UnusableReason().find("intrinsics[1]: fy 1e+300 pixels"), std::string::npos);
  ASSERT_TRUE(CameraModel::Create("LENSMODEL_CAHVORE_linearity=0.00",
                                  {1000, 1000, 511.5, 383.5, 0, 0, 0, 0, 0, 0, 0, 0}, 1024, 768, &c)
                  .ok());
  EXPECT_NE(c.UnusableReason().find("mrcal 2.2 can neither unproject this model"),
            std::string::npos);
  int n = 0;
  bool gradients = true;
  EXPECT_TRUE(CameraModel::CheckLensModelName("LENSMODEL_OPENCV8", &n, &gradients).ok());
  EXPECT_EQ(n, 12);
  EXPECT_TRUE(gradients);
  EXPECT_TRUE(
      CameraModel::CheckLensModelName("LENSMODEL_CAHVORE_linearity=0.00", &n, &gradients).ok());
  EXPECT_FALSE(gradients);
  EXPECT_EQ(CameraModel::CheckLensModelName("LENSMODEL_FOO")
                .message()
                .rfind("lensmodel: unknown lens model 'LENSMODEL_FOO'", 0),
            0u);
}

TEST(CameraModel, PinholeKnownAnswer) {
  const CameraModel cam = CameraModel::Pinhole(1000, 1024, 768);
  EXPECT_EQ(cam.lensmodel(), "LENSMODEL_PINHOLE");
  EXPECT_EQ(cam.intrinsics(), (std::vector<double>{1000, 1000, 511.5, 383.5}));
  EXPECT_EQ(cam.width(), 1024);
  EXPECT_EQ(cam.height(), 768);
  EXPECT_EQ(cam.Summary(), "LENSMODEL_PINHOLE 1024x768, fx 1000.0 fy 1000.0");
  EXPECT_EQ(cam.cam_from_ref().rvec, Eigen::Vector3d::Zero());
  EXPECT_EQ(cam.cam_from_ref().tvec, Eigen::Vector3d::Zero());
  Eigen::Vector2d px;
  Eigen::Matrix<double, 2, 3> dp;
  ASSERT_TRUE(cam.Project(Eigen::Vector3d(0.1, 0.2, 2), &px, &dp));
  EXPECT_NEAR(px.x(), 511.5 + 50, 1e-9);
  EXPECT_NEAR(px.y(), 383.5 + 100, 1e-9);
  // d(u)/d(x) = f / z, d(u)/d(z) = -f x / z^2.
  EXPECT_NEAR(dp(0, 0), 500, 1e-9);
  EXPECT_NEAR(dp(0, 1), 0, 1e-9);
  EXPECT_NEAR(dp(0, 2), -25, 1e-9);
  EXPECT_NEAR(dp(1, 2), -50, 1e-9);
  Eigen::Vector3d d;
  ASSERT_TRUE(cam.Unproject(Eigen::Vector2d(561.5, 483.5), &d));
  EXPECT_LT((d - Eigen::Vector3d(0.1, 0.2, 2).normalized()).norm(), 1e-12);
}

TEST(CameraModel, PinholeCannotProjectBehindTheCamera) {
  const CameraModel cam = CameraModel::Pinhole(1000, 1024, 768);
  const Eigen::Vector2d sentinel(-7, -7);
  Eigen::Vector2d px = sentinel;
  EXPECT_FALSE(cam.Project(Eigen::Vector3d(0.1, 0.2, -2), &px));
  EXPECT_FALSE(cam.Project(Eigen::Vector3d(0.1, 0.2, 0), &px));
  EXPECT_FALSE(cam.Project(Eigen::Vector3d(std::nan(""), 0.2, 1), &px));
  EXPECT_FALSE(OpenCv8().Project(Eigen::Vector3d(0.1, 0.2, -2), &px));
  EXPECT_EQ(px, sentinel);  // untouched on failure
}

TEST(CameraModel, EmptyModelDoesNothing) {
  const CameraModel cam;
  EXPECT_TRUE(cam.empty());
  EXPECT_EQ(cam.Summary(), "(empty camera model)");
  Eigen::Vector2d px;
  Eigen::Vector3d d;
  std::vector<Eigen::Vector3d> many;
  EXPECT_FALSE(cam.Project(Eigen::Vector3d(0, 0, 1), &px));
  EXPECT_FALSE(cam.Unproject(Eigen::Vector2d(1, 1), &d));
  EXPECT_FALSE(cam.UnprojectMany({Eigen::Vector2d(1, 1)}, &many));
  ExpectError(cam.Write(TempPath("empty.cameramodel")), TempPath("empty.cameramodel") + ": ",
              {"empty CameraModel"});
}

TEST(CameraModel, RoundTripPinhole) { ExpectRoundTrip(CameraModel::Pinhole(1000, 1024, 768)); }
TEST(CameraModel, RoundTripOpenCv8) { ExpectRoundTrip(OpenCv8()); }
TEST(CameraModel, RoundTripSplined) { ExpectRoundTrip(Splined()); }

TEST(CameraModel, UnprojectManyMarksFailures) {
  const CameraModel cam = OpenCv8();
  std::vector<Eigen::Vector3d> d;
  EXPECT_TRUE(cam.UnprojectMany({}, &d));
  EXPECT_TRUE(d.empty());
  EXPECT_FALSE(
      cam.UnprojectMany({Eigen::Vector2d(100, 100), Eigen::Vector2d(std::nan(""), 3)}, &d));
  ASSERT_EQ(d.size(), 2u);
  EXPECT_NEAR(d[0].norm(), 1.0, 1e-12);
  EXPECT_TRUE(d[1].hasNaN());
}

TEST(CameraModel, JacobiansPinhole) { ExpectJacobiansMatch(CameraModel::Pinhole(1000, 1024, 768)); }
TEST(CameraModel, JacobiansOpenCv4) { ExpectJacobiansMatch(OpenCv4()); }
TEST(CameraModel, JacobiansOpenCv8) { ExpectJacobiansMatch(OpenCv8()); }
TEST(CameraModel, JacobiansSplined) { ExpectJacobiansMatch(Splined()); }

TEST(CameraModel, SplinedIntrinsicsJacobianIsDenseAndMostlyZero) {
  // mrcal 2.2 returns the splined gradient densely: 2 x (4 + 2 * 16 * 12) with, per row, fx and
  // cx (or fy and cy) and the 4 x 4 control points around the point non-zero.
  const CameraModel cam = Splined();
  Eigen::Vector2d px;
  Eigen::Matrix<double, 2, Eigen::Dynamic> di;
  ASSERT_TRUE(cam.Project(Eigen::Vector3d(0.3, -0.2, 1.5), &px, nullptr, &di));
  ASSERT_EQ(di.cols(), 4 + 2 * 16 * 12);
  EXPECT_EQ((di.array() != 0).count(), 2 * (2 + 16));
}

TEST(CameraModel, CahvoreProjectsOnlyWithoutGradients) {
  // CAHVORE with linearity 1 and no distortion is a pinhole camera.
  const CameraModel cam = MustCreate("LENSMODEL_CAHVORE_linearity=1.00",
                                     {1000, 1000, 511.5, 383.5, 0, 0, 0, 0, 0, 0, 0, 0}, 1024, 768);
  Eigen::Vector2d px;
  ASSERT_TRUE(cam.Project(Eigen::Vector3d(0.1, 0.2, 2), &px));
  EXPECT_NEAR(px.x(), 561.5, 1e-6);
  EXPECT_NEAR(px.y(), 483.5, 1e-6);
  Eigen::Matrix<double, 2, 3> dp;
  Eigen::Matrix<double, 2, Eigen::Dynamic> di;
  EXPECT_FALSE(cam.Project(Eigen::Vector3d(0.1, 0.2, 2), &px, &dp));
  EXPECT_FALSE(cam.Project(Eigen::Vector3d(0.1, 0.2, 2), &px, nullptr, &di));
  Eigen::Vector3d d;
  EXPECT_FALSE(cam.Unproject(Eigen::Vector2d(500, 400), &d));
  // The linearity is a number, not a fixed spelling.
  CameraModel same;
  ASSERT_TRUE(
      CameraModel::Create("LENSMODEL_CAHVORE_linearity=1", cam.intrinsics(), 1024, 768, &same)
          .ok());
  Eigen::Vector2d px2;
  ASSERT_TRUE(same.Project(Eigen::Vector3d(0.1, 0.2, 2), &px2));
  EXPECT_EQ(px2, px);
}

TEST(CameraModel, Summary) {
  EXPECT_EQ(OpenCv8().Summary(), "LENSMODEL_OPENCV8 1024x768, fx 900.0 fy 905.0");
  EXPECT_EQ(Splined().Summary(), SplinedName() + " 1024x768, fx 600.0 fy 602.0");
}

// ----------------------------------------------------------------------------------------------
// Files

void ExpectSameModel(const CameraModel& a, const CameraModel& b) {
  EXPECT_EQ(a.lensmodel(), b.lensmodel());
  EXPECT_EQ(a.intrinsics(), b.intrinsics());  // bit-exact
  EXPECT_EQ(a.width(), b.width());
  EXPECT_EQ(a.height(), b.height());
  EXPECT_EQ(a.cam_from_ref().rvec, b.cam_from_ref().rvec);
  EXPECT_EQ(a.cam_from_ref().tvec, b.cam_from_ref().tvec);
}

// Awkward values: many digits, tiny terms, a negative zero.
CameraModel AwkwardOpenCv8() {
  CameraModel cam = MustCreate("LENSMODEL_OPENCV8",
                               {900.1234567890123, 2700.0 / 7, 511.5 + 1e-9, 383.25, -0.3 + 1e-12,
                                0.1, 1e-7, -2.5e-9, 0.01, -0.0, 1.0 / 3, 1e-300},
                               1280, 960);
  cam.set_cam_from_ref(
      Pose{Eigen::Vector3d(0.1, -0.2, 0.3 + 1e-15), Eigen::Vector3d(1.5, -2.25, 1.0 / 3)});
  return cam;
}

TEST(CameraModelIo, WriteThenReadIsExact) {
  for (const CameraModel& cam :
       {AwkwardOpenCv8(), Splined(), CameraModel::Pinhole(800, 640, 480)}) {
    SCOPED_TRACE(cam.lensmodel());
    const std::string path = TempPath("exact.cameramodel");
    ASSERT_TRUE(cam.Write(path).ok());
    CameraModel back;
    const Status s = CameraModel::Read(path, &back);
    ASSERT_TRUE(s.ok()) << s.message();
    ExpectSameModel(back, cam);
  }
}

// What mrcal's Python reader makes of a file: lens model, intrinsics, rt_cam_ref, size.
struct PythonView {
  std::string lensmodel;
  std::vector<double> intrinsics, extrinsics, imagersize;
};

PythonView ReadWithPython(const std::string& path) {
  const std::string script = TempPath("read.py");
  // mrcal 2.2's cameramodel has no lensmodel() method: intrinsics() returns (lensmodel, values).
  WriteText(script,
            "import sys, mrcal\n"
            "m = mrcal.cameramodel(sys.argv[1])\n"
            "lensmodel, intrinsics = m.intrinsics()\n"
            "print(lensmodel)\n"
            "print(' '.join(repr(float(x)) for x in intrinsics))\n"
            "print(' '.join(repr(float(x)) for x in m.extrinsics_rt_fromref()))\n"
            "print(' '.join(str(int(x)) for x in m.imagersize()))\n");
  std::string out;
  const int rc = RunCommand(std::string(kPython) + " '" + script + "' '" + path + "'", &out);
  EXPECT_EQ(rc, 0) << out;
  PythonView v;
  std::istringstream in(out);
  std::string line;
  std::getline(in, v.lensmodel);
  std::getline(in, line);
  v.intrinsics = SplitNumbers(line);
  std::getline(in, line);
  v.extrinsics = SplitNumbers(line);
  std::getline(in, line);
  v.imagersize = SplitNumbers(line);
  return v;
}

TEST(CameraModelIo, MrcalPythonReadsOurFiles) {
  if (!PythonMrcalAvailable()) GTEST_SKIP() << kPython << " cannot import mrcal (python3-mrcal)";
  for (const CameraModel& cam : {AwkwardOpenCv8(), Splined()}) {
    SCOPED_TRACE(cam.lensmodel());
    const std::string path = TempPath("for_python.cameramodel");
    ASSERT_TRUE(cam.Write(path).ok());
    const PythonView v = ReadWithPython(path);
    EXPECT_EQ(v.lensmodel, cam.lensmodel());
    EXPECT_EQ(v.intrinsics, cam.intrinsics());  // repr() round-trips: bit-exact
    const Pose& pose = cam.cam_from_ref();
    EXPECT_EQ(v.extrinsics, (std::vector<double>{pose.rvec.x(), pose.rvec.y(), pose.rvec.z(),
                                                 pose.tvec.x(), pose.tvec.y(), pose.tvec.z()}));
    EXPECT_EQ(v.imagersize, (std::vector<double>{double(cam.width()), double(cam.height())}));
  }
}

TEST(CameraModelIo, ReadsFilesWrittenByMrcalPython) {
  if (!PythonMrcalAvailable()) GTEST_SKIP() << kPython << " cannot import mrcal (python3-mrcal)";
  const std::string script = TempPath("write.py");
  // A note (comment lines) and a valid-intrinsics region, as mrcal's tools write them.
  WriteText(script,
            "import sys, numpy as np, mrcal\n"
            "intrinsics = np.array([float(x) for x in sys.argv[3].split(',')])\n"
            "rt = np.array([float(x) for x in sys.argv[4].split(',')])\n"
            "w, h = int(sys.argv[5]), int(sys.argv[6])\n"
            "region = np.array([[0, 0], [w - 1, 0], [w - 1, h - 1], [0, h - 1], [0, 0]], "
            "dtype=float)\n"
            "m = mrcal.cameramodel(intrinsics=(sys.argv[2], intrinsics), imagersize=(w, h),\n"
            "                      extrinsics_rt_fromref=rt, valid_intrinsics_region=region)\n"
            "m.write(sys.argv[1], note='written by camera_test\\nwith mrcal.cameramodel.write')\n");
  for (const CameraModel& cam : {AwkwardOpenCv8(), Splined()}) {
    SCOPED_TRACE(cam.lensmodel());
    const std::string path = TempPath("from_python.cameramodel");
    std::string intrinsics, rt;
    for (double x : cam.intrinsics()) intrinsics += (intrinsics.empty() ? "" : ",") + Digits17(x);
    const Pose& pose = cam.cam_from_ref();
    for (double x : {pose.rvec.x(), pose.rvec.y(), pose.rvec.z(), pose.tvec.x(), pose.tvec.y(),
                     pose.tvec.z()}) {
      rt += (rt.empty() ? "" : ",") + Digits17(x);
    }
    std::string out;
    ASSERT_EQ(RunCommand(std::string(kPython) + " '" + script + "' '" + path + "' '" +
                             cam.lensmodel() + "' '" + intrinsics + "' '" + rt + "' " +
                             std::to_string(cam.width()) + " " + std::to_string(cam.height()),
                         &out),
              0)
        << out;
    CameraModel back;
    const Status s = CameraModel::Read(path, &back);
    ASSERT_TRUE(s.ok()) << s.message();
    EXPECT_EQ(back.lensmodel(), cam.lensmodel());
    EXPECT_EQ(back.width(), cam.width());
    EXPECT_EQ(back.height(), cam.height());
    // mrcal's Python writes 10 significant digits.
    ASSERT_EQ(back.intrinsics().size(), cam.intrinsics().size());
    for (std::size_t i = 0; i < cam.intrinsics().size(); ++i) {
      EXPECT_NEAR(back.intrinsics()[i], cam.intrinsics()[i], 1e-9 * std::abs(cam.intrinsics()[i]))
          << i;
    }
    EXPECT_LT((back.cam_from_ref().rvec - pose.rvec).norm(), 1e-9);
    EXPECT_LT((back.cam_from_ref().tvec - pose.tvec).norm(), 1e-9);
  }
}

// ----------------------------------------------------------------------------------------------
// Errors

// A .cameramodel with the given fields (already formatted as Python literals).
std::string ModelText(const std::string& lensmodel, const std::string& intrinsics,
                      const std::string& imagersize = "[1024, 768]",
                      const std::string& extrinsics = "[0, 0, 0, 0, 0, 0]") {
  return "{\n  'lensmodel': '" + lensmodel + "',\n  'intrinsics': " + intrinsics +
         ",\n  'extrinsics': " + extrinsics + ",\n  'imagersize': " + imagersize + ",\n}\n";
}

// Writes `text` to `name` and expects Read to fail with a message naming the file.
void ExpectReadError(const std::string& name, const std::string& text,
                     std::initializer_list<std::string> parts) {
  SCOPED_TRACE(name);
  const std::string path = TempPath(name);
  WriteText(path, text);
  CameraModel cam = CameraModel::Pinhole(10, 4, 3);
  ExpectError(CameraModel::Read(path, &cam), path + ": ", parts);
  EXPECT_EQ(cam.lensmodel(), "LENSMODEL_PINHOLE");  // unchanged
}

TEST(CameraModelErrors, ReadMissingFileOrDirectory) {
  const std::string missing = TempPath("no_such.cameramodel");
  CameraModel cam;
  ExpectError(CameraModel::Read(missing, &cam), missing + ": ", {"no such file", ".cameramodel"});
  ExpectError(CameraModel::Read(TempDir().string(), &cam), TempDir().string() + ": ",
              {"is a directory"});
}

TEST(CameraModelErrors, ReadUnparseable) {
  ExpectReadError("empty.cameramodel", "", {"the file is empty", "expected an mrcal .cameramodel"});
  ExpectReadError("garbage.cameramodel", "this is not a camera model\n",
                  {"mrcal cannot parse the file", "expected an mrcal .cameramodel"});
  ExpectReadError("truncated.cameramodel", "{ 'lensmodel': 'LENSMODEL_PINHOLE', 'intrinsics': [1,",
                  {"mrcal cannot parse the file"});
  ExpectReadError("no_extrinsics.cameramodel",
                  "{'lensmodel': 'LENSMODEL_PINHOLE', 'intrinsics': [1, 1, 1, 1], "
                  "'imagersize': [4, 3]}",
                  {"missing 'extrinsics'"});
  ExpectReadError("misordered.cameramodel",
                  "{'intrinsics': [1, 1, 1, 1], 'lensmodel': 'LENSMODEL_PINHOLE', "
                  "'extrinsics': [0, 0, 0, 0, 0, 0], 'imagersize': [4, 3]}",
                  {"'intrinsics' comes before 'lensmodel'"});
}

TEST(CameraModelErrors, ReadUnknownLensModel) {
  ExpectReadError("unknown.cameramodel", ModelText("LENSMODEL_FOO", "[1, 1, 1, 1]"),
                  {"lensmodel: unknown lens model 'LENSMODEL_FOO'", "expected one of",
                   "LENSMODEL_OPENCV8", "LENSMODEL_SPLINED_STEREOGRAPHIC_order=..."});
  ExpectReadError("unconfigured.cameramodel",
                  ModelText("LENSMODEL_SPLINED_STEREOGRAPHIC", "[1, 1, 1, 1]"),
                  {"lensmodel: 'LENSMODEL_SPLINED_STEREOGRAPHIC' has a missing or unreadable "
                   "configuration",
                   "_Nx=..._Ny=..."});
  // mrcal's reader accepts this name, but mrcal_project would abort on a 4th-order spline.
  std::string values = "[600, 600, 511.5, 383.5";
  for (int i = 0; i < 2 * 16 * 12; ++i) values += ", 0";
  ExpectReadError(
      "order4.cameramodel",
      ModelText("LENSMODEL_SPLINED_STEREOGRAPHIC_order=4_Nx=16_Ny=12_fov_x_deg=100", values + "]"),
      {"lensmodel: ", "expected a spline order of 2 or 3, got 4"});
}

TEST(CameraModelErrors, ReadWrongNumberOfIntrinsics) {
  ExpectReadError("short.cameramodel", ModelText("LENSMODEL_PINHOLE", "[1000, 1000, 511.5]"),
                  {"intrinsics: expected 4 values for LENSMODEL_PINHOLE, got 3"});
  ExpectReadError("long.cameramodel",
                  ModelText("LENSMODEL_OPENCV4", "[1000, 1000, 511.5, 383.5, 0, 0, 0, 0, 0]"),
                  {"intrinsics: expected 8 values for LENSMODEL_OPENCV4, got 9"});
}

TEST(CameraModelErrors, ReadNonFiniteIntrinsics) {
  ExpectReadError("nan.cameramodel", ModelText("LENSMODEL_PINHOLE", "[1000, nan, 511.5, 383.5]"),
                  {"intrinsics[1]: expected a finite number, got 'nan'"});
  ExpectReadError("inf.cameramodel", ModelText("LENSMODEL_PINHOLE", "[1000, 1000, 1e400, 383.5]"),
                  {"intrinsics[2]: expected a finite number, got '1e400'"});
  ExpectReadError("bad_extrinsics.cameramodel",
                  ModelText("LENSMODEL_PINHOLE", "[1000, 1000, 511.5, 383.5]", "[1024, 768]",
                            "[0, 0, 0, 0, 0, inf]"),
                  {"extrinsics[5]: expected a finite number, got 'inf'"});
}

// mrcal 2.2 reads past the end of its buffer on a file that ends inside a quoted string or a
// comment (fuzz/fuzz_camera.cc covers it): every prefix of a good file gives an error (or, for
// the whole file, the model), never a crash.
TEST(CameraModelErrors, ReadTruncatedAtEveryByte) {
  const std::string text = "# a comment\n" +
                           ModelText("LENSMODEL_OPENCV4", "[500, 500, 319.5, 239.5, 0, 0, 0, 0]") +
                           "# trailing comment";
  const std::string path = TempPath("truncated.cameramodel");
  for (std::size_t n = 0; n <= text.size(); ++n) {
    SCOPED_TRACE(n);
    WriteText(path, text.substr(0, n));
    CameraModel cam;
    const Status s = CameraModel::Read(path, &cam);
    if (n == text.size()) {
      EXPECT_TRUE(s.ok()) << s.message();
    } else if (!s.ok()) {
      EXPECT_EQ(s.message().rfind(path + ": ", 0), 0u) << s.message();
    }
  }
  ExpectReadError("unclosed.cameramodel", "{\n  'lensmodel': 'LENSMODEL_PIN",
                  {"the string opened on line 2 is not closed before the end of the file"});
  ExpectReadError("unclosed_key.cameramodel",
                  ModelText("LENSMODEL_PINHOLE", "[1, 1, 1, 1]").substr(0, 100) + "'imagersiz",
                  {"is not closed before the end of the file"});
  // mrcal closes a string at the next quote of either kind and knows no escapes: these are
  // unclosed strings to it (and read past its buffer), whatever the quotes look like.
  ExpectReadError("mixed_quotes.cameramodel", "{\n  'lensmodel\": 'LENSMODEL_PINHOLE\n}\n",
                  {"the string opened on line 2 is not closed before the end of the file"});
  ExpectReadError("escaped_quote.cameramodel", "{\n  'lensmodel': 'a\\' 'b\n}\n",
                  {"the string opened on line 2 is not closed before the end of the file"});
}

TEST(CameraModelErrors, ReadBadFocalLength) {
  ExpectReadError("zero_f.cameramodel", ModelText("LENSMODEL_PINHOLE", "[0, 1000, 511.5, 383.5]"),
                  {"intrinsics[0]: expected a positive focal length fx (pixels), got 0"});
  ExpectReadError("negative_f.cameramodel",
                  ModelText("LENSMODEL_PINHOLE", "[1000, -1000, 511.5, 383.5]"),
                  {"intrinsics[1]: expected a positive focal length fy (pixels), got -1000"});
  ExpectReadError("inf_extrinsics.cameramodel",
                  ModelText("LENSMODEL_PINHOLE", "[1000, 1000, 511.5, 383.5]", "[1024, 768]",
                            "[0, 0, 0, 0, 1e400, 0]"),
                  {"extrinsics[4]: expected a finite number"});
}

TEST(CameraModelErrors, ReadBadImageSize) {
  ExpectReadError("zero.cameramodel",
                  ModelText("LENSMODEL_PINHOLE", "[1000, 1000, 511.5, 383.5]", "[0, 768]"),
                  {"imagersize: expected a positive width and height", "got [0, 768]"});
  ExpectReadError("negative.cameramodel",
                  ModelText("LENSMODEL_PINHOLE", "[1000, 1000, 511.5, 383.5]", "[1024, -5]"),
                  {"imagersize: expected a positive width and height", "got [1024, -5]"});
}

TEST(CameraModelErrors, CreateChecksEverything) {
  CameraModel cam = CameraModel::Pinhole(10, 4, 3);
  ExpectError(CameraModel::Create("LENSMODEL_FOO", {1, 1, 1, 1}, 4, 3, &cam),
              "lensmodel: ", {"unknown lens model 'LENSMODEL_FOO'", "LENSMODEL_PINHOLE"});
  ExpectError(CameraModel::Create("LENSMODEL_OPENCV8", {1, 1, 1, 1}, 4, 3, &cam),
              "intrinsics: ", {"expected 12 values for LENSMODEL_OPENCV8, got 4"});
  ExpectError(CameraModel::Create("LENSMODEL_PINHOLE", {1, 1, INFINITY, 1}, 4, 3, &cam),
              "intrinsics[2]: ", {"expected a finite number, got inf"});
  ExpectError(CameraModel::Create("LENSMODEL_PINHOLE", {std::nan(""), 1, 1, 1}, 4, 3, &cam),
              "intrinsics[0]: ", {"expected a finite number, got nan"});
  ExpectError(CameraModel::Create("LENSMODEL_PINHOLE", {0, 1, 1, 1}, 4, 3, &cam),
              "intrinsics[0]: ", {"expected a positive focal length fx (pixels), got 0"});
  ExpectError(CameraModel::Create("LENSMODEL_OPENCV4", {500, -500, 1, 1, 0, 0, 0, 0}, 4, 3, &cam),
              "intrinsics[1]: ", {"expected a positive focal length fy (pixels), got -500"});
  ExpectError(CameraModel::Create("LENSMODEL_PINHOLE", {1, 1, 1, 1}, 0, 3, &cam),
              "imagersize: ", {"expected a positive width and height", "got 0x3"});
  ExpectError(CameraModel::Create("LENSMODEL_PINHOLE", {1, 1, 1, 1}, 4, -3, &cam),
              "imagersize: ", {"got 4x-3"});
  const std::vector<double> spline22(4 + 2 * 3 * 12, 0.0);
  ExpectError(
      CameraModel::Create("LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=3_Ny=12_fov_x_deg=100",
                          spline22, 4, 3, &cam),
      "lensmodel: ", {"expected Nx and Ny >= order + 1 = 4, got Nx=3 Ny=12"});
  ExpectError(CameraModel::Create("LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=12_fov_x_deg=0",
                                  SplinedIntrinsics(), 4, 3, &cam),
              "lensmodel: ", {"expected 0 < fov_x_deg < 360, got 0"});
  ExpectError(
      CameraModel::Create("LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=-1_Ny=12_fov_x_deg=100",
                          SplinedIntrinsics(), 4, 3, &cam),
      "lensmodel: ", {"not in mrcal's canonical form", "Nx=65535"});
  ExpectError(
      CameraModel::Create("LENSMODEL_SPLINED_STEREOGRAPHIC_order=03_Nx=16_Ny=12_fov_x_deg=100",
                          SplinedIntrinsics(), 4, 3, &cam),
      "lensmodel: ",
      {"not in mrcal's canonical form",
       "expected 'LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=16_Ny=12_fov_x_deg=100'"});
  ExpectError(CameraModel::Create("LENSMODEL_CAHVORE_linearity=inf", std::vector<double>(12, 1.0),
                                  4, 3, &cam),
              "lensmodel: ", {"expected a finite linearity"});
  EXPECT_EQ(cam.lensmodel(), "LENSMODEL_PINHOLE");  // unchanged by every failure
  EXPECT_EQ(cam.width(), 4);
}

TEST(CameraModelErrors, WriteFailures) {
  const std::string bad_dir = TempPath("no_such_dir/x.cameramodel");
  ExpectError(CameraModel::Pinhole(10, 4, 3).Write(bad_dir), bad_dir + ": ",
              {"cannot write: No such file or directory"});
  CameraModel cam = CameraModel::Pinhole(10, 4, 3);
  cam.set_cam_from_ref(Pose{Eigen::Vector3d::Zero(), Eigen::Vector3d(0, std::nan(""), 0)});
  const std::string path = TempPath("nan_pose.cameramodel");
  ExpectError(cam.Write(path), path + ": ", {"extrinsics[4]: expected a finite number"});
}

}  // namespace
}  // namespace svms

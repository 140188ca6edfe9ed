#include "svms/sim/render.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <nlohmann/json.hpp>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "svms/camera/photometric.h"
#include "svms/codec/svms44.h"
#include "svms/detect/bit_sampler.h"
#include "svms/imageio/image_io.h"
#include "svms/sim/scene.h"
#include "svms/sim/truth.h"
#include "svms_testing/scratch_dir.h"

namespace svms {
namespace {

// A camera looking straight at the world origin from z = `distance` (camera z = -world z).
Pose LookDown(double distance, double x = 0, double y = 0) {
  // cam_from_world: rotate 180 degrees about x (camera y down = world -y, z forward = world -z).
  Pose p;
  p.rvec = Eigen::Vector3d(M_PI, 0, 0);
  p.tvec = -(p.Rotation() * Eigen::Vector3d(x, y, distance));
  return p;
}

Scene BaseScene(const CameraModel& cam) {
  Scene s;
  s.seed = 11;
  s.camera = cam;
  s.sensor.read_noise = 0;
  s.sensor.shot_noise = false;
  s.light.ambient = 1.0;  // uniform light: radiance = reflectance
  return s;
}

SceneObject PlateWithMarker(const MarkerModel& m, const Pose& object_from_marker,
                            double plate = 2) {
  SceneObject o;
  o.name = "plate";
  o.shape = SceneObject::Shape::kPlane;
  o.size = Eigen::Vector3d(plate, plate, 0);
  o.material.reflectance = 0.3;
  SceneMarker sm;
  sm.model = m;
  sm.object_from_marker = object_from_marker;
  o.markers.push_back(sm);
  return o;
}

std::unique_ptr<Renderer> Make(const Scene& s) {
  std::unique_ptr<Renderer> r;
  const Status st = Renderer::Create(s, &r);
  EXPECT_TRUE(st.ok()) << st.message();
  return r;
}

CameraModel Opencv8(int w, int h) {
  CameraModel cam;
  const Status s = CameraModel::Create("LENSMODEL_OPENCV8",
                                       {700, 705, (w - 1) / 2.0 + 3, (h - 1) / 2.0 - 2, -0.28, 0.09,
                                        0.001, -0.0007, -0.01, 0.02, 0.003, 0.001},
                                       w, h, &cam);
  EXPECT_TRUE(s.ok()) << s.message();
  return cam;
}

TEST(Render, TruthCornersEqualAnIndependentProjection) {
  Scene s = BaseScene(Opencv8(640, 480));
  Pose fm;  // on the plate, turned in its plane
  fm.rvec = Eigen::Vector3d(0, 0, 0.4);
  fm.tvec = Eigen::Vector3d(0.05, -0.03, 0);
  s.objects.push_back(PlateWithMarker(MarkerModel::Standard(5, 0.1, 0.02), fm));
  Pose tilted = LookDown(0.9, 0.02, 0.01);
  tilted = Pose{Eigen::Vector3d(0.25, -0.15, 0), Eigen::Vector3d::Zero()} * tilted;
  s.views.push_back(View{"v", tilted});
  auto r = Make(s);
  const ViewTruth t = ComputeTruth(*r, 0);
  ASSERT_EQ(t.markers.size(), 1u);
  // OpenCV's own projection with the same 8 distortion coefficients.
  const auto& in = s.camera.intrinsics();
  const cv::Matx33d K(in[0], 0, in[2], 0, in[1], in[3], 0, 0, 1);
  const std::vector<double> dist(in.begin() + 4, in.end());
  std::vector<cv::Point3d> pts;
  for (const auto& c : MarkerModel::Standard(5, 0.1, 0.02).Corners()) {
    const Eigen::Vector3d p = t.markers[0].cam_from_marker * c;
    pts.emplace_back(p.x(), p.y(), p.z());
  }
  std::vector<cv::Point2d> px;
  cv::projectPoints(pts, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, dist, px);
  for (int c = 0; c < 4; ++c) {
    EXPECT_NEAR(t.markers[0].corners[c].pixel.x(), px[c].x, 1e-6);
    EXPECT_NEAR(t.markers[0].corners[c].pixel.y(), px[c].y, 1e-6);
    EXPECT_TRUE(t.markers[0].corners[c].in_image);
    EXPECT_FALSE(t.markers[0].corners[c].occluded);
  }
  EXPECT_EQ(t.markers[0].bits_occluded, 0);
  // Fully visible exactly when no cell leaves the frame (corners are in, nothing occludes).
  EXPECT_EQ(t.markers[0].fully_visible(), t.markers[0].bits_outside == 0)
      << t.markers[0].bits_outside;
}

TEST(Render, CameraRaysMatchMrcalWithinATenThousandthOfAPixel) {
  Scene s = BaseScene(Opencv8(320, 240));
  s.views.push_back(View{"v", LookDown(1)});
  auto r = Make(s);
  double worst = 0;
  for (double v = 0.13; v < 239; v += 7.77) {
    for (double u = -0.41; u < 319; u += 5.31) {
      Eigen::Vector3d d;
      ASSERT_TRUE(r->CameraRay(u, v, &d));
      Eigen::Vector2d back;
      ASSERT_TRUE(s.camera.Project(d, &back));
      worst = std::max(worst, (back - Eigen::Vector2d(u, v)).norm());
    }
  }
  RecordProperty("worst_px", std::to_string(worst));
  EXPECT_LT(worst, 1e-4) << "interpolated rays within a ten-thousandth of a pixel";
}

TEST(Render, RenderedMarkerDecodesAtItsTruthCorners) {
  Scene s = BaseScene(Opencv8(640, 480));
  s.light.ambient = 0.1;
  s.light.sun = Sun{Eigen::Vector3d(0.3, -0.4, 1).normalized(), 1.0, 0.53};
  s.sensor.read_noise = 3;
  s.sensor.shot_noise = true;
  for (int id : {17, 4242}) {
    s.objects.clear();
    Pose fm;
    fm.rvec = Eigen::Vector3d(0, 0, 2.0);
    MarkerModel m = MarkerModel::Standard(id, 0.12, 0.03);
    s.objects.push_back(PlateWithMarker(m, fm));
    s.views = {
        View{"v", Pose{Eigen::Vector3d(0.12, -0.08, 0), Eigen::Vector3d::Zero()} * LookDown(0.8)}};
    auto r = Make(s);
    const cv::Mat img = r->Expose(r->RenderRadiance(0), 0);
    const ViewTruth t = ComputeTruth(*r, 0);
    ASSERT_TRUE(t.markers[0].fully_visible());
    std::vector<cv::Point2d> src, dst;
    const auto corners = m.Corners();
    for (int c = 0; c < 4; ++c) {
      src.emplace_back(corners[c].x(), corners[c].y());
      dst.emplace_back(t.markers[0].corners[c].pixel.x(), t.markers[0].corners[c].pixel.y());
    }
    // The lens bends lines, so a homography from the corners is only near the truth: fine for
    // reading bits at 60+ px.
    const cv::Mat Hcv = cv::findHomography(src, dst);
    Eigen::Matrix3d H;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) H(i, j) = Hcv.at<double>(i, j);
    const BitReading br = SampleBits(img, H, m);
    const CodeMatch match = Svms44::Decode(br.word, 0);
    if (const char* dir = std::getenv("SVMS_TEST_IMAGES"); dir && !match.accepted())
      cv::imwrite(std::string(dir) + "/decode_fail_" + std::to_string(id) + ".png", img);
    ASSERT_TRUE(match.accepted()) << id << " read " << Svms44::ToBitString(br.word) << " want "
                                  << Svms44::ToBitString(Svms44::Codeword(id)) << " black "
                                  << br.black << " white " << br.white << " outside "
                                  << br.samples_outside;
    EXPECT_EQ(match.id, id);
    EXPECT_EQ(match.rotation, 0);
    // Every bit as printed, none corrected: the renderer paints the cells where the detector
    // samples them (both from MarkerModel::BitCellCentre).
    EXPECT_EQ(br.word, Svms44::Codeword(id)) << Svms44::ToBitString(br.word);
  }
}

TEST(Render, FrontoParallelSquareCoversTheExpectedArea) {
  // Pinhole f = 1000 px; a flat 0.1 m marker at 2 m: the black square is 50 px wide.
  Scene s = BaseScene(CameraModel::Pinhole(1000, 400, 400));
  MarkerModel m = MarkerModel::Standard(7, 0.1, 0);
  s.objects.push_back(PlateWithMarker(m, Pose{}));
  s.objects[0].markers[0].black = 0.0;
  s.objects[0].markers[0].white = 1.0;
  s.views.push_back(View{"v", LookDown(2.0, 0.0003, -0.0007)});
  auto r = Make(s);
  const cv::Mat L = r->RenderRadiance(0);
  // Inside the stripe's outer boundary (5 cells = 83.3 mm -> 83.3 px across), darkness is the
  // black square only.
  const double c = 199.5 - 1000 * 0.0003 / 2.0, half = 0.5 * 1000 * (5 * m.cell_size * 2) / 2.0 - 2;
  double dark = 0;
  for (int y = 0; y < 400; ++y)
    for (int x = 0; x < 400; ++x)
      if (std::abs(x - c) < half && std::abs(y - (199.5 - 1000 * 0.0007 / 2.0)) < half)
        dark += 1 - L.at<float>(y, x);
  const double expected = 50.0 * 50.0;
  EXPECT_NEAR(dark, expected, 0.005 * expected);
}

// The area of the unit pixel square about (x, y) inside the convex polygon `poly`
// (counter-clockwise or clockwise): the pixel clipped by each of its edges, then the shoelace.
double CoveredArea(const std::vector<Eigen::Vector2d>& poly, int x, int y) {
  std::vector<Eigen::Vector2d> p = {
      {x - 0.5, y - 0.5}, {x + 0.5, y - 0.5}, {x + 0.5, y + 0.5}, {x - 0.5, y + 0.5}};
  double orient = 0;
  for (size_t i = 0; i < poly.size(); ++i) {
    const Eigen::Vector2d &a = poly[i], &b = poly[(i + 1) % poly.size()];
    orient += a.x() * b.y() - b.x() * a.y();
  }
  for (size_t i = 0; i < poly.size() && !p.empty(); ++i) {
    const Eigen::Vector2d a = poly[i], b = poly[(i + 1) % poly.size()];
    auto inside = [&](const Eigen::Vector2d& q) {
      return orient * ((b.x() - a.x()) * (q.y() - a.y()) - (b.y() - a.y()) * (q.x() - a.x())) >= 0;
    };
    std::vector<Eigen::Vector2d> next;
    for (size_t k = 0; k < p.size(); ++k) {
      const Eigen::Vector2d &u = p[k], &v = p[(k + 1) % p.size()];
      if (inside(u)) next.push_back(u);
      if (inside(u) != inside(v)) {
        const Eigen::Vector2d d = b - a;
        const double t = (d.x() * (a.y() - u.y()) - d.y() * (a.x() - u.x())) /
                         (d.x() * (v.y() - u.y()) - d.y() * (v.x() - u.x()));
        next.push_back(u + t * (v - u));
      }
    }
    p = next;
  }
  double area = 0;
  for (size_t k = 0; k < p.size(); ++k)
    area += p[k].x() * p[(k + 1) % p.size()].y() - p[(k + 1) % p.size()].x() * p[k].y();
  return 0.5 * std::abs(area);
}

// A black square's edges, slanted, against its white stripe: 16 jittered rays give an edge
// pixel's coverage to a few percent of the contrast; sensor.edge_rays_per_pixel = 256 renders
// those pixels again and brings it under 1 %, leaves every pixel whose neighbours all match it
// to the bit, and renders the same bytes twice.
TEST(Render, EdgeRaysRenderEdgePixelsAtTheirExactCoverage) {
  Scene s = BaseScene(CameraModel::Pinhole(1000, 200, 200));
  MarkerModel m = MarkerModel::Standard(7, 0.1, 0);
  s.objects.push_back(
      PlateWithMarker(m, Pose{Eigen::Vector3d(0, 0, 0.3), Eigen::Vector3d::Zero()}));
  s.objects[0].markers[0].black = 0.0;
  s.objects[0].markers[0].white = 1.0;
  s.views.push_back(View{"v", LookDown(2.0, 0.0003, -0.0007)});
  s.sensor.edge_rays_per_pixel = 0;
  const cv::Mat coarse = Make(s)->RenderRadiance(0);
  s.sensor.edge_rays_per_pixel = 256;
  const std::unique_ptr<Renderer> r = Make(s);
  const cv::Mat fine = r->RenderRadiance(0);
  EXPECT_EQ(cv::norm(fine, r->RenderRadiance(0), cv::NORM_INF), 0);
  // The black square in the image, from the truth's corners.
  const ViewTruth t = ComputeTruth(*r, 0);
  ASSERT_EQ(t.markers.size(), 1u);
  std::vector<Eigen::Vector2d> square;
  for (const PointTruth& c : t.markers[0].corners) square.push_back(c.pixel);
  const cv::Mat edge_mask = EdgePixels(coarse);
  double e2_coarse = 0, e2_fine = 0;
  int edge = 0, kept = 0;
  for (int y = 1; y + 1 < coarse.rows; ++y)
    for (int x = 1; x + 1 < coarse.cols; ++x) {
      const double covered = CoveredArea(square, x, y);
      if (covered > 0.02 && covered < 0.98) {
        EXPECT_TRUE(edge_mask.at<uint8_t>(y, x)) << covered << " covered at " << x << ", " << y;
        e2_coarse += std::pow(coarse.at<float>(y, x) - (1 - covered), 2);
        e2_fine += std::pow(fine.at<float>(y, x) - (1 - covered), 2);
        ++edge;
      }
      if (!edge_mask.at<uint8_t>(y, x)) {
        EXPECT_EQ(fine.at<float>(y, x), coarse.at<float>(y, x)) << x << ", " << y;
        ++kept;
      }
    }
  const double rms_coarse = std::sqrt(e2_coarse / edge), rms_fine = std::sqrt(e2_fine / edge);
  std::printf(
      "%d edge pixels: coverage error RMS %.4f at 16 rays, %.4f with 256 on edges; %d "
      "pixels kept\n",
      edge, rms_coarse, rms_fine, kept);
  EXPECT_GT(edge, 150);
  EXPECT_GT(rms_coarse, 0.02);
  EXPECT_LT(rms_fine, 0.01);
  EXPECT_GT(kept, coarse.total() / 2);
}

// Defocus as a lens makes it: the light blurred before the pixels integrate it. A black square
// (3 degrees off the pixel rows, where every pixel along a side has nearly the same sub-pixel
// phase) in white, behind a Gaussian of 0.7 px: the blurred square is exactly the product of two
// blurred intervals in its own axes, integrated here over each pixel's area. Exposed from
// RenderRadianceFine, every pixel within 3 px of the square is within 0.6 % of the contrast of
// that; blurred on the pixel grid instead (a radiance at the camera's size), pixels err by
// several percent, depending on the phase.
TEST(Render, DefocusBlursTheLightBeforeThePixelsIntegrateIt) {
  Scene s = BaseScene(CameraModel::Pinhole(1000, 200, 200));
  MarkerModel m = MarkerModel::Standard(7, 0.1, 0);
  s.objects.push_back(PlateWithMarker(
      m, Pose{Eigen::Vector3d(0, 0, 3 * M_PI / 180), Eigen::Vector3d(0.0021, -0.0013, 0)}));
  s.objects[0].markers[0].black = 0.0;
  s.objects[0].markers[0].white = 1.0;
  s.views.push_back(View{"v", LookDown(2.0)});
  s.sensor.edge_rays_per_pixel = 256;
  s.sensor.bits = 16;
  s.sensor.exposure = s.sensor.full_well;  // DN = radiance x 65535
  constexpr double kBlur = 0.7;
  s.sensor.defocus_sigma_px = kBlur;
  const std::unique_ptr<Renderer> r = Make(s);
  const cv::Mat lens = r->Expose(r->RenderRadianceFor(0, s.sensor), 0);
  const cv::Mat grid = r->Expose(r->RenderRadiance(0), 0);
  ASSERT_EQ(lens.size(), grid.size());
  const ViewTruth t = ComputeTruth(*r, 0);
  ASSERT_EQ(t.markers.size(), 1u);
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (const PointTruth& c : t.markers[0].corners) centre += 0.25 * c.pixel;
  const Eigen::Vector2d a = t.markers[0].corners[0].pixel, b = t.markers[0].corners[1].pixel;
  const Eigen::Vector2d ax = (b - a).normalized(), ay(-ax.y(), ax.x());
  const double h = 0.5 * (b - a).norm();
  auto interval = [&](double u) {
    return 0.5 * (std::erf((u + h) / (kBlur * std::sqrt(2.0))) -
                  std::erf((u - h) / (kBlur * std::sqrt(2.0))));
  };
  double worst_lens = 0, worst_grid = 0;
  int pixels = 0;
  for (int y = 0; y < lens.rows; ++y)
    for (int x = 0; x < lens.cols; ++x) {
      const Eigen::Vector2d q = Eigen::Vector2d(x, y) - centre;
      const double du = std::abs(q.dot(ax)) - h, dv = std::abs(q.dot(ay)) - h;
      if (std::max(du, dv) > 3 || std::max(du, dv) < -3) continue;
      constexpr int kS = 8;
      double dark = 0;
      for (int j = 0; j < kS; ++j)
        for (int i = 0; i < kS; ++i) {
          const Eigen::Vector2d p = q + Eigen::Vector2d((i + 0.5) / kS - 0.5, (j + 0.5) / kS - 0.5);
          dark += interval(p.dot(ax)) * interval(p.dot(ay)) / (kS * kS);
        }
      const double truth = 65535 * (1 - dark);
      worst_lens = std::max(worst_lens, std::abs(lens.at<uint16_t>(y, x) - truth) / 65535);
      worst_grid = std::max(worst_grid, std::abs(grid.at<uint16_t>(y, x) - truth) / 65535);
      ++pixels;
    }
  std::printf(
      "%d pixels within 3 px of the square: worst error %.4f of the contrast (light blurred "
      "on the fine grid), %.4f (on the pixel grid)\n",
      pixels, worst_lens, worst_grid);
  EXPECT_GT(pixels, 1000);
  EXPECT_LT(worst_lens, 0.006);
  EXPECT_GT(worst_grid, 0.02);
}

TEST(EdgePixels, AStraightGradientIsNotAnEdgeButAStepItsRampAndNoiseAre) {
  cv::Mat r(40, 60, CV_32F);
  // A shading gradient of 0.012 per pixel across the image and 0.006 down it (0.018 along a
  // diagonal, under kEdgeRadianceJump).
  for (int y = 0; y < r.rows; ++y)
    for (int x = 0; x < r.cols; ++x) r.at<float>(y, x) = 0.1f + 0.012f * x + 0.006f * y;
  EXPECT_EQ(cv::countNonZero(EdgePixels(r)), 0);
  // A vertical step of 0.6 whose edge runs through column 30 at half coverage: the half pixel
  // sits on a straight ramp (0.2, 0.5, 0.8), found by the jump; its two neighbours by both tests.
  cv::Mat s(40, 60, CV_32F, cv::Scalar(0.2));
  s.colRange(31, 60).setTo(0.8);
  s.col(30).setTo(0.5);
  cv::Mat e = EdgePixels(s);
  for (int x = 0; x < s.cols; ++x) EXPECT_EQ(e.at<uint8_t>(20, x), x >= 29 && x <= 31 ? 1 : 0) << x;
  EXPECT_EQ(cv::countNonZero(e), 3 * s.rows);
  // A faint step (0.01, under the jump) is still found where it bends the profile.
  cv::Mat f(40, 60, CV_32F, cv::Scalar(0.3));
  f.colRange(30, 60).setTo(0.31);
  e = EdgePixels(f);
  EXPECT_EQ(e.at<uint8_t>(20, 29), 1);
  EXPECT_EQ(e.at<uint8_t>(20, 30), 1);
  EXPECT_EQ(e.at<uint8_t>(20, 27), 0);
  EXPECT_EQ(e.at<uint8_t>(20, 32), 0);
  // Noise of the first pass's estimate (one pixel off by 0.005) is found, with its neighbours;
  // the sun disc's sampling noise (0.001) is not.
  cv::Mat n(40, 60, CV_32F, cv::Scalar(0.5));
  n.at<float>(30, 30) = 0.501f;
  EXPECT_EQ(cv::countNonZero(EdgePixels(n)), 0);
  n.at<float>(30, 30) = 0.5f;
  n.at<float>(10, 10) = 0.505f;
  e = EdgePixels(n);
  EXPECT_EQ(e.at<uint8_t>(10, 10), 1);
  EXPECT_EQ(e.at<uint8_t>(10, 11), 1);
  EXPECT_EQ(e.at<uint8_t>(11, 11), 1);
  EXPECT_EQ(e.at<uint8_t>(10, 13), 0);
  EXPECT_EQ(cv::countNonZero(e), 9);
}

// RenderRadianceFine casts the fine grid only inside the camera pixels on an edge and their
// neighbours, and copies the camera pixel elsewhere (render.cc). Against the fine grid rendered
// whole (a camera 4 times finer, 16 rays in every one of its pixels, the fine grid's own count
// on edges), the exposed frames agree to the sampling noise: under a sun whose disc is sampled
// (the noise that copying avoids) with a post whose shading curves within a pixel, and in the
// ambient light of a shadow (contrast 0.03), the marker square to the pixel rows at two
// half-pixel phases, where a step through the middle of a pixel is no edge pixel of its own.
// Measured: worst 0.1 % of the contrast in sunlight, 0 in shadow (the very rays of the whole
// grid); without the neighbours 4.9-5.6 % in shadow, without casting at all 6 % in sunlight. The
// shadow's frames are checked to hold such steps.
TEST(Render, TheFineGridIsRenderedWhereTheLightChangesWithinAPixel) {
  constexpr int kSize = 160;
  constexpr double kFocal = 1000;
  struct Case {
    const char* name;
    bool sun;
    Pose object_from_marker;
  };
  const Case cases[] = {
      {"sunlit, turned", true,
       Pose{Eigen::Vector3d(0.2, -0.3, 0.5), Eigen::Vector3d(0.003, -0.002, 0)}},
      {"shadow, square to the rows", false, Pose{}},
      {"shadow, half a pixel on", false,
       Pose{Eigen::Vector3d::Zero(), Eigen::Vector3d(0.0006, 0.0006, 0)}},
  };
  for (const Case& c : cases) {
    auto scene_for = [&](const CameraModel& cam, int rays, int edge_rays) {
      Scene s = BaseScene(cam);
      s.light.ambient = c.sun ? 0.05 : 0.04;
      if (c.sun) s.light.sun = Sun{Eigen::Vector3d(0.4, 0.3, 1).normalized(), 1.0, 0.53};
      s.objects.push_back(
          PlateWithMarker(MarkerModel::Standard(12, 0.1, c.sun ? 0.02 : 0), c.object_from_marker));
      s.views.push_back(View{"v", LookDown(1.2)});
      s.sensor.rays_per_pixel = rays;
      s.sensor.edge_rays_per_pixel = edge_rays;
      s.sensor.bits = 16;
      s.sensor.exposure = s.sensor.full_well;  // DN = radiance x 65535
      s.sensor.defocus_sigma_px = 0.7;
      return s;
    };
    const std::unique_ptr<Renderer> r =
        Make(scene_for(CameraModel::Pinhole(kFocal, kSize, kSize), 16, 256));
    // Pixel (i, j) of a camera 4 times finer with its principal point at (4 W - 1) / 2 is fine
    // pixel (i, j) of RenderRadianceFine's grid.
    const std::unique_ptr<Renderer> whole = Make(
        scene_for(CameraModel::Pinhole(kRadianceSupersample * kFocal, kRadianceSupersample * kSize,
                                       kRadianceSupersample * kSize),
                  16, 0));
    const cv::Mat fine = r->RenderRadianceFine(0), reference = whole->RenderRadiance(0);
    ASSERT_EQ(fine.size(), reference.size());
    cv::Mat a, b;
    r->Expose(fine, 0).convertTo(a, CV_64F, 1 / 65535.0);
    r->Expose(reference, 0).convertTo(b, CV_64F, 1 / 65535.0);
    double lo, hi, worst;
    cv::minMaxLoc(b, &lo, &hi);
    cv::minMaxLoc(cv::abs(a - b), nullptr, &worst);
    const double contrast = hi - lo;
    std::printf(
        "%s: exposed from the fine grid cast at edges only against cast whole: worst %.6f of "
        "white, %.3f %% of the contrast %.3f\n",
        c.name, worst, 100 * worst / contrast, contrast);
    EXPECT_GT(contrast, c.sun ? 0.5 : 0.025) << c.name;
    EXPECT_LT(worst / contrast, 0.005) << c.name;
    if (c.sun) continue;
    // The shadow's case is the one for the neighbours: camera pixels that a step crosses (their
    // 16 fine pixels of the reference span a quarter of the contrast or more) which are no edge
    // pixels of the first pass (rays_per_pixel alone: the same samples), found only as a
    // neighbour's.
    const cv::Mat first =
        Make(scene_for(CameraModel::Pinhole(kFocal, kSize, kSize), 16, 0))->RenderRadiance(0);
    const cv::Mat edge = EdgePixels(first);
    double rlo, rhi;
    cv::minMaxLoc(reference, &rlo, &rhi);
    int unflagged_steps = 0;
    for (int y = 0; y < kSize; ++y)
      for (int x = 0; x < kSize; ++x) {
        if (edge.at<uint8_t>(y, x)) continue;
        double blo, bhi;
        cv::minMaxLoc(reference(cv::Rect(kRadianceSupersample * x, kRadianceSupersample * y,
                                         kRadianceSupersample, kRadianceSupersample)),
                      &blo, &bhi);
        unflagged_steps += bhi - blo >= 0.25 * (rhi - rlo);
      }
    std::printf("%s: %d pixels crossed by a step that are no edge pixels of their own\n", c.name,
                unflagged_steps);
    EXPECT_GT(unflagged_steps, 0) << c.name;
  }
}

TEST(Render, PostLitAt45DegreesCastsAShadowAsLongAsItIsTall) {
  Scene s = BaseScene(CameraModel::Pinhole(2000, 400, 400));
  s.light.ambient = 0.05;
  s.light.sun =
      Sun{Eigen::Vector3d(1, 0, 1).normalized(), 1.0, 0.0};  // point sun, 45 degrees, from +x
  const double h = 0.07, radius = 0.002;
  MarkerModel m = MarkerModel::Standard(8, 0.1, h);
  m.post->radius = m.post->tip_radius = radius;
  s.objects.push_back(PlateWithMarker(m, Pose{}));
  s.views.push_back(View{"v", LookDown(1.0)});
  auto r = Make(s);
  // Geometry: along -x from the post, shadowed up to h + r (the top disc's far edge).
  for (double x = -0.005; x > -0.09; x -= 0.001) {
    const bool shadow = r->InSunShadow(0, Eigen::Vector3d(x, 0, 0));
    if (x > -(h + radius) + 0.0005) {
      EXPECT_TRUE(shadow) << x;
    }
    if (x < -(h + radius) - 0.0005) {
      EXPECT_FALSE(shadow) << x;
    }
  }
  // Pixels: along the image row through the post, the shadow edge in the white stripe is at
  // h + r from the centre (2000 px/m at 1 m: 144 px). The camera looks down with its x along
  // world x, so world x maps to column 199.5 + 2000 x; world y = 0 is between rows 199 and 200.
  const cv::Mat L = r->RenderRadiance(0);
  auto at = [&](int col) { return 0.5 * (L.at<float>(199, col) + L.at<float>(200, col)); };
  double edge = -1;
  for (int col = 150; col > 20; --col) {
    if (at(col) > 0.4) {  // first lit pixel beyond the shadow (lit white: 0.85 * 0.707 + ambient)
      const double prev = at(col + 1);
      edge = col + 1 - (0.4 - prev) / (at(col) - prev);  // sub-pixel crossing
      break;
    }
  }
  ASSERT_GT(edge, 0);
  EXPECT_NEAR((199.5 - edge) / 2000.0, h + radius, 1.0 / 2000);
}

TEST(Render, NoiseMatchesItsModel) {
  Scene s = BaseScene(CameraModel::Pinhole(300, 200, 200));
  s.sensor.shot_noise = true;
  s.sensor.read_noise = 6;
  s.sensor.exposure = 10000;
  s.sensor.full_well = 20000;
  s.sensor.bits = 16;
  SceneObject wall;
  wall.name = "wall";
  wall.size = Eigen::Vector3d(20, 20, 0);
  wall.material.reflectance = 0.5;
  s.objects.push_back(wall);
  s.views.push_back(View{"v", LookDown(1)});
  auto r = Make(s);
  const cv::Mat img = r->Expose(r->RenderRadiance(0), 0);
  cv::Scalar mean, sd;
  cv::meanStdDev(img, mean, sd);
  const double g = 65535.0 / 20000, electrons = 10000 * 0.5;
  EXPECT_NEAR(mean[0], g * electrons, 0.005 * g * electrons);
  const double var = g * g * (electrons + 36) + 1.0 / 12;
  EXPECT_NEAR(sd[0] * sd[0], var, 0.03 * var);  // 40,000 pixels: 1 % standard error
}

TEST(Render, AFixedSeedRendersTheSameBytes) {
  Scene s = BaseScene(CameraModel::Pinhole(400, 160, 120));
  s.sensor.read_noise = 5;
  s.sensor.shot_noise = true;
  s.light.sun = Sun{Eigen::Vector3d(0.2, 0.1, 1).normalized(), 1.0, 0.53};
  s.background.kind = Background::Kind::kEarth;
  s.objects.push_back(PlateWithMarker(MarkerModel::Standard(1, 0.1, 0.02), Pose{}, 0.3));
  s.views.push_back(View{"v", LookDown(1)});
  auto a = Make(s), b = Make(s);
  const cv::Mat ia = a->Expose(a->RenderRadiance(0), 0), ib = b->Expose(b->RenderRadiance(0), 0);
  EXPECT_EQ(cv::norm(ia, ib, cv::NORM_INF), 0);
  s.seed = 12;
  auto c = Make(s);
  EXPECT_GT(cv::norm(ia, c->Expose(c->RenderRadiance(0), 0), cv::NORM_L1), 0);
}

TEST(Render, OccluderIsFlaggedInTruth) {
  Scene s = BaseScene(CameraModel::Pinhole(800, 400, 400));
  const MarkerModel m = MarkerModel::Standard(2, 0.1, 0.02);
  s.objects.push_back(PlateWithMarker(m, Pose{}));
  Occluder bar;
  // Seen from (0, 0, 1), a bar over x in [-0.045, -0.025] at height 0.3 hides the ground at
  // x in [-0.064, -0.036]: the left corners (x = -0.05) and cells k = 2, 3 of the top and bottom
  // rows (x = -0.0583, -0.0417).
  bar.world_from_occluder.tvec = Eigen::Vector3d(-0.035, 0, 0.3);
  bar.size = Eigen::Vector3d(0.02, 0.5, 0.01);
  s.occluders.push_back(bar);
  s.views.push_back(View{"v", LookDown(1)});
  auto r = Make(s);
  const ViewTruth t = ComputeTruth(*r, 0);
  EXPECT_TRUE(t.markers[0].corners[0].occluded);   // top-left
  EXPECT_FALSE(t.markers[0].corners[1].occluded);  // top-right
  EXPECT_FALSE(t.markers[0].corners[2].occluded);  // bottom-right
  EXPECT_TRUE(t.markers[0].corners[3].occluded);   // bottom-left
  EXPECT_FALSE(t.markers[0].fully_visible());
  EXPECT_EQ(t.markers[0].bits_occluded, 4);
}

TEST(SceneFile, ErrorsNameTheField) {
  const std::string good = R"({"type": "svms.scene", "seed": 1,
    "camera": {"lensmodel": "LENSMODEL_PINHOLE", "intrinsics": [500, 500, 99.5, 99.5], "width": 200, "height": 200},
    "objects": [], "views": [{"name": "a", "cam_from_world": {"rvec": [0,0,0], "tvec": [0,0,1]}}]})";
  Scene s;
  ASSERT_TRUE(ParseSceneJson(good, "s.json", "", &s).ok());
  auto expect = [&](const std::string& from, const std::string& to, const std::string& want) {
    std::string text = good;
    const size_t at = text.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    text.replace(at, from.size(), to);
    Scene sc;
    const Status st = ParseSceneJson(text, "s.json", "", &sc);
    ASSERT_FALSE(st.ok()) << to;
    EXPECT_NE(st.message().find(want), std::string::npos) << st.message();
    EXPECT_EQ(st.message().rfind("s.json: ", 0), 0u) << st.message();
  };
  expect("\"seed\": 1", "\"seed\": -1", "seed: expected a non-negative integer");
  expect("\"width\": 200", "\"width\": 0", "camera: ");
  expect("[500, 500, 99.5, 99.5]", "[500, 500, 99.5]", "camera: ");
  expect("\"objects\": []", "\"objects\": [{\"name\": \"b\", \"shape\": \"cone\"}]",
         "objects[0].shape: expected \"plane\" or \"box\"");
  expect("\"views\": [", "\"sensor\": {\"rays_per_pixel\": 10}, \"views\": [",
         "sensor.rays_per_pixel: expected a square number");
  expect("\"views\": [", "\"sensor\": {\"bits\": 12}, \"views\": [",
         "sensor.bits: expected 8 or 16");
  expect("\"views\": [", "\"sensor\": {\"edge_rays_per_pixel\": 20}, \"views\": [",
         "sensor.edge_rays_per_pixel: expected 0 (off), or a square number of at most 4096");
  expect("\"views\": [", "\"sensor\": {\"edge_rays_per_pixel\": 8100}, \"views\": [",
         "sensor.edge_rays_per_pixel: expected 0 (off), or a square number of at most 4096");
  expect("\"views\": [",
         "\"light\": {\"sun\": {\"to_sun\": [0,0,0], \"irradiance\": 1}}, \"views\": [",
         "light.sun.to_sun: expected a nonzero direction");
  expect("\"views\": [",
         "\"background\": {\"kind\": \"image\", \"image\": \"nope.png\"}, \"views\": [",
         "background.image: nope.png: no such file");
  expect("\"name\": \"a\"", "\"name\": \"a/b\"",
         "views[0].name: expected a non-empty file name without slashes");
  expect("\"tvec\": [0,0,1]", "\"tvec\": [0,0]",
         "views[0].cam_from_world.tvec: expected an array of 3 numbers");
  expect("\"seed\": 1,", "\"seed\": 1, \"colour\": 3,", "colour: unknown field");
  expect(
      "\"objects\": [], \"views\": [{\"name\": \"a\", \"cam_from_world\": {\"rvec\": [0,0,0], "
      "\"tvec\": [0,0,1]}}]",
      "\"objects\": [], \"views\": []", "views: expected a non-empty array");
  // Bad numbers: a literal beyond a double's range (read as infinity), zero and negative sizes,
  // impossible cameras.
  expect("\"tvec\": [0,0,1]", "\"tvec\": [0,0,1e400]",
         ": tvec: the number 1e400 is beyond the range of a double; expected a finite number");
  expect("[500, 500, 99.5, 99.5]", "[500, 500, -1e999, 99.5]",
         "intrinsics: the number -1e999 is beyond");
  expect("[500, 500, 99.5, 99.5]", "[0, 500, 99.5, 99.5]",
         "camera: intrinsics[0]: expected a positive focal length fx");
  expect("\"width\": 200", "\"width\": 2000000",
         "camera: 2000000x200 pixels; expected at most 100 megapixels");
  expect("\"views\": [",
         "\"light\": {\"sun\": {\"to_sun\": [0,0,1], \"irradiance\": 1e400}}, \"views\": [",
         "irradiance: the number 1e400 is beyond");
  const std::string plate =
      "\"objects\": [{\"name\": \"p\", \"shape\": \"plane\", \"size\": [1, SIZE, 0], "
      "\"reflectance\": 0.5, \"world_from_object\": {\"rvec\": [0,0,0], \"tvec\": [0,0,0]}}]";
  auto with_size = [&](const std::string& v) {
    std::string t = plate;
    t.replace(t.find("SIZE"), 4, v);
    return t;
  };
  expect("\"objects\": []", with_size("0"), "objects[0].size: expected positive extents");
  expect("\"objects\": []", with_size("-2"), "objects[0].size: expected positive extents");
  expect("\"objects\": []", with_size("1e308e"), "not valid JSON");
  {
    std::string text = good;
    text.replace(text.find("\"objects\": []"), 13, with_size("1"));
    Scene ok;
    const Status st = ParseSceneJson(text, "s.json", "", &ok);
    EXPECT_TRUE(st.ok()) << "the plate itself is fine: " << st.message();
  }
}

TEST(Render, SunDirectionsFromCodeAreNormalised) {
  Scene s = BaseScene(CameraModel::Pinhole(400, 64, 48));
  s.light.sun = Sun{Eigen::Vector3d(0, 0, 5), 1.0, 0.53};  // not unit length
  s.objects.push_back(PlateWithMarker(MarkerModel::Standard(1, 0.1, 0.02), Pose{}));
  s.views.push_back(View{"v", LookDown(1)});
  auto a = Make(s);
  s.light.sun->to_sun_world = Eigen::Vector3d(0, 0, 1);
  auto b = Make(s);
  EXPECT_EQ(cv::norm(a->RenderRadiance(0), b->RenderRadiance(0), cv::NORM_INF), 0);
  s.light.sun->to_sun_world = Eigen::Vector3d::Zero();
  std::unique_ptr<Renderer> r;
  const Status st = Renderer::Create(s, &r);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("light.sun.to_sun"), std::string::npos);
}

TEST(SceneFile, RoundTripsThroughJson) {
  Scene s = BaseScene(Opencv8(64, 48));
  s.light.sun = Sun{Eigen::Vector3d(0, 0.6, 0.8), 2.0, 0.53};
  s.objects.push_back(PlateWithMarker(MarkerModel::Standard(9, 0.1, -0.02), Pose{}));
  s.views.push_back(View{"v0", LookDown(1)});
  s.sensor.edge_rays_per_pixel = 64;
  Scene back;
  const Status st = ParseSceneJson(SceneToJson(s), "x.json", "", &back);
  ASSERT_TRUE(st.ok()) << st.message();
  EXPECT_EQ(SceneToJson(back), SceneToJson(s));
  EXPECT_EQ(back.sensor.edge_rays_per_pixel, 64);
}

// The camera pipeline (docs/simulator.md, "Camera pipeline and sensor profiles").

// A wall of reflectance `r` filling a w x h view under uniform light of 1 (radiance r), with
// exposure = full well, so that the linear signal s is r; no noise.
Scene FlatWall(double reflectance, int w = 16, int h = 12) {
  Scene s = BaseScene(CameraModel::Pinhole(20, w, h));
  s.sensor.exposure = 10000;
  s.sensor.full_well = 10000;
  SceneObject wall;
  wall.name = "wall";
  wall.size = Eigen::Vector3d(20, 20, 0);
  wall.material.reflectance = reflectance;
  s.objects.push_back(wall);
  s.views.push_back(View{"v", LookDown(1)});
  return s;
}

cv::Mat Exposed(const Scene& s) {
  auto r = Make(s);
  if (!r) return cv::Mat();
  return r->Expose(r->RenderRadianceFor(0, s.sensor), 0);
}

TEST(CameraPipeline, FlatPatchesFollowTheResponseCurve) {
  struct Case {
    const char* response;
    int bits, signal_bits;
    double black;
    int dn_grey, dn_white;  // at s = 0.2 and 0.8, worked out by hand (docs/simulator.md)
  };
  const Case cases[] = {
      {"linear", 8, 0, 0, 51, 204},           {"srgb", 8, 0, 0, 124, 231},
      {"gamma:2.2", 8, 0, 0, 123, 230},       {"gamma:2.2", 16, 0, 0, 31533, 59214},
      {"srgb", 16, 12, 256, 2116, 3735},      {"linear", 16, 12, 256, 1024, 3327},
      {"linear", 8, 0, 16, 16 + 48, 16 + 191}};
  for (const Case& c : cases) {
    for (const auto& [r, want] : {std::pair{0.2, c.dn_grey}, std::pair{0.8, c.dn_white}}) {
      Scene s = FlatWall(r);
      s.sensor.response = c.response;
      s.sensor.bits = c.bits;
      s.sensor.signal_bits = c.signal_bits;
      s.sensor.black_level = c.black;
      const std::string what = std::string(c.response) + ", " + std::to_string(c.bits) +
                               " bits, black " + std::to_string(c.black) + ", s " +
                               std::to_string(r);
      auto ren = Make(s);
      ASSERT_TRUE(ren) << what;
      const cv::Mat radiance = ren->RenderRadiance(0);
      ASSERT_NEAR(radiance.at<float>(6, 8), r, 1e-6) << what;
      const cv::Mat img = ren->Expose(radiance, 0);
      ASSERT_EQ(img.type(), c.bits == 16 ? CV_16UC1 : CV_8UC1) << what;
      double lo, hi;
      cv::minMaxLoc(img, &lo, &hi);
      EXPECT_EQ(lo, want) << what;
      EXPECT_EQ(hi, want) << what;
      // The same as DN = black + FromLinear(s) * (white - black).
      Response response;
      ASSERT_TRUE(Response::Parse(c.response, &response).ok());
      const double white = (1 << (c.signal_bits ? c.signal_bits : c.bits)) - 1;
      EXPECT_NEAR(want, c.black + response.FromLinear(r) * (white - c.black), 0.5) << what;
      // Over-exposed: the white level.
      s.sensor.exposure = 2 * s.sensor.full_well / r;
      cv::minMaxLoc(Exposed(s), &lo, &hi);
      EXPECT_EQ(lo, white) << what;
      EXPECT_EQ(hi, white) << what;
    }
  }
}

TEST(CameraPipeline, TwelveSignalBitsNeverExceedTheirWhiteLevel) {
  for (double black : {0.0, 256.0}) {
    Scene s = FlatWall(0.995, 64, 48);
    s.sensor.bits = 16;
    s.sensor.signal_bits = 12;
    s.sensor.black_level = black;
    s.sensor.shot_noise = true;
    s.sensor.read_noise = 8;
    double lo, hi;
    // Near saturation, noise pushes about a third of the pixels to the white level, none beyond.
    const cv::Mat img = Exposed(s);
    cv::minMaxLoc(img, &lo, &hi);
    EXPECT_EQ(hi, 4095) << black;
    EXPECT_GT(lo, black + 0.9 * (4095 - black)) << black;
    EXPECT_GT(cv::countNonZero(img == 4095), static_cast<int>(img.total() / 10)) << black;
    // A quarter of the well: black + 0.25 * (4095 - black) on average.
    s.objects[0].material.reflectance = 0.25;
    const cv::Scalar mean = cv::mean(Exposed(s));
    EXPECT_NEAR(mean[0], black + 0.25 * (4095 - black), 1.0) << black;
  }
  // The limit is signal_bits': all 16 bits saturate at 65535.
  Scene s = FlatWall(1.0);
  s.sensor.bits = 16;
  s.sensor.exposure = 20000;
  double lo, hi;
  cv::minMaxLoc(Exposed(s), &lo, &hi);
  EXPECT_EQ(lo, 65535);
  EXPECT_EQ(hi, 65535);
}

TEST(CameraPipeline, BlackLevelOffsetsABlackArea) {
  for (const char* response : {"linear", "srgb"}) {
    Scene s = FlatWall(0, 64, 48);  // black: no light
    s.sensor.response = response;
    s.sensor.bits = 16;
    s.sensor.signal_bits = 12;
    s.sensor.black_level = 256;
    double lo, hi;
    cv::minMaxLoc(Exposed(s), &lo, &hi);
    EXPECT_EQ(lo, 256) << response;
    EXPECT_EQ(hi, 256) << response;
    s.sensor.bits = 8;
    s.sensor.signal_bits = 0;
    s.sensor.black_level = 16;
    cv::minMaxLoc(Exposed(s), &lo, &hi);
    EXPECT_EQ(lo, 16) << response;
    EXPECT_EQ(hi, 16) << response;
    // Read noise of 20 electrons (7.7 DN at 12 bits). A linear (raw) frame keeps it on both
    // sides of the black level, as a raw sensor does: mean 256, spread 7.7 DN. An encoded one
    // (sRGB) cannot go below black: the noise clipped there lifts its mean.
    s.sensor.bits = 16;
    s.sensor.signal_bits = 12;
    s.sensor.black_level = 256;
    s.sensor.read_noise = 20;
    const cv::Mat img = Exposed(s);
    cv::minMaxLoc(img, &lo, &hi);
    EXPECT_GT(hi, 256) << response;
    cv::Scalar mean, sd;
    cv::meanStdDev(img, mean, sd);
    if (std::string(response) == "linear") {
      EXPECT_LT(lo, 256 - 2 * 7.7);
      EXPECT_NEAR(mean[0], 256, 0.3);
      EXPECT_NEAR(sd[0], std::sqrt(7.68 * 7.68 + 1.0 / 12), 0.3);
    } else {
      EXPECT_EQ(lo, 256) << response;
      EXPECT_GT(mean[0], 256 + 1) << response;
    }
  }
}

TEST(CameraPipeline, BayerMosaicCarriesTheChannelGainsInItsPattern) {
  // A grey wall at 0.6 of the well: red pixels 0.6 * 0.55, green 0.6, blue 0.6 * 0.75 of 65535.
  const int kRed = 21627, kGreen = 39321, kBlue = 29491;
  struct Case {
    const char* pattern;
    int at[4];  // pixels (0, 0), (1, 0), (0, 1), (1, 1) as (x, y)
    int code;   // OpenCV's demosaicing for it (the detector's, photometric.h)
  };
  const Case cases[] = {
      {"RGGB", {kRed, kGreen, kGreen, kBlue}, cv::COLOR_BayerRGGB2BGR},
      {"BGGR", {kBlue, kGreen, kGreen, kRed}, cv::COLOR_BayerBGGR2BGR},
      {"GRBG", {kGreen, kRed, kBlue, kGreen}, cv::COLOR_BayerGRBG2BGR},
      {"GBRG", {kGreen, kBlue, kRed, kGreen}, cv::COLOR_BayerGBRG2BGR},
  };
  for (const Case& c : cases) {
    Scene s = FlatWall(0.6, 32, 24);
    s.sensor.bits = 16;
    s.sensor.bayer = c.pattern;
    const cv::Mat img = Exposed(s);
    ASSERT_EQ(img.type(), CV_16UC1) << c.pattern;
    for (int y0 : {0, 10})
      for (int x0 : {0, 6}) {
        EXPECT_EQ(img.at<uint16_t>(y0, x0), c.at[0]) << c.pattern;
        EXPECT_EQ(img.at<uint16_t>(y0, x0 + 1), c.at[1]) << c.pattern;
        EXPECT_EQ(img.at<uint16_t>(y0 + 1, x0), c.at[2]) << c.pattern;
        EXPECT_EQ(img.at<uint16_t>(y0 + 1, x0 + 1), c.at[3]) << c.pattern;
      }
    // OpenCV's demosaicing for that pattern name recovers each channel's level.
    cv::Mat bgr;
    cv::cvtColor(img, bgr, c.code);
    const cv::Scalar m = cv::mean(bgr(cv::Rect(4, 4, 24, 16)));
    EXPECT_NEAR(m[0], kBlue, 2) << c.pattern;
    EXPECT_NEAR(m[1], kGreen, 2) << c.pattern;
    EXPECT_NEAR(m[2], kRed, 2) << c.pattern;
  }
}

// A marker on a plate, sunlit, with the default noise: edges, flat areas and noise to encode.
Scene MarkerOnPlate(const std::string& profile) {
  Scene s = BaseScene(CameraModel::Pinhole(250, 160, 120));
  s.sensor.read_noise = 4;
  s.sensor.shot_noise = true;
  s.light.ambient = 0.3;
  s.light.sun = Sun{Eigen::Vector3d(0.2, 0.1, 1).normalized(), 1.0, 0.53};
  s.objects.push_back(PlateWithMarker(MarkerModel::Standard(3, 0.1, 0.02), Pose{}));
  s.views.push_back(View{"v", LookDown(1)});
  EXPECT_TRUE(ApplySensorProfile(profile, &s.sensor).ok());
  return s;
}

TEST(CameraPipeline, JpegThroughTheCodecIsCloseOnAFlatPatchAndLossy) {
  const Scene s = MarkerOnPlate("jpeg_srgb");
  ASSERT_EQ(ViewFileExtension(s.sensor), ".jpg");
  const cv::Mat exposed = Exposed(s);
  cv::Mat decoded;
  const Status st = ThroughCodec(s.sensor, exposed, &decoded);
  ASSERT_TRUE(st.ok()) << st.message();
  ASSERT_EQ(decoded.type(), CV_8UC1);
  ASSERT_EQ(decoded.size(), exposed.size());
  // The plate above the marker (its decal spans x 52-107, y 32-87): smooth but noisy.
  cv::Mat diff;
  cv::absdiff(decoded, exposed, diff);
  const cv::Rect flat(0, 0, 160, 24);
  double hi;
  cv::minMaxLoc(diff(flat), nullptr, &hi);
  if (const char* dir = std::getenv("SVMS_TEST_IMAGES")) {
    cv::imwrite(std::string(dir) + "/camera_pipeline_exposed.png", exposed);
    cv::imwrite(std::string(dir) + "/camera_pipeline_through_jpeg.png", decoded);
  }
  EXPECT_LT(cv::mean(diff(flat))[0], 2.0);
  EXPECT_LE(hi, 8);
  // A real lossy codec: many pixels change, most of all at the marker's edges.
  EXPECT_GT(cv::countNonZero(diff), static_cast<int>(diff.total() / 10));
  EXPECT_GT(cv::norm(diff(cv::Rect(50, 30, 60, 60)), cv::NORM_INF), hi);
  // Exactly the pixels a reader of the written file decodes.
  static const svms_testing::ScratchDir dir("svms_render_test");
  const std::string file = dir.File("v" + ViewFileExtension(s.sensor));
  ASSERT_TRUE(WriteImage(file, exposed, ViewImageEncoding(s.sensor)).ok());
  cv::Mat read;
  ImageHeader header;
  ASSERT_TRUE(LoadStoredImage(file, 1 << 20, &read, &header).ok());
  EXPECT_EQ(header.format, "JPEG");
  EXPECT_EQ(cv::norm(read, decoded, cv::NORM_INF), 0);
  // The quality is the sensor's: a lower one changes more.
  Sensor low = s.sensor;
  low.jpeg_quality = 20;
  cv::Mat coarse;
  ASSERT_TRUE(ThroughCodec(low, exposed, &coarse).ok());
  EXPECT_GT(cv::norm(coarse, exposed, cv::NORM_L1), 1.5 * cv::norm(decoded, exposed, cv::NORM_L1));
}

TEST(CameraPipeline, PngIsLosslessAndDeclaresItsResponse) {
  static const svms_testing::ScratchDir dir("svms_render_test_png");
  for (const auto& [profile, declared] :
       {std::pair{"linear", "linear"}, std::pair{"srgb8", "srgb"}, std::pair{"raw12", "linear"}}) {
    const Scene s = MarkerOnPlate(profile);
    ASSERT_EQ(ViewFileExtension(s.sensor), ".png");
    const cv::Mat exposed = Exposed(s);
    cv::Mat decoded;
    ASSERT_TRUE(ThroughCodec(s.sensor, exposed, &decoded).ok());
    EXPECT_EQ(cv::norm(decoded, exposed, cv::NORM_INF), 0) << profile;
    const std::string file = dir.File(std::string(profile) + ".png");
    ASSERT_TRUE(WriteImage(file, exposed, ViewImageEncoding(s.sensor)).ok()) << profile;
    cv::Mat read;
    ImageHeader header;
    ASSERT_TRUE(LoadStoredImage(file, 1 << 20, &read, &header).ok()) << profile;
    EXPECT_EQ(header.declared_response, declared) << profile;
    EXPECT_EQ(cv::norm(read, exposed, cv::NORM_INF), 0) << profile;
  }
  Sensor gamma;
  gamma.response = "gamma:2.2";
  EXPECT_EQ(ViewImageEncoding(gamma).png_response, "gamma:2.2");
  gamma.response = "sRGB";
  EXPECT_EQ(ViewImageEncoding(gamma).png_response, "srgb");
}

TEST(CameraPipeline, TruthRecordsThePhotometry) {
  for (const char* profile : {"raw12_bayer", "jpeg_srgb"}) {
    const Scene s = MarkerOnPlate(profile);
    auto r = Make(s);
    const nlohmann::json j = nlohmann::json::parse(TruthToJson(s, {ComputeTruth(*r, 0)}));
    const nlohmann::json& p = j.at("photometry");
    if (std::string(profile) == "raw12_bayer") {
      EXPECT_EQ(p.at("response"), "linear");
      EXPECT_EQ(p.at("bits"), 16);
      EXPECT_EQ(p.at("signal_bits"), 12);
      EXPECT_EQ(p.at("black_level"), 256);
      EXPECT_EQ(p.at("white_level"), 4095);
      EXPECT_EQ(p.at("bayer"), "RGGB");
      EXPECT_EQ(p.at("channel_gain"), nlohmann::json({0.55, 1.0, 0.75}));
      EXPECT_EQ(p.at("format"), "png");
      EXPECT_FALSE(p.contains("jpeg_quality"));
      EXPECT_EQ(j.at("views")[0].at("image"), "v.png");
    } else {
      EXPECT_EQ(p.at("response"), "srgb");
      EXPECT_EQ(p.at("bits"), 8);
      EXPECT_EQ(p.at("signal_bits"), 8);
      EXPECT_EQ(p.at("black_level"), 0);
      EXPECT_EQ(p.at("white_level"), 255);
      EXPECT_EQ(p.at("bayer"), "");
      EXPECT_EQ(p.at("format"), "jpeg");
      EXPECT_EQ(p.at("jpeg_quality"), 85);
      EXPECT_FALSE(p.contains("channel_gain"));
      EXPECT_EQ(j.at("views")[0].at("image"), "v.jpg");
    }
    EXPECT_EQ(j.at("bits"), p.at("bits"));  // the existing field, unchanged
  }
}

TEST(SensorProfile, EachNameSetsItsPipelineAndKeepsTheLight) {
  Sensor base;
  base.exposure = 9000;
  base.full_well = 11000;
  base.read_noise = 3;
  base.defocus_sigma_px = 0.2;
  base.rays_per_pixel = 4;
  base.response = "gamma:1.8";  // replaced by every profile
  base.black_level = 7;
  ASSERT_EQ(SensorProfileNames(),
            (std::vector<std::string>{"linear", "srgb8", "jpeg_srgb", "raw12", "raw12_bayer"}));
  struct Want {
    const char* response;
    int bits, signal_bits;
    double black;
    const char* bayer;
    const char* format;
    double defocus;
  };
  const Want wants[] = {{"linear", 8, 0, 0, "", "png", 0.2},
                        {"srgb", 8, 0, 0, "", "png", 0.7},
                        {"srgb", 8, 0, 0, "", "jpeg", 0.7},
                        {"linear", 16, 12, 256, "", "png", 0.2},
                        {"linear", 16, 12, 256, "RGGB", "png", 0.2}};
  for (size_t i = 0; i < SensorProfileNames().size(); ++i) {
    const std::string& name = SensorProfileNames()[i];
    const Want& w = wants[i];
    Sensor s = base;
    const Status st = ApplySensorProfile(name, &s);
    ASSERT_TRUE(st.ok()) << name << ": " << st.message();
    EXPECT_TRUE(CheckSensor(s).ok()) << name;
    EXPECT_EQ(s.response, w.response) << name;
    EXPECT_EQ(s.bits, w.bits) << name;
    EXPECT_EQ(s.signal_bits, w.signal_bits) << name;
    EXPECT_EQ(s.black_level, w.black) << name;
    EXPECT_EQ(s.bayer, w.bayer) << name;
    EXPECT_EQ(s.format, w.format) << name;
    EXPECT_EQ(s.jpeg_quality, 85) << name;
    EXPECT_EQ(s.defocus_sigma_px, w.defocus) << name;
    EXPECT_EQ(s.exposure, 9000) << name;
    EXPECT_EQ(s.full_well, 11000) << name;
    EXPECT_EQ(s.read_noise, 3) << name;
    EXPECT_EQ(s.rays_per_pixel, 4) << name;
  }
  // "linear" on the default sensor changes nothing.
  Scene a = FlatWall(0.5), b = a;
  ASSERT_TRUE(ApplySensorProfile("linear", &b.sensor).ok());
  EXPECT_EQ(SceneToJson(a), SceneToJson(b));
  // An unknown name: an error naming it and the choices; the sensor as it was.
  Sensor s = base;
  const Status st = ApplySensorProfile("raw14", &s);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("\"raw14\""), std::string::npos) << st.message();
  for (const std::string& name : SensorProfileNames())
    EXPECT_NE(st.message().find(name), std::string::npos) << st.message();
  EXPECT_EQ(s.response, "gamma:1.8");
  EXPECT_EQ(s.black_level, 7);
}

TEST(SceneFile, CameraPipelineRoundTripsThroughJson) {
  Scene s = FlatWall(0.5);
  // Defaults are written and read back.
  Scene back;
  ASSERT_TRUE(ParseSceneJson(SceneToJson(s), "x.json", "", &back).ok());
  EXPECT_EQ(SceneToJson(back), SceneToJson(s));
  EXPECT_EQ(back.sensor.response, "linear");
  EXPECT_EQ(back.sensor.format, "png");
  // Every field away from its default.
  s.sensor.bits = 16;
  s.sensor.response = "gamma:2.2";
  s.sensor.signal_bits = 14;
  s.sensor.black_level = 512;
  s.sensor.bayer = "GBRG";
  s.sensor.channel_gain = {0.5, 0.9, 0.6};
  Status st = ParseSceneJson(SceneToJson(s), "x.json", "", &back);
  ASSERT_TRUE(st.ok()) << st.message();
  EXPECT_EQ(SceneToJson(back), SceneToJson(s));
  EXPECT_EQ(back.sensor.bits, 16);
  EXPECT_EQ(back.sensor.response, "gamma:2.2");
  EXPECT_EQ(back.sensor.signal_bits, 14);
  EXPECT_EQ(back.sensor.black_level, 512);
  EXPECT_EQ(back.sensor.bayer, "GBRG");
  EXPECT_EQ(back.sensor.channel_gain, (std::array<double, 3>{0.5, 0.9, 0.6}));
  s.sensor = Sensor();
  s.sensor.response = "srgb";
  s.sensor.format = "jpeg";
  s.sensor.jpeg_quality = 60;
  st = ParseSceneJson(SceneToJson(s), "x.json", "", &back);
  ASSERT_TRUE(st.ok()) << st.message();
  EXPECT_EQ(SceneToJson(back), SceneToJson(s));
  EXPECT_EQ(back.sensor.format, "jpeg");
  EXPECT_EQ(back.sensor.jpeg_quality, 60);
  EXPECT_EQ(back.sensor.response, "srgb");
}

TEST(SceneFile, CameraPipelineErrorsNameTheField) {
  const std::string head = R"({"type": "svms.scene", "seed": 1,
    "camera": {"lensmodel": "LENSMODEL_PINHOLE", "intrinsics": [500, 500, 99.5, 99.5], "width": 200, "height": 200},
    "objects": [], "views": [{"name": "a", "cam_from_world": {"rvec": [0,0,0], "tvec": [0,0,1]}}],
    "sensor": {)";
  auto parse = [&](const std::string& sensor, Scene* out) {
    return ParseSceneJson(head + sensor + "}}", "s.json", "", out);
  };
  Scene s;
  {
    const Status st = parse(R"("bits": 16, "signal_bits": 12, "black_level": 256,
        "response": "sRGB", "bayer": "BGGR", "channel_gain": [0.5, 1, 0.7])",
                            &s);
    ASSERT_TRUE(st.ok()) << st.message();
    EXPECT_EQ(s.sensor.response, "srgb");  // one spelling
    EXPECT_EQ(s.sensor.white_level(), 4095);
  }
  const std::pair<std::string, std::string> bad[] = {
      {R"("signal_bits": 12)", "sensor.signal_bits: expected 0 (all of sensor.bits) or 6 to 8"},
      {R"("bits": 16, "signal_bits": 5)",
       "sensor.signal_bits: expected 0 (all of sensor.bits) "
       "or 6 to 16 (sensor.bits), got the number 5"},
      {R"("signal_bits": "12")", "sensor.signal_bits: expected an integer"},
      {R"("bits": 16, "signal_bits": 12, "black_level": 4095)",
       "sensor.black_level: expected at least 0 and below the white level 4095"},
      {R"("black_level": -1)", "sensor.black_level: expected a number in ["},
      {R"("bayer": "RGBG")",
       "sensor.bayer: expected \"\" (grey), \"RGGB\", \"BGGR\", \"GRBG\" "
       "or \"GBRG\", got the string \"RGBG\""},
      {R"("bayer": "rggb")", "sensor.bayer: expected"},
      {R"("channel_gain": [0.5, 1, 0.7])",
       "sensor.channel_gain: expected only with a Bayer mosaic"},
      {R"("bayer": "RGGB", "channel_gain": [0.5, 0, 0.7])",
       "sensor.channel_gain[1]: expected a number in (0, 10], got the number 0"},
      {R"("bayer": "RGGB", "channel_gain": [0.5, 1])",
       "sensor.channel_gain: expected an array of 3 numbers"},
      {R"("bits": 16, "format": "jpeg")",
       "sensor.format: expected \"png\" with 16 bits (a JPEG holds 8), got the string \"jpeg\""},
      {R"("format": "tiff")", "sensor.format: expected \"png\" or \"jpeg\""},
      {R"("bayer": "RGGB", "format": "jpeg")", "sensor.format: expected \"png\" for a Bayer"},
      {R"("format": "jpeg", "jpeg_quality": 0)",
       "sensor.jpeg_quality: expected 1 to 100, got the number 0"},
      {R"("format": "jpeg", "jpeg_quality": 101)", "sensor.jpeg_quality: expected 1 to 100"},
      {R"("jpeg_quality": 90)", "sensor.jpeg_quality: expected only with sensor.format \"jpeg\""},
      {R"("response": "table:/etc/passwd")",
       "sensor.response: expected \"linear\", \"srgb\" or \"gamma:G\""},
      {R"("response": "gamma:0")", "sensor.response: expected"},
      {R"("response": "log")", "sensor.response: expected"},
      {R"("response": 2.2)", "sensor.response: expected a string"},
      {R"("gain": 2)", "sensor.gain: unknown field"},
  };
  for (const auto& [sensor, want] : bad) {
    const Status st = parse(sensor, &s);
    ASSERT_FALSE(st.ok()) << sensor;
    EXPECT_EQ(st.message().rfind("s.json: ", 0), 0u) << st.message();
    EXPECT_NE(st.message().find(want), std::string::npos) << st.message();
  }
  // A scene built in code meets the same rules.
  Scene c = FlatWall(0.5);
  c.sensor.format = "jpeg";
  c.sensor.bits = 16;
  std::unique_ptr<Renderer> r;
  const Status st = Renderer::Create(c, &r);
  ASSERT_FALSE(st.ok());
  EXPECT_NE(st.message().find("sensor.format: expected \"png\" with 16 bits"), std::string::npos)
      << st.message();
}

}  // namespace
}  // namespace svms

// The SVMS detector stage by stage, so a slowdown shows where it happens: each stage's free
// function (detector.h's steps) timed alone on the inputs the previous stages give, on one
// fixed rendered 1024 x 1024 image (three markers of about 30, 60 and 120 px on a noise-
// textured plate, the earth behind, sun, shot noise; seed fixed). BM_DetectSteps runs the
// whole detector and reports its own per-step timings (DetectionStats) as counters, to check
// the stage benchmarks add up to what the pipeline spends. One core (OpenCV on one thread).
// Run: build/bin/svms_bench_detector_stages --benchmark_repetitions=9
// --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <memory>
#include <opencv2/imgproc.hpp>

#include "svms/codec/svms44.h"
#include "svms/detect/bit_sampler.h"
#include "svms/detect/corner_refine.h"
#include "svms/detect/detector.h"
#include "svms/detect/marker_pose.h"
#include "svms/detect/quads.h"
#include "svms/detect/segments.h"
#include "svms/sim/render.h"

namespace {

// The image and what every stage before the one timed produces from it.
struct Fixture {
  cv::Mat image;
  svms::CameraModel camera;
  std::vector<svms::MarkerModel> models;
  std::vector<svms::Segment> segments;
  std::vector<svms::Quad> quads;
  std::vector<svms::Detection> detections;  // the detector's output (corners refined)
  svms::DetectorOptions options;
};

const Fixture& Get() {
  cv::setNumThreads(1);  // one core: OpenCV's Sobel and Canny would otherwise use a thread pool
  static const Fixture fx = [] {
    Fixture f;
    const int w = 1024, h = 1024;
    svms::Scene s;
    s.seed = 5;
    const double focal = 0.9 * w;
    s.camera = svms::CameraModel::Pinhole(focal, w, h);
    s.light.sun = svms::Sun{Eigen::Vector3d(0.3, -0.3, 1).normalized(), 1.0, 0.53};
    s.light.ambient = 0.08;
    s.background.kind = svms::Background::Kind::kEarth;
    svms::SceneObject plate;
    plate.name = "plate";
    plate.shape = svms::SceneObject::Shape::kBox;
    plate.size = Eigen::Vector3d(3, 3, 0.02);
    plate.world_from_object.tvec = Eigen::Vector3d(0, 0, -0.01);
    plate.material.pattern.kind = svms::Pattern::Kind::kNoise;
    plate.material.pattern.period = 0.01;
    plate.material.pattern.low = 0.05;
    plate.material.pattern.high = 0.4;
    const double distance = 2.0, px_per_m = focal / distance;
    const double sizes_px[3] = {30, 60, 120}, xs[3] = {-0.3 * w, 0, 0.25 * w};
    for (int k = 0; k < 3; ++k) {
      const double size = sizes_px[k] / px_per_m;
      svms::SceneMarker m;
      m.model = svms::MarkerModel::Standard(100 + k, size, size / 4);
      m.object_from_marker.tvec = Eigen::Vector3d(xs[k] / px_per_m, 0.05 * k, 0.01);
      m.object_from_marker.rvec = Eigen::Vector3d(0, 0, 0.3 * k);
      plate.markers.push_back(m);
    }
    s.objects.push_back(plate);
    svms::Pose view;
    view.rvec = Eigen::Vector3d(M_PI, 0, 0);
    view.tvec = -(view.Rotation() * Eigen::Vector3d(0, 0, distance));
    s.views.push_back(svms::View{"v", view, std::nullopt, std::nullopt});
    s.sensor.rays_per_pixel = 4;
    std::unique_ptr<svms::Renderer> r;
    if (!svms::Renderer::Create(s, &r).ok()) std::abort();
    f.image = r->Expose(r->RenderRadiance(0), 0);
    f.camera = s.camera;
    for (const auto& m : s.objects[0].markers) f.models.push_back(m.model);
    cv::Mat gx, gy;
    f.segments = svms::FindSegments(f.image, f.options.segments, &gx, &gy);
    f.quads = svms::FindQuads(f.segments, f.options.quads, w, h);
    f.detections = svms::Detector(f.options, f.camera, f.models).Detect(f.image);
    return f;
  }();
  return fx;
}

void BM_Stage1_Segments(benchmark::State& state) {
  const Fixture& f = Get();
  cv::Mat gx, gy;
  size_t n = 0;
  for (auto _ : state) n = svms::FindSegments(f.image, f.options.segments, &gx, &gy).size();
  state.counters["segments"] = static_cast<double>(n);
}
BENCHMARK(BM_Stage1_Segments)->Unit(benchmark::kMillisecond);

void BM_Stage2_Quads(benchmark::State& state) {
  const Fixture& f = Get();
  size_t n = 0;
  for (auto _ : state)
    n = svms::FindQuads(f.segments, f.options.quads, f.image.cols, f.image.rows).size();
  state.counters["quads"] = static_cast<double>(n);
}
BENCHMARK(BM_Stage2_Quads)->Unit(benchmark::kMillisecond);

// Homography, bit sampling and decoding of every quad (the detector's steps 5-7).
void BM_Stage3_Decode(benchmark::State& state) {
  const Fixture& f = Get();
  const svms::MarkerModel unit = svms::MarkerModel::Standard(0, 1.0, 0);
  const std::vector<cv::Point2f> src{{-0.5f, 0.5f}, {0.5f, 0.5f}, {0.5f, -0.5f}, {-0.5f, -0.5f}};
  int accepted = 0;
  for (auto _ : state) {
    accepted = 0;
    for (const svms::Quad& q : f.quads) {
      if (q.completed) continue;  // step 4b's: corners fitted before they are read (detector.cc)
      std::vector<cv::Point2f> dst;
      for (const auto& p : q.corners)
        dst.emplace_back(static_cast<float>(p.x()), static_cast<float>(p.y()));
      const cv::Mat Hc = cv::getPerspectiveTransform(src, dst);
      Eigen::Matrix3d H;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) H(i, j) = Hc.at<double>(i, j);
      const svms::BitReading bits = svms::SampleBits(f.image, H, unit);
      if (bits.samples_outside > 0 || bits.white - bits.black < f.options.min_contrast) continue;
      accepted +=
          svms::Svms44::Decode(bits.word, f.options.max_corrections, f.options.id_count).accepted();
    }
  }
  state.counters["quads"] = static_cast<double>(f.quads.size());
  state.counters["decoded"] = accepted;
}
BENCHMARK(BM_Stage3_Decode)->Unit(benchmark::kMillisecond);

void BM_Stage4_Refine(benchmark::State& state) {
  const Fixture& f = Get();
  for (auto _ : state)
    for (const svms::Detection& d : f.detections)
      benchmark::DoNotOptimize(
          svms::RefineCorners(f.image, d.corners, &f.camera, f.options.refine, {}, d.black));
  state.counters["markers"] = static_cast<double>(f.detections.size());
}
BENCHMARK(BM_Stage4_Refine)->Unit(benchmark::kMicrosecond);

void BM_Stage5_Pose(benchmark::State& state) {
  const Fixture& f = Get();
  for (auto _ : state)
    for (const svms::Detection& d : f.detections)
      for (const svms::MarkerModel& m : f.models)
        if (m.id == d.id) {
          svms::MarkerPose mp;
          benchmark::DoNotOptimize(svms::EstimateMarkerPose(f.image, d.corners, m, f.camera,
                                                            d.black, d.white, f.options.pose, &mp));
        }
  state.counters["markers"] = static_cast<double>(f.detections.size());
}
BENCHMARK(BM_Stage5_Pose)->Unit(benchmark::kMicrosecond);

// The whole detector, with its own per-step timings as counters (ms per image).
void BM_DetectSteps(benchmark::State& state) {
  const Fixture& f = Get();
  const svms::Detector det(f.options, f.camera, f.models);
  svms::DetectionStats stats;
  std::array<double, svms::DetectionStats::kSteps> ms{};
  size_t found = 0;
  for (auto _ : state) {
    found = det.Detect(f.image, &stats).size();
    for (int k = 0; k < svms::DetectionStats::kSteps; ++k) ms[k] += stats.ms[k];
  }
  state.counters["markers_found"] = static_cast<double>(found);
  for (int k = 0; k < svms::DetectionStats::kSteps; ++k)
    state.counters[std::string("ms_") + svms::DetectionStats::kStepNames[k]] =
        ms[k] / state.iterations();
}
BENCHMARK(BM_DetectSteps)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();

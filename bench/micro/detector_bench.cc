// Detector speed (targets: <= 2 ms per 640x480 and <= 6 ms per 1024x1024 image, median, one
// core (OpenCV limited to one thread), three markers on a textured, noisy background, markers of
// 30 px still found). The images are rendered once by the simulator; only Detector::Detect is
// timed. Run: build/bin/svms_bench_detector --benchmark_repetitions=9
// --benchmark_report_aggregates_only=true
#include <benchmark/benchmark.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <thread>

#include "svms/detect/detector.h"
#include "svms/sim/render.h"

namespace {

using svms::Pose;

// Three markers (one about 30 px, one about 60 px, one about 120 px) on a plate with a noise
// texture, the earth behind, sun and shot noise: what the targets speak of.
struct Frame {
  cv::Mat image;
  svms::CameraModel camera;
  std::vector<svms::MarkerModel> models;
};

Frame MakeFrame(int width, int height, double read_noise_e = -1) {
  svms::Scene s;
  s.seed = 5;
  const double f = 0.9 * width;
  s.camera = svms::CameraModel::Pinhole(f, width, height);
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
  const double distance = 2.0;
  const double px_per_m = f / distance;
  const double sizes_px[3] = {30, 60, 120};
  const double xs[3] = {-0.3 * width, 0, 0.25 * width};
  for (int k = 0; k < 3; ++k) {
    const double size = sizes_px[k] / px_per_m;
    svms::SceneMarker m;
    m.model = svms::MarkerModel::Standard(100 + k, size, size / 4);
    m.object_from_marker.tvec = Eigen::Vector3d(xs[k] / px_per_m, 0.05 * k, 0.01);
    m.object_from_marker.rvec = Eigen::Vector3d(0, 0, 0.3 * k);
    plate.markers.push_back(m);
  }
  s.objects.push_back(plate);
  Pose view;
  view.rvec = Eigen::Vector3d(M_PI, 0, 0);
  view.tvec = -(view.Rotation() * Eigen::Vector3d(0, 0, distance));
  s.views.push_back(svms::View{"v", view, std::nullopt, std::nullopt});
  s.sensor.rays_per_pixel = 4;
  if (read_noise_e >= 0) s.sensor.read_noise = read_noise_e;
  std::unique_ptr<svms::Renderer> r;
  if (!svms::Renderer::Create(s, &r).ok()) std::abort();
  Frame fr;
  fr.image = r->Expose(r->RenderRadiance(0), 0);
  fr.camera = s.camera;
  for (const auto& m : s.objects[0].markers) fr.models.push_back(m.model);
  return fr;
}

void BM_Detect(benchmark::State& state) {
  cv::setNumThreads(1);  // one core: OpenCV's Sobel and Canny would otherwise use a thread pool
  const int w = static_cast<int>(state.range(0)), h = static_cast<int>(state.range(1));
  static std::map<int, Frame> frames;
  if (!frames.count(w)) frames[w] = MakeFrame(w, h);
  const Frame& fr = frames[w];
  const svms::Detector det(svms::DetectorOptions{}, fr.camera, fr.models);
  svms::DetectionStats stats;
  size_t found = 0;
  std::array<double, svms::DetectionStats::kSteps> ms{};
  for (auto _ : state) {
    const auto d = det.Detect(fr.image, &stats);
    found = d.size();
    for (int k = 0; k < svms::DetectionStats::kSteps; ++k) ms[k] += stats.ms[k];
  }
  state.counters["markers_found"] = static_cast<double>(found);
  state.counters["segments"] = stats.segments;
  state.counters["quads"] = stats.quads;
  for (int k = 0; k < svms::DetectionStats::kSteps; ++k)
    state.counters[std::string("ms_") + svms::DetectionStats::kStepNames[k]] =
        ms[k] / state.iterations();
}
BENCHMARK(BM_Detect)->Args({640, 480})->Args({1024, 1024})->Unit(benchmark::kMillisecond);

// One frame on several threads (DetectorOptions::threads, the argument): BM_Detect's 1024 x
// 1024 frame. The ratio of the 1-thread median to the 2-thread median is docs/benchmarks.md's
// figure; wall time (UseRealTime), as the other threads' work is not the caller's CPU time.
void BM_DetectThreads(benchmark::State& state) {
  cv::setNumThreads(1);
  static const Frame fr = MakeFrame(1024, 1024);
  svms::DetectorOptions options;
  options.threads = static_cast<int>(state.range(0));
  const svms::Detector det(options, fr.camera, fr.models);
  svms::DetectionStats stats;
  std::vector<svms::Detection> out;
  std::array<double, svms::DetectionStats::kSteps> ms{};
  for (auto _ : state) {
    det.Detect(fr.image, &stats, std::chrono::steady_clock::time_point::max(), &out);
    for (int k = 0; k < svms::DetectionStats::kSteps; ++k) ms[k] += stats.ms[k];
  }
  state.counters["markers_found"] = static_cast<double>(out.size());
  // Wall time per step (with 2 threads steps 5-10 are all under "decode").
  for (int k = 0; k < svms::DetectionStats::kSteps; ++k)
    state.counters[std::string("ms_") + svms::DetectionStats::kStepNames[k]] =
        ms[k] / state.iterations();
}
BENCHMARK(BM_DetectThreads)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond)->UseRealTime();

// The same frame detected by a 1-thread and a 2-thread Detector in turn, frame by frame, each
// timed on its own: on a shared machine the speed drifts by tens of percent over seconds, so
// the two medians of separate runs (BM_DetectThreads) do not compare; interleaved, both see the
// same drift. Counters: the median wall time of each (ms) and their ratio, the figure of
// docs/benchmarks.md ("on 2 threads at least 1.6x faster than on one"). The iteration's own
// time includes the rests.
void BM_DetectThreadsInterleaved(benchmark::State& state) {
  cv::setNumThreads(1);
  static const Frame fr = MakeFrame(1024, 1024);
  svms::DetectorOptions one_thread, two_threads;
  two_threads.threads = 2;
  const svms::Detector one(one_thread, fr.camera, fr.models),
      two(two_threads, fr.camera, fr.models);
  svms::DetectionStats stats;
  std::vector<svms::Detection> out;
  std::vector<double> ms1, ms2;
  const auto never = std::chrono::steady_clock::time_point::max();
  // 1 ms of rest after each frame: the 2-thread Detector's workers watch for work for 0.5 ms
  // after its frame (worker_pool.h) and must not take the core from the next 1-thread frame;
  // each 2-thread frame then starts with its workers asleep, as in a flight loop whose frames
  // come tens of milliseconds apart.
  const auto rest = std::chrono::milliseconds(1);
  for (auto _ : state) {
    auto t0 = std::chrono::steady_clock::now();
    one.Detect(fr.image, &stats, never, &out);
    auto t1 = std::chrono::steady_clock::now();
    std::this_thread::sleep_for(rest);
    auto t2 = std::chrono::steady_clock::now();
    two.Detect(fr.image, &stats, never, &out);
    auto t3 = std::chrono::steady_clock::now();
    std::this_thread::sleep_for(rest);
    ms1.push_back(std::chrono::duration<double, std::milli>(t1 - t0).count());
    ms2.push_back(std::chrono::duration<double, std::milli>(t3 - t2).count());
  }
  auto median = [](std::vector<double> v) {
    std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
    return v[v.size() / 2];
  };
  const double m1 = median(ms1), m2 = median(ms2);
  state.counters["ms_1_thread"] = m1;
  state.counters["ms_2_threads"] = m2;
  state.counters["speedup"] = m1 / m2;
}
BENCHMARK(BM_DetectThreadsInterleaved)->Unit(benchmark::kMillisecond)->UseRealTime();

// Cost against sensor noise (it must not balloon): the same 640 x 480 frame with read noise of
// 0, 60, 240 and 480 electrons RMS (full well 15,000 electrons at level 255: 0, 1, 4 and 8 grey
// levels), shot noise throughout.
void BM_DetectNoise(benchmark::State& state) {
  cv::setNumThreads(1);
  const double read_noise = static_cast<double>(state.range(0));
  static std::map<int, Frame> frames;
  const int key = static_cast<int>(state.range(0));
  if (!frames.count(key)) frames[key] = MakeFrame(640, 480, read_noise);
  const Frame& fr = frames[key];
  const svms::Detector det(svms::DetectorOptions{}, fr.camera, fr.models);
  svms::DetectionStats stats;
  size_t found = 0;
  for (auto _ : state) found = det.Detect(fr.image, &stats).size();
  state.counters["markers_found"] = static_cast<double>(found);
  state.counters["segments"] = stats.segments;
  state.counters["quads"] = stats.quads;
}
BENCHMARK(BM_DetectNoise)->Arg(0)->Arg(60)->Arg(240)->Arg(480)->Unit(benchmark::kMillisecond);

// BM_Detect's 1024 x 1024 frame with 6,000 random grey quadrilaterals of 4-40 px drawn over
// it (seeded), a few grey levels of noise on top: thousands of edges, segments and candidate
// quads, the worst case of a busy photograph.
cv::Mat Cluttered(const cv::Mat& base) {
  cv::Mat img = base.clone();
  cv::RNG rng(7);
  for (int i = 0; i < 6000; ++i) {
    const float cy = rng.uniform(0.f, 1024.f);  // y first, GCC's order: one frame everywhere
    const cv::Point2f c(rng.uniform(0.f, 1024.f), cy);
    const float r = rng.uniform(2.f, 20.f), a = rng.uniform(0.f, 6.3f);
    std::vector<cv::Point> q;
    for (int k = 0; k < 4; ++k) {
      const float t = a + k * 1.5708f + rng.uniform(-0.3f, 0.3f), rk = r * rng.uniform(0.7f, 1.3f);
      q.emplace_back(cvRound(c.x + rk * std::cos(t)), cvRound(c.y + rk * std::sin(t)));
    }
    cv::fillConvexPoly(img, q, cv::Scalar(rng.uniform(0, 256)), cv::LINE_AA);
  }
  cv::Mat noise(img.size(), CV_16S);
  rng.fill(noise, cv::RNG::NORMAL, 0, 3);
  cv::Mat out;
  img.convertTo(out, CV_16S);
  out += noise;
  out.convertTo(img, CV_8U);
  return img;
}

// The deadline as a bound: the cluttered frame (Cluttered) detected under a budget
// of B ms (the argument; 0: none). Counters: the budget, the median, 99th-percentile and longest
// frame (ms), the longest's excess over the budget (ms), the frames over 1.25 B + 1 ms, the
// share of frames that ran out of time. Wall time per frame
// is measured here, not by the library.
void BM_DetectDeadline(benchmark::State& state) {
  cv::setNumThreads(1);
  static const Frame base = MakeFrame(1024, 1024);
  static const cv::Mat image = Cluttered(base.image);
  const svms::Detector det(svms::DetectorOptions{}, base.camera, base.models);
  const double budget_ms = static_cast<double>(state.range(0));
  svms::DetectionStats stats;
  std::vector<svms::Detection> out;
  double longest = 0;
  int exceeded = 0;
  std::vector<double> frame_ms;
  frame_ms.reserve(4096);
  for (auto _ : state) {
    const auto t0 = std::chrono::steady_clock::now();
    const auto deadline =
        budget_ms > 0 ? t0 + std::chrono::microseconds(static_cast<int64_t>(budget_ms * 1000))
                      : std::chrono::steady_clock::time_point::max();
    det.Detect(image, &stats, deadline, &out);
    const double ms =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
    longest = std::max(longest, ms);
    frame_ms.push_back(ms);
    exceeded += stats.budget_exceeded;
  }
  // The median and 99th percentile beside the longest: on a shared machine the longest frame
  // is the one the scheduler took the core from.
  std::sort(frame_ms.begin(), frame_ms.end());
  state.counters["budget_ms"] = budget_ms;
  state.counters["median_ms"] = frame_ms[frame_ms.size() / 2];
  // Frames over the bound docs/benchmarks.md states, 1.25 B + 1 ms.
  state.counters["over_bound"] =
      budget_ms > 0
          ? static_cast<double>(frame_ms.end() - std::upper_bound(frame_ms.begin(), frame_ms.end(),
                                                                  1.25 * budget_ms + 1))
          : 0;
  state.counters["p99_ms"] = frame_ms[std::min(frame_ms.size() - 1, frame_ms.size() * 99 / 100)];
  state.counters["longest_ms"] = longest;
  state.counters["longest_over_budget_ms"] = budget_ms > 0 ? longest - budget_ms : 0;
  state.counters["share_exceeded"] = static_cast<double>(exceeded) / state.iterations();
  state.counters["markers_found"] = static_cast<double>(out.size());
}
BENCHMARK(BM_DetectDeadline)
    ->Arg(0)
    ->Arg(2)
    ->Arg(5)
    ->Arg(10)
    ->Arg(20)
    ->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();

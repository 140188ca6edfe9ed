#include "svms/bench/speed_benchmark.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <memory>
#include <opencv2/core/utility.hpp>
#include <random>
#include <thread>

#include "svms/bench/compare_records.h"
#include "svms/bench/report_numbers.h"
#include "svms/bench/speed_report.h"
#include "svms/detect/detector.h"
#include "svms/imageio/image_io.h"
#include "svms/peers/compare_metrics.h"
#include "svms/peers/peer_detectors.h"
#include "svms/peers/peer_tags.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/pipelines/report_file.h"
#include "svms/sim/render.h"
#include "svms/sim/truth.h"

namespace svms {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;
using Vec3 = Eigen::Vector3d;

constexpr double kMarkerSize = 0.1;  // black square, metres (the depth sets its size in pixels)
// The black square's side in pixels, head-on, cycled through over the rendered crops so that
// every size is drawn as often.
const std::vector<double> kSizesPx = {12, 14, 17, 20,  24,  30,  36, 45,
                                      55, 70, 90, 110, 140, 170, 200};
const std::vector<std::string> kFamilies = {"svms44", kTag36h11, kAruco6x6};

void Announce(const SpeedRun& run, const std::string& what) {
  std::cerr << "svms bench speed: ["
            << Cell(Ms(std::chrono::steady_clock::now() - run.start) / 1000, 0) << " s] " << what
            << "\n";
}

// The scene that renders markers into `crop`: a pinhole camera of the crop's size (f = its
// width) at the world origin looking along +z, the crop behind everything (at the radiance
// that gives back its own grey values), and `count` markers (their sizes taken in turn from
// kSizesPx from *next_size on), each on a plane just the size of its decal, tilted up to 25 deg,
// placed where it overlaps no other. Markers that find no room are counted in *not_placed.
Scene MarkerScene(const PhotoCrop& crop, const std::string& backdrop, int count, uint64_t seed,
                  size_t* next_size, int* placed, int* not_placed) {
  const int W = crop.image.cols, H = crop.image.rows;
  const double f = W;
  Scene s;
  s.seed = seed;
  s.camera = CameraModel::Pinhole(f, W, H);
  s.background.kind = Background::Kind::kImage;
  s.background.image_path = backdrop;
  // Radiance r gives DN = r * exposure / full_well * 255: this brightness gives back the crop.
  s.background.brightness = s.sensor.full_well / s.sensor.exposure;
  s.light.sun = Sun{Vec3(0.25, -0.35, -1).normalized(), 1.0, 0.53};
  s.light.ambient = 0.15;
  s.views.push_back(View{"v", Pose{}});
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u01(0, 1);
  std::vector<std::array<double, 3>> taken;  // centre x, y and half-width (px) of each decal
  std::vector<double> sizes;
  for (int k = 0; k < count; ++k) sizes.push_back(kSizesPx[(*next_size)++ % kSizesPx.size()]);
  std::sort(sizes.rbegin(), sizes.rend());  // the large ones first, while there is room
  for (double px : sizes) {
    // The decal (2 sides wide) turned by `roll`: its half-width on the image axes, with room
    // for the tilt's perspective.
    const double roll = 2 * M_PI * u01(rng);
    const double tilt = 25 * M_PI / 180 * u01(rng), az = 2 * M_PI * u01(rng);
    const double half = 1.12 * px * (std::abs(std::cos(roll)) + std::abs(std::sin(roll)));
    bool ok = false;
    double cx = 0, cy = 0;
    for (int attempt = 0; attempt < 200 && !ok && 2 * half + 4 < std::min(W, H); ++attempt) {
      cx = half + 2 + u01(rng) * (W - 2 * half - 4);
      cy = half + 2 + u01(rng) * (H - 2 * half - 4);
      ok = true;
      for (const auto& t : taken)
        if (std::abs(cx - t[0]) < half + t[2] + 4 && std::abs(cy - t[1]) < half + t[2] + 4)
          ok = false;
    }
    if (!ok) {
      ++*not_placed;
      continue;
    }
    taken.push_back({cx, cy, half});
    ++*placed;
    const double z = f * kMarkerSize / px;
    const Vec3 centre(z * (cx - (W - 1) / 2.0) / f, z * (cy - (H - 1) / 2.0) / f, z);
    // Object z (the marker's normal) toward the camera: a half turn about x, then the tilt
    // about an axis in the marker plane, and the roll about the normal.
    const Eigen::Matrix3d R =
        Eigen::AngleAxisd(tilt, Vec3(std::cos(az), std::sin(az), 0)).toRotationMatrix() *
        Eigen::AngleAxisd(M_PI, Vec3::UnitX()).toRotationMatrix() *
        Eigen::AngleAxisd(roll, Vec3::UnitZ()).toRotationMatrix();
    SceneObject plane;
    plane.name = "m" + std::to_string(taken.size());
    plane.shape = SceneObject::Shape::kPlane;
    SceneMarker m;
    m.model =
        MarkerModel::Standard(static_cast<int>(rng() % 32768), kMarkerSize, 0.25 * kMarkerSize);
    plane.size = Vec3(2 * m.model.half_extent(), 2 * m.model.half_extent(), 0);
    plane.world_from_object = Pose::FromRotation(R, centre);
    plane.material.reflectance = 0.5;
    plane.markers.push_back(m);
    s.objects.push_back(plane);
  }
  return s;
}

// One crop's rendered images (svms44, tag36h11, aruco6x6) and their truths.
struct Rendered {
  std::array<cv::Mat, 3> image;
  std::array<ViewTruth, 3> truth;
  bool ok = false;
};

// Renders the markers of `scene` in each family (views of one crop) on up to `threads` threads.
Rendered RenderFamilies(const Scene& scene, int threads, std::string* error) {
  Rendered out;
  std::array<std::string, 3> errors;
  std::atomic<int> next{0};
  std::vector<std::thread> pool;
  for (int t = 0; t < std::min(3, std::max(1, threads)); ++t)
    pool.emplace_back([&] {
      for (int k; (k = next++) < 3;) {
        Scene fam;
        if (Status s = PeerScene(scene, kFamilies[k], &fam); !s) {
          errors[k] = s.message();
          continue;
        }
        std::unique_ptr<Renderer> r;
        if (Status s = Renderer::Create(fam, &r); !s) {
          errors[k] = s.message();
          continue;
        }
        out.image[k] = r->Expose(r->RenderRadianceFor(0, r->scene().sensor), 0);
        out.truth[k] = ComputeTruth(*r, 0);
      }
    });
  for (auto& t : pool) t.join();
  for (const std::string& e : errors)
    if (!e.empty()) {
      *error = e;
      return out;
    }
  out.ok = true;
  return out;
}

// The timed systems: svms (its whole family, like the peers, no camera, no models: detection
// and corners) with its defaults, with steps 1-4 on a 2x decimated image (as AprilTag's
// decimate 2) and with its defaults on two threads per frame (DetectorOptions::threads), then
// the standard peers.
struct Systems {
  std::vector<std::unique_ptr<Detector>> svms;  // "svms", "svms_d2", "svms_t2"
  std::vector<std::unique_ptr<PeerDetector>> peers;
  std::vector<std::string> names;  // the svms configurations first, then the peers
};

Systems MakeSystems(SpeedRun* run) {
  Systems sys;
  for (const int decimate : {1, 2}) {
    DetectorOptions o;
    o.known_ids_only = false;
    o.decimate = decimate;
    sys.svms.push_back(std::make_unique<Detector>(o, CameraModel{}, std::vector<MarkerModel>{}));
    const std::string name = decimate == 1 ? "svms" : "svms_d" + std::to_string(decimate);
    sys.names.push_back(name);
    run->settings.push_back(
        {{"name", name},
         {"family", "svms44"},
         {"library", "svms::Detector (this repository)"},
         {"id_count", o.id_count},
         {"known_ids_only", false},
         {"camera", "none (no undistortion, no pose)"},
         {"other_options", decimate == 1 ? "DetectorOptions defaults"
                                         : "DetectorOptions defaults, decimate " +
                                               std::to_string(decimate) + " (steps 1-4)"}});
  }
  {
    DetectorOptions o;
    o.known_ids_only = false;
    o.threads = 2;
    sys.svms.push_back(std::make_unique<Detector>(o, CameraModel{}, std::vector<MarkerModel>{}));
    sys.names.push_back("svms_t2");
    run->settings.push_back({{"name", "svms_t2"},
                             {"family", "svms44"},
                             {"library", "svms::Detector (this repository)"},
                             {"id_count", o.id_count},
                             {"known_ids_only", false},
                             {"camera", "none (no undistortion, no pose)"},
                             {"other_options",
                              "DetectorOptions defaults, threads 2 (one frame "
                              "shared by two threads)"}});
  }
  for (const PeerDetectorConfig& c : StandardPeerConfigs()) {
    sys.peers.push_back(std::make_unique<PeerDetector>(c));
    sys.names.push_back(c.name);
    json j = json::parse(c.DescribeJson());
    j["pose"] = "none (detection and corners only)";
    run->settings.push_back(j);
  }
  return sys;
}

// The family index (kFamilies) whose image system `k` (Systems::names order) reads.
int FamilyOf(const Systems& sys, size_t k) {
  if (k < sys.svms.size()) return 0;
  return sys.peers[k - sys.svms.size()]->config().family() == kTag36h11 ? 1 : 2;
}

// Runs system `k` (or svms with its defaults under `budget_ms` > 0) on `img` and times the call.
std::vector<FoundMarker> RunOne(const Systems& sys, size_t k, double budget_ms, const cv::Mat& img,
                                SpeedRecord* rec) {
  std::vector<FoundMarker> found;
  const auto t0 = std::chrono::steady_clock::now();
  if (k < sys.svms.size()) {
    DetectionStats stats;
    const Detector& det = *sys.svms[k];
    const std::vector<Detection> dets =
        budget_ms > 0
            ? det.Detect(img, &stats,
                         t0 + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                                  std::chrono::duration<double, std::milli>(budget_ms)))
            : det.Detect(img, &stats);
    rec->ms = Ms(std::chrono::steady_clock::now() - t0);
    rec->budget_exceeded = stats.budget_exceeded;
    rec->step_ms = stats.ms;
    for (const Detection& d : dets)
      found.push_back(
          FoundMarker{d.id, d.corners, std::nullopt, false, std::nullopt, std::nullopt, 0});
  } else {
    const std::vector<PeerDetection> dets = sys.peers[k - sys.svms.size()]->Detect(img);
    rec->ms = Ms(std::chrono::steady_clock::now() - t0);
    for (const PeerDetection& d : dets)
      found.push_back(
          FoundMarker{d.id, d.corners, std::nullopt, false, std::nullopt, std::nullopt, 0});
  }
  return found;
}

// Every system, and svms under each budget, on one image of class `cls` (markers: each system
// on its own family's image), in an order rotated by `turn`; the records into *run.
void TimeImage(const Systems& sys, const std::string& cls, const std::string& name,
               const std::string& source, const std::array<const cv::Mat*, 3>& images,
               const std::array<const ViewTruth*, 3>& truths, size_t turn, SpeedRun* run) {
  struct Job {
    size_t k;
    double budget;
  };
  std::vector<Job> jobs;
  for (size_t k = 0; k < sys.names.size(); ++k) jobs.push_back({k, 0});
  for (double b : run->budgets_ms) jobs.push_back({0, b});
  std::rotate(jobs.begin(), jobs.begin() + turn % jobs.size(), jobs.end());
  for (const Job& j : jobs) {
    const int fam = FamilyOf(sys, j.k);
    SpeedRecord rec{cls, name, j.budget > 0 ? BudgetSystem(j.budget) : sys.names[j.k], source};
    const std::vector<FoundMarker> found = RunOne(sys, j.k, j.budget, *images[fam], &rec);
    const ImageOutcome io = EvaluateImage(*truths[fam], found);
    rec.detections = static_cast<int>(found.size());
    rec.false_positives = io.false_positives;
    rec.wrong_ids = io.wrong_ids;
    run->images.push_back(rec);
    if (j.budget > 0) continue;
    for (const MarkerOutcome& m : io.markers)
      run->markers.push_back(
          SpeedMarker{cls, name, rec.system, m.min_side_px, m.eligible, m.detected, m.wrong_id});
  }
}

int RunBenchmark(const SpeedBenchmarkOptions& o) {
  if (o.out.empty()) {
    std::cerr << "svms bench speed: --out DIR is required\n";
    return kExitBadInput;
  }
  SpeedRun run;
  run.start = std::chrono::steady_clock::now();
  run.budgets_ms = {5, 10};
  cv::setNumThreads(1);
  run.sources = FindPhotoSources(o.photo_root);
  int found = 0;
  for (const PhotoSource& s : run.sources) {
    std::cerr << "svms bench speed: " << s.package << " (" << s.dir << "): "
              << (s.present ? std::to_string(s.files.size()) + " photographs"
                            : std::string("missing (not installed: scripts/install_bench_photos)"))
              << "\n";
    found += static_cast<int>(s.files.size());
  }
  if (found == 0) {
    std::cerr << "svms bench speed: no photographs found: install plasma-workspace-wallpapers, "
                 "ukui-wallpapers or opencv-doc (scripts/install_bench_photos)\n";
    return kExitBadInput;
  }
  const fs::path dir(o.out);
  std::error_code ec;
  fs::create_directories(dir / "backdrops", ec);
  if (ec) {
    std::cerr << "svms bench speed: " << dir.string() << ": cannot create: " << ec.message()
              << "\n";
    return kExitBadInput;
  }
  if (o.save_images) fs::create_directories(dir / "images", ec);
  Systems sys = MakeSystems(&run);
  run.systems = sys.names;
  const std::vector<cv::Size> sizes = {{1024, 1024}, {640, 480}};
  size_t next_size = 0, turn = 0;
  bool warm_1024 = false, warm_640 = false;
  for (const PhotoSource& src : run.sources) {
    const size_t n = o.quick ? std::min<size_t>(2, src.files.size()) : src.files.size();
    for (size_t p = 0; p < n; ++p) {
      std::vector<PhotoCrop> crops;
      if (Status s = CutCrops(src.files[p], src.package, sizes, o.quick ? 1 : o.crops_per_size,
                              o.seed, &crops);
          !s) {
        std::cerr << "svms bench speed: " << s.message() << "\n";
        run.photo_failures.push_back(s.message());
        continue;
      }
      if (crops.empty()) continue;  // smaller than 640 x 480
      ++run.photos_used;
      Announce(run, src.package + ": " + fs::path(src.files[p]).string() + ": " +
                        std::to_string(crops.size()) + " crops");
      for (const PhotoCrop& c : crops) {
        const bool big = c.image.cols == 1024;
        const std::string size_name = big ? "1024" : "640";
        bool& warm = big ? warm_1024 : warm_640;
        // The markers rendered into the crop (before any timing: rendering uses every thread).
        const fs::path backdrop = dir / "backdrops" / (c.name + ".png");
        Rendered r;
        if (Status s = WriteImage(backdrop.string(), c.image); !s) {
          std::cerr << "svms bench speed: " << s.message() << "\n";
          ++run.render_failures;
        } else {
          const Scene scene =
              MarkerScene(c, fs::absolute(backdrop).string(), big ? 4 : 2, o.seed * 100003 + turn,
                          &next_size, &run.markers_placed, &run.markers_not_placed);
          std::string error;
          r = RenderFamilies(scene, o.threads, &error);
          if (!r.ok) {
            std::cerr << "svms bench speed: " << c.name << ": " << error << "\n";
            ++run.render_failures;
          }
        }
        if (!o.save_images) fs::remove(backdrop, ec);
        const ViewTruth none;
        if (!warm) {  // every system once on an image of this size, untimed
          SpeedRecord scratch;
          for (size_t k = 0; k < sys.names.size(); ++k) RunOne(sys, k, 0, c.image, &scratch);
          warm = true;
        }
        TimeImage(sys, "photo_" + size_name, c.name, c.package, {&c.image, &c.image, &c.image},
                  {&none, &none, &none}, turn++, &run);
        if (r.ok) {
          TimeImage(sys, "markers_" + size_name, c.name, c.package,
                    {&r.image[0], &r.image[1], &r.image[2]},
                    {&r.truth[0], &r.truth[1], &r.truth[2]}, turn++, &run);
          if (o.save_images)
            for (int k = 0; k < 3; ++k)
              if (Status s =
                      WriteImage((dir / "images" / (c.name + "_" + kFamilies[k] + ".png")).string(),
                                 r.image[k]);
                  !s)
                NoteOutputFailure(s.message());
        }
      }
    }
  }
  fs::remove(dir / "backdrops", ec);
  if (run.photos_used == 0) {
    std::cerr << "svms bench speed: no photograph of at least 640 x 480 could be read\n";
    return kExitBadInput;
  }
  Announce(run, "tables and plots");
  return WriteSpeedReport(o, run);
}

}  // namespace

int RunSpeedBenchmark(const SpeedBenchmarkOptions& options) {
  return FinishOutputs("svms bench speed", RunBenchmark(options));
}

}  // namespace svms

#include "svms/bench/compare_benchmark.h"

#include <atomic>
#include <filesystem>
#include <iostream>
#include <memory>
#include <opencv2/core/utility.hpp>
#include <thread>

#include "svms/bench/compare_records.h"
#include "svms/bench/compare_report.h"
#include "svms/bench/report_numbers.h"
#include "svms/datasets/datasets.h"
#include "svms/detect/detector.h"
#include "svms/geometry/pose.h"
#include "svms/imageio/image_io.h"
#include "svms/marker/model_io.h"
#include "svms/peers/peer_detectors.h"
#include "svms/peers/peer_pose.h"
#include "svms/peers/peer_tags.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/pipelines/report_file.h"
#include "svms/sim/render.h"
#include "svms/sim/truth.h"

namespace svms {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// One configuration under test: the SVMS detector, or a peer detector.
struct System {
  std::string name, family;
  std::unique_ptr<Detector> svms;  // built per scene (it takes the camera and the models)
  std::unique_ptr<PeerDetector> peer;
  json settings;
};

// Runs `sys` on `img`: its markers with poses, and the time (detection + pose, one core).
std::vector<FoundMarker> Run(const System& sys, const cv::Mat& img, const CameraModel& camera,
                             double marker_size, double* ms) {
  std::vector<FoundMarker> out;
  const auto t0 = std::chrono::steady_clock::now();
  if (sys.svms) {
    for (const Detection& d : sys.svms->Detect(img)) {
      out.push_back(FoundMarker{d.id, d.corners, d.cam_from_marker, d.pose_ambiguous,
                                d.cam_from_marker ? std::optional(d.covariance) : std::nullopt,
                                d.alternative_pose, d.alternative_weight});
    }
  } else {
    for (const PeerDetection& d : sys.peer->Detect(img)) {
      FoundMarker f{d.id, d.corners, std::nullopt, false, std::nullopt, std::nullopt, 0};
      Pose p;
      if (marker_size > 0 && PeerPose(camera, d.corners, marker_size, &p)) f.cam_from_marker = p;
      out.push_back(f);
    }
  }
  *ms = Ms(std::chrono::steady_clock::now() - t0);
  return out;
}

// Renders views [begin, end) of `r` on `threads` threads.
std::vector<cv::Mat> RenderBatch(const Renderer& r, int begin, int end, int threads) {
  std::vector<cv::Mat> imgs(end - begin);
  std::vector<std::thread> pool;
  std::atomic<int> next{begin};
  for (int t = 0; t < std::max(1, threads); ++t)
    pool.emplace_back([&] {
      for (int v; (v = next++) < end;)
        imgs[v - begin] = r.Expose(r.RenderRadianceFor(v, r.scene().sensor), v);
    });
  for (auto& t : pool) t.join();
  return imgs;
}

// "[12 s] what" on stderr: the time since `start`.
void Announce(std::chrono::steady_clock::time_point start, const std::string& what) {
  std::cerr << "[" << Cell(Ms(std::chrono::steady_clock::now() - start) / 1000, 0) << " s] " << what
            << "\n";
}

// SVMS (decoding its whole family, like the peers) and the standard peer configurations, each
// with every setting for summary.json.
std::vector<System> MakeSystems(const DetectorOptions& svms_options) {
  std::vector<System> systems;
  {
    System s;
    s.name = "svms";
    s.family = "svms44";
    s.settings = {{"name", "svms"},
                  {"family", "svms44"},
                  {"library", "svms::Detector (this repository)"},
                  {"id_count", svms_options.id_count},
                  {"known_ids_only", false},
                  {"max_corrections", svms_options.max_corrections},
                  {"max_unsupported_corrections", svms_options.max_unsupported_corrections},
                  {"min_contrast", svms_options.min_contrast},
                  {"refine_corners", svms_options.refine_corners},
                  {"equalize_rings", svms_options.equalize_rings},
                  {"deconvolve_rings", svms_options.deconvolve_rings},
                  {"pose", "svms::Detector's own (corners + post tip)"},
                  {"other_options", "DetectorOptions defaults"}};
    systems.push_back(std::move(s));
  }
  for (const PeerDetectorConfig& c : StandardPeerConfigs()) {
    System s;
    s.name = c.name;
    s.family = c.family();
    s.peer = std::make_unique<PeerDetector>(c);
    s.settings = json::parse(c.DescribeJson());
    s.settings["pose"] = "cv::solvePnP SOLVEPNP_IPPE_SQUARE on the 4 corners, undistorted by mrcal";
    systems.push_back(std::move(s));
  }
  return systems;
}

// The four sweeps, each rendered once per family; every system of that family on each view.
// False when a scene file could not be written.
bool RunSweeps(const CompareBenchmarkOptions& o, const fs::path& dir,
               const DetectorOptions& svms_options, std::vector<System>& systems, CompareRun* run) {
  const std::vector<std::string> families = {"svms44", kTag36h11, kAruco6x6};
  std::error_code ec;
  for (const CompareSweep& sw : run->sweeps) {
    for (const std::string& fam : families) {
      Scene scene;
      if (Status s = PeerScene(sw.scene, fam, &scene); !s) {
        std::cerr << "svms bench compare: " << s.message() << "\n";
        return false;
      }
      const fs::path scene_file = dir / "scenes" / (sw.name + "_" + fam + ".json");
      if (Status s = WriteTextFile(scene_file.string(), SceneToJson(scene)); !s) {
        std::cerr << "svms bench compare: " << s.message() << "\n";
        return false;
      }
      std::unique_ptr<Renderer> r;
      if (Status s = Renderer::Create(scene, &r); !s) {
        std::cerr << "svms bench compare: " << scene_file.string() << ": " << s.message() << "\n";
        ++run->failures;
        continue;
      }
      std::vector<MarkerModel> models;
      for (const SceneObject& ob : scene.objects)
        for (const SceneMarker& m : ob.markers) models.push_back(m.model);
      for (System& sys : systems)
        if (sys.family == fam && sys.name == "svms")
          sys.svms = std::make_unique<Detector>(svms_options, scene.camera, models);
      const int n = static_cast<int>(scene.views.size());
      Announce(run->start, sw.name + " / " + fam + ": " + std::to_string(n) + " views");
      const int batch = std::max(2, 4 * o.threads);
      for (int b = 0; b < n; b += batch) {
        const int e = std::min(n, b + batch);
        const std::vector<cv::Mat> imgs = RenderBatch(*r, b, e, o.threads);
        for (int v = b; v < e; ++v) {
          const ViewTruth truth = ComputeTruth(*r, v);
          if (o.save_images) {
            const fs::path idir = dir / "images" / (sw.name + "_" + fam);
            fs::create_directories(idir, ec);
            if (Status w =
                    WriteImage((idir / (scene.views[v].name + ".png")).string(), imgs[v - b]);
                !w)
              NoteOutputFailure(w.message());
          }
          for (const System& sys : systems) {
            if (sys.family != fam) continue;
            ImageRecord ir{sw.name, scene.views[v].name, sys.name};
            const auto found = Run(sys, imgs[v - b], scene.camera, run->scenes.marker_size, &ir.ms);
            const ImageOutcome io = EvaluateImage(truth, found);
            ir.detections = static_cast<int>(found.size());
            ir.false_positives = io.false_positives;
            ir.wrong_ids = io.wrong_ids;
            run->images.push_back(ir);
            for (const MarkerOutcome& m : io.markers)
              run->markers.push_back(MarkerRecord{sw.name, scene.views[v].name,
                                                  Condition(sw.name, scene.views[v].name, m),
                                                  sys.name, fam, m});
          }
        }
      }
    }
  }
  return true;
}

// Clutter: the standard clutter set (no markers), the same images for every system.
void RunClutter(const CompareBenchmarkOptions& o, const DetectorOptions& svms_options,
                std::vector<System>& systems, CompareRun* run) {
  Dataset d;
  MakeDataset("clutter", DatasetOptions{o.seed, o.quick}, &d);
  Scene& scene = d.scenes.front().second;
  scene.sensor.edge_rays_per_pixel = run->scenes.edge_rays_per_pixel;
  std::unique_ptr<Renderer> r;
  if (Status s = Renderer::Create(scene, &r); !s) {
    std::cerr << "svms bench compare: clutter: " << s.message() << "\n";
    ++run->failures;
  } else {
    for (System& sys : systems)
      if (sys.name == "svms")
        sys.svms =
            std::make_unique<Detector>(svms_options, scene.camera, std::vector<MarkerModel>{});
    const int n = static_cast<int>(scene.views.size());
    Announce(run->start, "clutter: " + std::to_string(n) + " views, every system");
    for (int b = 0; b < n; b += 4 * o.threads) {
      const int e = std::min(n, b + 4 * o.threads);
      const std::vector<cv::Mat> imgs = RenderBatch(*r, b, e, o.threads);
      for (int v = b; v < e; ++v) {
        const ViewTruth truth = ComputeTruth(*r, v);
        for (const System& sys : systems) {
          ImageRecord ir{"clutter", scene.views[v].name, sys.name};
          const auto found = Run(sys, imgs[v - b], scene.camera, 0, &ir.ms);
          const ImageOutcome io = EvaluateImage(truth, found);
          ir.detections = static_cast<int>(found.size());
          ir.false_positives = io.false_positives;
          ir.wrong_ids = io.wrong_ids;
          run->images.push_back(ir);
        }
      }
    }
  }
}

// Fig. 9: the range set (dual 0.432/0.108 m, 1024 x 1024, 0.8 to 16 m), SVMS only.
void RunFig9(const CompareBenchmarkOptions& o, CompareRun* run) {
  Dataset d;
  MakeDataset("range", DatasetOptions{o.seed, o.quick}, &d);
  Scene& scene = d.scenes.front().second;
  scene.sensor.edge_rays_per_pixel = run->scenes.edge_rays_per_pixel;
  std::unique_ptr<Renderer> r;
  if (Status s = Renderer::Create(scene, &r); !s) {
    std::cerr << "svms bench compare: range: " << s.message() << "\n";
    ++run->failures;
  } else {
    std::vector<MarkerModel> models;
    for (const SceneObject& ob : scene.objects)
      for (const SceneMarker& m : ob.markers) models.push_back(m.model);
    DetectorOptions fo;  // the recommended settings: the markers are known
    const Detector det(fo, scene.camera, models);
    const int n = static_cast<int>(scene.views.size());
    Announce(run->start, "range (Fig. 9): " + std::to_string(n) + " views");
    for (int b = 0; b < n; b += 2 * o.threads) {
      const int e = std::min(n, b + 2 * o.threads);
      const std::vector<cv::Mat> imgs = RenderBatch(*r, b, e, o.threads);
      for (int v = b; v < e; ++v) {
        const ViewTruth truth = ComputeTruth(*r, v);
        const auto dets = det.Detect(imgs[v - b]);
        Fig9Row row;
        row.view = scene.views[v].name;
        row.distance = truth.markers.front().cam_from_marker.tvec.norm();
        // The larger marker found with a pose: outer if found, else inner (both share the
        // centre, so both give the dual marker's pose).
        const Detection* best = nullptr;
        const MarkerTruth* bt = nullptr;
        for (const MarkerTruth& t : truth.markers)
          for (const Detection& dd : dets)
            if (dd.id == t.id && dd.cam_from_marker && (!bt || t.side_px > bt->side_px)) {
              best = &dd;
              bt = &t;
            }
        if (best) {
          row.used = bt->nested_in < 0 ? "outer" : "inner";
          row.range_err_mm =
              1000 * std::abs(best->cam_from_marker->tvec.norm() - bt->cam_from_marker.tvec.norm());
          row.orient_err_deg = AngleBetweenDeg(*best->cam_from_marker, bt->cam_from_marker);
        } else {
          row.used = "none";
        }
        run->fig9.push_back(row);
      }
    }
  }
}

int RunBenchmark(const CompareBenchmarkOptions& o) {
  if (o.out.empty()) {
    std::cerr << "svms bench compare: --out DIR is required\n";
    return kExitBadInput;
  }
  CompareRun run;
  run.start = std::chrono::steady_clock::now();
  cv::setNumThreads(1);
  const fs::path dir(o.out);
  std::error_code ec;
  fs::create_directories(dir / "scenes", ec);
  if (ec) {
    std::cerr << "svms bench compare: " << dir.string() << ": cannot create: " << ec.message()
              << "\n";
    return kExitBadInput;
  }
  DetectorOptions svms_options;
  svms_options.known_ids_only = false;  // like the peers: decode the whole family
  std::vector<System> systems = MakeSystems(svms_options);
  for (const System& s : systems) {
    run.names.push_back(s.name);
    run.settings.push_back(s.settings);
  }
  run.scenes.seed = o.seed;
  run.scenes.quick = o.quick;
  run.scenes.size_views = o.size_views;
  run.scenes.post_height_fraction = o.post_height;
  run.scenes.edge_rays_per_pixel = o.edge_rays;
  run.sweeps = MakeCompareSweeps(run.scenes);
  if (!RunSweeps(o, dir, svms_options, systems, &run)) return kExitFailed;
  RunClutter(o, svms_options, systems, &run);
  RunFig9(o, &run);
  Announce(run.start, "scoring and plotting");
  return WriteCompareReport(o, run);
}

}  // namespace

int RunCompareBenchmark(const CompareBenchmarkOptions& options) {
  return FinishOutputs("svms bench compare", RunBenchmark(options));
}

}  // namespace svms

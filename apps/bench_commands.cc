// The options of each benchmark of svms-bench (`svms bench NAME`), parsed into the benchmark
// library's options structs (bench/svms/bench/); the runs are the library's.
#include "bench_commands.h"

#include <memory>
#include <string>

#include "svms/bench/calibrate_benchmark.h"
#include "svms/bench/compare_benchmark.h"
#include "svms/bench/detect_benchmark.h"
#include "svms/bench/pose_benchmark.h"
#include "svms/bench/profiles_benchmark.h"
#include "svms/bench/speed_benchmark.h"
#include "svms/bench/survey_benchmark.h"
#include "svms/detect/detector.h"
#include "svms/sim/scene.h"

namespace svms::cli {

void AddBenchDetect(CLI::App& bench, int* exit_code) {
  auto o = std::make_shared<DetectBenchmarkOptions>();
  CLI::App* c = bench.add_subcommand(
      "detect",
      "Detection rate, false positives, corner and pose accuracy of the detector against the "
      "simulator's truth (range, angle, sun, occlusion, clutter and noise-free sets)");
  c->add_option("--out", o->out, "Output directory (report.md, CSV, JSON, plots)")->required();
  c->add_flag("--quick", o->quick, "A few views per set (a smoke test, about a minute)");
  c->add_option("--seed", o->seed, "Seed of the datasets and of the sensor noise")
      ->check(CLI::NonNegativeNumber);
  c->add_option("--threads", o->threads, "Views rendered and detected at once")
      ->check(CLI::Range(1, 256));
  c->add_option("--sets", o->sets, "Only these sets (default: all)")->delimiter(',');
  c->footer("Example:\n  svms bench detect --quick --out out/bench/detect");
  c->callback([o, exit_code] { *exit_code = RunDetectBenchmark(*o); });
}

void AddBenchCalibrate(CLI::App& bench, int* exit_code) {
  auto o = std::make_shared<CalibrateBenchmarkOptions>();
  CLI::App* cmd = bench.add_subcommand(
      "calibrate", "Calibration accuracy vs the true camera: svms, mrcal and OpenCV side by side");
  cmd->add_option("--out", o->out, "Output directory (data/, CSV, JSON, plots, report.md)")
      ->required();
  cmd->add_flag("--quick", o->quick, "The first 12 views only (smoke test)");
  cmd->add_option("--seed", o->seed, "Seed of the dataset's views and of the sensor noise")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  cmd->add_option("--threads", o->threads, "Rendering and detection threads")
      ->check(CLI::Range(1, 256));
  cmd->footer("Example:\n  svms bench calibrate --out out/bench/calibrate");
  cmd->callback([o, exit_code] { *exit_code = RunCalibrateBenchmark(*o); });
}

void AddBenchCompare(CLI::App& bench, int* exit_code) {
  auto o = std::make_shared<CompareBenchmarkOptions>();
  CLI::App* c = bench.add_subcommand(
      "compare", "SVMS vs AprilTag 3 (tag36h11) and OpenCV ArUco (6x6) on the same scenes");
  c->add_option("--out", o->out, "Output directory (CSV, JSON, plots, report.md)")->required();
  c->add_flag("--quick", o->quick, "A few views per sweep (smoke test, under 2 minutes)");
  c->add_option("--seed", o->seed, "Seed of every scene and of the noise")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  c->add_option("--size-views", o->size_views,
                "Views per marker size in the size sweep (more to measure rare events, such as "
                "flips at 8 px)")
      ->capture_default_str()
      ->check(CLI::Range(1, 200));
  c->add_option("--post-height", o->post_height,
                "The SVMS post's height as a fraction of the black square's side (a taller post "
                "tells a small marker's tilt better, and leaves the square sooner off-axis)")
      ->capture_default_str()
      ->check(CLI::Range(0.05, 1.0));
  c->add_option("--edge-rays", o->edge_rays,
                "Rays per pixel on edge pixels (0: off; a square number up to 4096): the "
                "rendered coverage of edge pixels, which sets every system's corner error on "
                "small markers")
      ->capture_default_str()
      ->check([](const std::string& v) -> std::string {
        Sensor sensor;
        try {
          size_t used = 0;
          sensor.edge_rays_per_pixel = std::stoi(v, &used);
          if (used != v.size()) sensor.edge_rays_per_pixel = -1;
        } catch (const std::exception&) {
          sensor.edge_rays_per_pixel = -1;
        }
        if (!ValidEdgeRays(sensor))
          return "expected 0 (off) or a square number up to 4096, got " + v;
        return "";
      });
  c->add_flag("--save-images", o->save_images,
              "Also write every rendered sweep image (DIR/images/SWEEP_FAMILY/VIEW.png)");
  c->add_option("--threads", o->threads, "Rendering threads (detectors always run on one core)")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  c->footer("Example:\n  svms bench compare --out out/bench/compare --quick");
  c->callback([o, exit_code] { *exit_code = RunCompareBenchmark(*o); });
}

void AddBenchSurvey(CLI::App& bench, int* exit_code) {
  auto o = std::make_shared<SurveyBenchmarkOptions>();
  CLI::App* cmd = bench.add_subcommand(
      "survey", "The survey on the rendered mockup vs truth, NEES Monte-Carlo, timing, baseline");
  cmd->add_option("--out", o->out, "Output directory (report.md, CSV, plots)")->required();
  cmd->add_flag("--quick", o->quick, "Quick mockup (6 views), 10 Monte-Carlo runs, 300 x 40");
  cmd->add_option("--data", o->data,
                  "A rendered mockup dataset to reuse (default: render one into OUT/mockup)");
  cmd->add_option("--runs", o->runs, "Monte-Carlo runs")->capture_default_str();
  cmd->add_option("--threads", o->threads, "Threads for rendering and detection")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  cmd->footer("Example:\n  svms bench survey --out out/bench/survey");
  cmd->callback([o, exit_code] { *exit_code = RunSurveyBenchmark(*o); });
}

void AddBenchPose(CLI::App& bench, int* exit_code) {
  auto o = std::make_shared<PoseBenchmarkOptions>();
  CLI::App* cmd = bench.add_subcommand(
      "pose",
      "Fused pose along the rendered approach: error, NEES, single vs fused, latency, soak");
  cmd->add_option("--out", o->out, "Output directory (report.md, CSV, plots)")->required();
  cmd->add_flag("--quick", o->quick, "Quick approach (12 frames) and mockup (8 views), 2 passes");
  cmd->add_option("--data", o->data, "A rendered approach dataset to reuse");
  cmd->add_option("--mockup", o->mockup, "A rendered mockup dataset to survey (reuse)");
  cmd->add_option("--layout", o->layout, "A surveyed layout to use instead of surveying");
  cmd->add_option("--camera", o->camera,
                  "Camera model for the survey and the pose (default: the dataset's true one); "
                  "its frame's rotation against the true camera's is measured and the errors are "
                  "also given in its own frame");
  cmd->add_option("--repeat", o->repeat, "Passes over the approach in the long run")
      ->check(CLI::Range(1, 1000))
      ->capture_default_str();
  cmd->add_option("--corner-sigma", o->corner_sigma_px, "Corner pixel noise for the fusion")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_option("--corner-sigma-exponent", o->corner_sigma_exponent,
                  "Corner sigma scales as (30 px / side)^this")
      ->capture_default_str();
  cmd->add_option("--variance-prior-dof", o->variance_prior_dof,
                  "Scale covariances by the frame's variance factor with this prior (0: off)")
      ->capture_default_str();
  cmd->add_option("--corner-fit-scale", o->corner_fit_scale,
                  "Corner sigma = this times the detector's line-fit sigma (default: "
                  "kCornerCovarianceScale with "
                  "--correlated-corners, else kCornerFitScale; marker_pose.h)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--corner-sigma-systematic", o->corner_sigma_systematic_px,
                  "Added in quadrature to the scaled line-fit sigma (px)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_option("--min-corner-sigma", o->min_corner_sigma_px, "No corner sigma below this (px)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  cmd->add_flag("--no-calibration-covariance", o->no_calibration_covariance,
                "Leave the camera's calibration uncertainty (CAMERA.covariance.json) out of the "
                "pose covariance");
  cmd->add_option("--profile", o->profile,
                  "Sensor profile the approach and mockup are rendered through when rendered "
                  "here (linear, srgb8, jpeg_srgb, raw12, raw12_bayer); a given --data is read "
                  "as its truth.json's photometry says");
  cmd->add_flag("--correlated-corners", o->correlated_corners,
                "Whiten each marker's corners with their joint covariance from the line fits "
                "(ObjectPoseOptions::corner_covariance_from_fit; off by default)");
  cmd->add_option("--min-tip-sigma", o->min_tip_sigma_px,
                  "No post-tip sigma below this (px; the detector's own sigma above it)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  cmd->add_flag("--size-model", o->size_model,
                "Corner sigma from the marker's size only (--corner-sigma, exponent)");
  cmd->add_flag("--no-marker-pose-with-edges", o->no_marker_pose_with_edges,
                "Where the fused pose rests on one marker, refit it from corners and tip instead "
                "of taking that marker's detector pose with its stripe and decal edges "
                "(ObjectPoseOptions::use_marker_pose_with_edges)");
  cmd->add_flag("--no-edges", o->no_edges,
                "Leave the markers' stripe and decal edges out of the fit "
                "(ObjectPoseOptions::use_edges); with --no-marker-pose-with-edges the fused pose "
                "rests on corners and tips only");
  cmd->add_flag("--rig", o->rig,
                "Also render the approach through a two-camera rig (narrow 20 deg + wide 60 deg "
                "1024 x 1024 pinholes, 0.5 m apart; OUT/rig, reused when there) and compare the "
                "rig's fused pose with each camera's alone, by range");
  cmd->add_option("--object", o->object,
                  "The dataset's object whose pose is the truth (truth.json: the approach's "
                  "'module', the range set's 'plate')")
      ->capture_default_str();
  cmd->add_option("--reference", o->reference,
                  "The marker that ties the layout's object frame to the dataset's "
                  "true_layout.json (the approach's 10, the range set's 1)")
      ->capture_default_str();
  cmd->add_option("--threads", o->threads, "Threads for rendering and the survey")
      ->check(CLI::Range(1, 256))
      ->capture_default_str();
  cmd->footer("Example:\n  svms bench pose --out out/bench/pose");
  cmd->callback([o, exit_code] { *exit_code = RunPoseBenchmark(*o); });
}

void AddBenchProfiles(CLI::App& bench, int* exit_code) {
  auto o = std::make_shared<ProfilesBenchmarkOptions>();
  CLI::App* c = bench.add_subcommand(
      "profiles", "The detector through each sensor profile's camera pipeline and codec");
  c->add_option("--out", o->out, "Output directory (report.md, summary.json, markers.csv)")
      ->required();
  c->add_flag("--quick", o->quick, "The datasets' quick subsets");
  c->add_option("--seed", o->seed, "Dataset seed")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  c->add_option("--threads", o->threads, "Views in parallel")->check(CLI::Range(1, 256));
  c->add_option("--profiles", o->profiles, "Profiles to run (default: all)")->delimiter(',');
  c->add_flag(
      "--correlated-corners", o->correlated_corners,
      "The single-marker pose takes the corners with their joint covariance from the "
      "line fits where the detector gives one (MarkerPoseOptions::corner_covariance_from_fit)");
  c->add_option("--corner-fit-scale", o->corner_fit_scale,
                "Corner sigma = this times the detector's line-fit sigma in the single-marker "
                "pose (default: kCornerCovarianceScale with --correlated-corners, else "
                "kCornerFitScale; marker_pose.h)")
      ->check(CLI::NonNegativeNumber);
  c->add_option("--decimate", o->decimate,
                "Find edges and quads on the images averaged over N x N blocks "
                "(DetectorOptions::decimate), to see what that loses on each profile")
      ->capture_default_str()
      ->check(CLI::Range(1, kMaxDecimate));
  c->footer("Example:\n  svms bench profiles --out out/bench/profiles");
  c->callback([o, exit_code] { *exit_code = RunProfilesBenchmark(*o); });
}

void AddBenchSpeed(CLI::App& bench, int* exit_code) {
  auto o = std::make_shared<SpeedBenchmarkOptions>();
  CLI::App* c = bench.add_subcommand(
      "speed",
      "Time per image of svms, AprilTag 3 and ArUco on real photographs (crops of the "
      "wallpapers and samples Debian installs), without and with markers rendered in; svms "
      "under a per-frame deadline");
  c->add_option("--out", o->out, "Output directory (report.md, summary.json, CSV, plot)")
      ->required();
  c->add_flag("--quick", o->quick,
              "Two photographs per source, one crop per size (a smoke test, under a minute)");
  c->add_option("--seed", o->seed, "Seed of the crops, the markers and the noise")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  c->add_option("--crops", o->crops_per_size, "Crops of each size per photograph")
      ->capture_default_str()
      ->check(CLI::Range(1, 100));
  c->add_option("--threads", o->threads, "Rendering threads (detectors always run on one core)")
      ->capture_default_str()
      ->check(CLI::Range(1, 64));
  c->add_option("--photo-root", o->photo_root,
                "Look for the photographs' packages under this directory instead of /");
  c->add_flag("--save-images", o->save_images,
              "Also write every image with markers (DIR/images/) and every crop (DIR/backdrops/), "
              "8 bits linear in light as the detectors read them (svms detect --response linear)");
  c->footer(
      "Photographs: plasma-workspace-wallpapers, ukui-wallpapers (scripts/install_bench_photos) "
      "and opencv-doc; the run uses those present.\nExample:\n  svms bench speed --out "
      "out/bench/speed --quick");
  c->callback([o, exit_code] { *exit_code = RunSpeedBenchmark(*o); });
}

}  // namespace svms::cli

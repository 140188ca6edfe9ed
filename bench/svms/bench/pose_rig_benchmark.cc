#include "svms/bench/pose_rig_benchmark.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <sstream>

#include "svms/base/format.h"
#include "svms/base/statistics.h"
#include "svms/bench/pose_benchmark_report.h"
#include "svms/bench/report_numbers.h"
#include "svms/bench/stored_frames.h"
#include "svms/camera/camera_rig.h"
#include "svms/datasets/datasets.h"
#include "svms/fusion/rig_pose_estimator.h"
#include "svms/marker/model_io.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/pipelines/render_scene.h"
#include "svms/pipelines/report_file.h"
#include "svms/sim/scene.h"

namespace svms {
namespace {

namespace fs = std::filesystem;

constexpr const char* kCameraNames[2] = {"narrow", "wide"};
constexpr double kFovDeg[2] = {20, 60};
constexpr int kImageSide = 1024;
constexpr double kHalfBaselineM = 0.25;  // the cameras sit at x = -0.25 m and +0.25 m
constexpr double kAimRangeM = 6;         // both look at (0, 0, 6) m in the rig frame

// The rig: each camera a pinhole of its field of view, its pose on the rig exact (no covariance),
// its model file in `dir`.
CameraRig MakeRig(const std::string& dir) {
  CameraRig rig;
  rig.name = "svms bench pose: narrow 20 deg + wide 60 deg, 0.5 m apart";
  for (int c = 0; c < 2; ++c) {
    RigCamera cam;
    cam.name = kCameraNames[c];
    cam.cameramodel_path =
        (fs::path(dir) / (std::string(kCameraNames[c]) + ".cameramodel")).string();
    cam.camera = CameraModel::Pinhole(0.5 * kImageSide / std::tan(kFovDeg[c] / 2 * M_PI / 180),
                                      kImageSide, kImageSide);
    const Eigen::Vector3d eye((c == 0 ? -1 : 1) * kHalfBaselineM, 0, 0);
    // Image rows downward: the rig's (the approach camera's) y axis.
    cam.rig_from_cam =
        LookAt(eye, Eigen::Vector3d(0, 0, kAimRangeM), Eigen::Vector3d(0, -1, 0)).Inverse();
    rig.cameras.push_back(cam);
  }
  return rig;
}

// What the rig's frames are rendered from: the approach's scene (its text) and the rig's
// constants. A rig folder is reused only when it holds the same.
nlohmann::json RigSource(const std::string& scene_text) {
  return {{"approach_scene_hash", std::to_string(std::hash<std::string>{}(scene_text))},
          {"fov_deg", {kFovDeg[0], kFovDeg[1]}},
          {"image_side", kImageSide},
          {"half_baseline_m", kHalfBaselineM},
          {"aim_range_m", kAimRangeM}};
}

}  // namespace

int PrepareRigApproach(const PoseBenchmarkOptions& o, const std::string& approach_dir,
                       RigFindings* f) {
  const std::string dir = (fs::path(o.out) / "rig").string();
  f->dir = dir;
  const std::string scene_path = approach_dir + "/scene.json";
  std::string scene_text;
  if (Status s = ReadTextFile(scene_path, &scene_text); !s) {
    std::cerr << "svms bench pose: --rig: " << scene_path
              << ": cannot read (the rig is rendered from the approach's scene; "
                 "svms dataset approach writes it)\n";
    return kExitBadInput;
  }
  const nlohmann::json source = RigSource(scene_text);
  if (fs::exists(fs::path(dir) / "port.rig")) {
    try {
      std::ifstream in(fs::path(dir) / "source.json");
      if (nlohmann::json::parse(in) == source) {
        std::cerr << "svms bench pose: reusing the rig's frames in " << dir << "\n";
        return kExitOk;
      }
    } catch (const std::exception&) {
    }
    std::cerr << "svms bench pose: " << dir << " was rendered from another approach or rig: "
              << "rendering it again\n";
  }
  Scene approach;
  if (Status s = ParseSceneJson(scene_text, scene_path, approach_dir, &approach); !s) {
    std::cerr << "svms bench pose: " << s.message() << "\n";
    return kExitBadInput;
  }
  std::error_code ec;
  fs::remove(fs::path(dir) / "port.rig", ec);  // an incomplete folder has none
  fs::create_directories(dir, ec);
  const CameraRig rig = MakeRig(dir);
  for (int c = 0; c < 2; ++c) {
    const RigCamera& cam = rig.cameras[c];
    Scene scene = approach;
    scene.camera = cam.camera;
    scene.seed = approach.seed * 1000 + 17 + c;
    const Pose cam_from_rig = cam.rig_from_cam.Inverse();
    for (View& v : scene.views) v.cam_from_world = cam_from_rig * v.cam_from_world;
    std::cerr << "svms bench pose: rendering the " << cam.name << " camera's " << scene.views.size()
              << " frames into " << dir << "/" << cam.name << "\n";
    const int rc =
        RenderScene(scene, "svms bench pose --rig", dir + "/" + cam.name, o.threads, false, true);
    if (rc != kExitOk) return rc;
    if (Status s = cam.camera.Write(cam.cameramodel_path); !s) {
      std::cerr << "svms bench pose: " << s.message() << "\n";
      return kExitFailed;
    }
  }
  // source.json, then port.rig last: a folder with port.rig is complete.
  for (Status s :
       {WriteFileAtomically((fs::path(dir) / "source.json").string(), source.dump(1) + "\n"),
        WriteRigFile(dir + "/port.rig", rig)})
    if (!s) {
      std::cerr << "svms bench pose: " << s.message() << "\n";
      return kExitFailed;
    }
  return kExitOk;
}

void RunRigApproach(const std::string& layout_path, const PoseEstimatorOptions& options,
                    const std::vector<std::pair<std::string, Pose>>& truth, RigFindings* f) {
  std::unique_ptr<RigPoseEstimator> est;
  if (Status s =
          RigPoseEstimator::CreateFromFiles(f->dir + "/port.rig", {layout_path}, options, &est);
      !s) {
    f->error = s.message();
    return;
  }
  RigFrameResult r;
  std::vector<std::pair<std::string, Pose>> one(1);
  for (size_t i = 0; i < truth.size(); ++i) {
    one[0] = truth[i];
    std::vector<cv::Mat> pair;
    for (int c = 0; c < 2; ++c)
      if (ReadStoredImages(f->dir + "/" + kCameraNames[c], one, &pair) != kExitOk) {
        f->error = "the " + std::string(kCameraNames[c]) + " camera's frame " + truth[i].first +
                   " could not be read (above)";
        return;
      }
    est->Estimate(pair, 0.1 * i, &r);
    const Pose& rig_from_object = truth[i].second;
    RigFrameRow row;
    row.name = truth[i].first;
    row.range = rig_from_object.tvec.norm();
    row.valid = r.pose.valid;
    row.markers = r.pose.markers_used;
    row.latency_ms = r.latency_ms;
    if (r.pose.valid) {
      const auto e = PoseError(rig_from_object, r.pose.cam_from_object);
      row.nees = Nees(rig_from_object, r.pose.cam_from_object, r.pose.covariance);
      row.position_mm = 1000 * e.tail<3>().norm();
      row.orientation_deg = e.head<3>().norm() * 180 / M_PI;
    }
    for (int c = 0; c < 2; ++c) {
      const ObjectPose& alone = r.cameras.at(c).pose;
      row.camera_valid[c] = alone.valid;
      row.camera_latency_ms[c] = r.cameras.at(c).latency_ms;
      row.camera_markers[c] = alone.markers_used;
      if (!alone.valid) continue;
      const auto e =
          PoseError(rig_from_object, est->rig().cameras[c].rig_from_cam * alone.cam_from_object);
      row.camera_position_mm[c] = 1000 * e.tail<3>().norm();
      row.camera_orientation_deg[c] = e.head<3>().norm() * 180 / M_PI;
    }
    f->rows.push_back(row);
    if ((i + 1) % 50 == 0)
      std::cerr << "svms bench pose: rig " << i + 1 << "/" << truth.size() << " frame pairs\n";
  }
}

std::string RigReport(const PoseBenchmarkOptions& o, const RigFindings& f,
                      double one_camera_latency_ms, nlohmann::json* summary, bool* met) {
  *met = false;
  if (!f.error.empty()) {
    *summary = {{"error", f.error}};
    return "\n### Two-camera rig (`--rig`)\n\nNot measured: " + f.error + "\n";
  }
  {
    OutputFile csv((fs::path(o.out) / "rig_frames.csv").string());
    csv << "frame,name,range_m,valid,markers,nees,position_mm,orientation_deg,narrow_valid,"
           "narrow_markers,narrow_position_mm,narrow_orientation_deg,wide_valid,wide_markers,"
           "wide_position_mm,wide_orientation_deg,latency_ms,narrow_latency_ms,wide_latency_ms\n";
    csv.precision(9);
    for (size_t i = 0; i < f.rows.size(); ++i) {
      const RigFrameRow& r = f.rows[i];
      csv << i << "," << r.name << "," << r.range << "," << r.valid << "," << r.markers << ","
          << r.nees << "," << r.position_mm << "," << r.orientation_deg;
      for (int c = 0; c < 2; ++c)
        csv << "," << r.camera_valid[c] << "," << r.camera_markers[c] << ","
            << r.camera_position_mm[c] << "," << r.camera_orientation_deg[c];
      csv << "," << r.latency_ms << "," << r.camera_latency_ms[0] << "," << r.camera_latency_ms[1]
          << "\n";
    }
  }
  std::vector<double> nees, latency;
  std::array<std::vector<double>, 2> camera_latency;
  int valid = 0;
  for (const RigFrameRow& r : f.rows) {
    latency.push_back(r.latency_ms);
    for (int c = 0; c < 2; ++c) camera_latency[c].push_back(r.camera_latency_ms[c]);
    if (!r.valid) continue;
    ++valid;
    nees.push_back(r.nees);
  }
  const double nees_mean = Mean(nees);
  const double half = NeesBandHalfWidth(nees.size());
  const bool nees_ok = !nees.empty() && std::abs(nees_mean - 6) <= half;
  const double below = nees.empty() ? 0 : std::count_if(nees.begin(), nees.end(), [](double v) {
                                            return v < 12.59;
                                          }) / static_cast<double>(nees.size());
  const double lat_median = Percentile(latency, 0.5);
  const double narrow_median = Percentile(camera_latency[0], 0.5);
  const double wide_median = Percentile(camera_latency[1], 0.5);
  const double slower = std::max(narrow_median, wide_median);
  const bool latency_ok = !latency.empty() && lat_median <= 2 * slower;

  std::ostringstream md;
  md << "\n### Two-camera rig (`--rig`)\n\n"
     << "The approach's scene seen by a rig whose frame is the approach camera's: a narrow "
        "(20 degrees across) and a wide (60 degrees) "
     << kImageSide << " x " << kImageSide
     << " pinhole at x = -0.25 m and +0.25 m, both turned toward (0, 0, 6 m), each with its own "
        "sensor noise (frames, source.json and port.rig in `"
     << f.dir
     << "`). One RigPoseEstimator per frame pair: every marker of both cameras in one "
        "rig_from_object fit; each camera's own pose (its PoseEstimator alone) carried to the rig "
        "for comparison. Targets: the rig no worse than the better camera alone at every range "
        "(RMS over the frames where both have a pose; every camera with a pose in at least half "
        "a bin's frames is compared), mean NEES in the chi-square(6) 95 % band "
        "with >= 90 % of frames below 12.59, median latency per frame pair at most 2x one "
        "camera's (the slower of the two alone: their own medians within the same calls). All "
        "on one thread, the cameras one after the other.\n\n"
     << "| measure | value | target |\n|---|---|---|\n"
     << "| frame pairs with a rig pose | " << valid << " / " << f.rows.size() << " | |\n"
     << "| mean NEES | " << Cell(nees_mean, 2) << " | [" << Fixed(6 - half, 2) << ", "
     << Fixed(6 + half, 2) << "] " << (nees_ok ? "met" : "**not met**") << " |\n"
     << "| frames with NEES below 12.59 | " << Fixed(100 * below, 1) << " % | >= 90 % "
     << (below >= 0.9 ? "met" : "**not met**") << " |\n"
     << "| latency median / 99 % per frame pair (ms) | " << Cell(lat_median, 2) << " / "
     << Cell(Percentile(latency, 0.99), 2) << " | <= " << Cell(2 * slower, 2) << " "
     << (latency_ok ? "met" : "**not met**") << " |\n"
     << "| latency median, narrow / wide alone (within the rig's calls) / the approach's own "
        "camera (one pass, above) (ms) | "
     << Cell(narrow_median, 2) << " / " << Cell(wide_median, 2) << " / "
     << Cell(one_camera_latency_ms, 2) << " | |\n\n";

  md << "| range (m) | pairs | rig valid | narrow / wide valid | orientation RMS rig / narrow "
        "/ wide (deg) | position RMS rig / narrow / wide (mm) | better camera | no worse |\n"
        "|---|---|---|---|---|---|---|---|\n";
  bool no_worse_everywhere = true;
  nlohmann::json bins = nlohmann::json::array();
  for (size_t b = 0; b + 1 < std::size(kPoseRangeEdgesM); ++b) {
    const double lo = kPoseRangeEdgesM[b], hi = kPoseRangeEdgesM[b + 1];
    int pairs = 0, rig_valid = 0;
    std::array<int, 2> cam_valid{};
    std::vector<double> rig_ori, rig_pos;
    // Per camera, over the frames where it and the rig both have a pose.
    std::array<std::vector<double>, 2> cam_ori, cam_pos, rig_ori_c, rig_pos_c;
    for (const RigFrameRow& r : f.rows) {
      if (r.range < lo || r.range >= hi) continue;
      ++pairs;
      rig_valid += r.valid;
      if (r.valid) rig_ori.push_back(r.orientation_deg), rig_pos.push_back(r.position_mm);
      for (int c = 0; c < 2; ++c) {
        cam_valid[c] += r.camera_valid[c];
        if (!r.valid || !r.camera_valid[c]) continue;
        cam_ori[c].push_back(r.camera_orientation_deg[c]);
        cam_pos[c].push_back(r.camera_position_mm[c]);
        rig_ori_c[c].push_back(r.orientation_deg);
        rig_pos_c[c].push_back(r.position_mm);
      }
    }
    if (pairs == 0) continue;
    // Each camera with a pose in at least half the bin's frames is a candidate; the rig must be
    // no worse than every candidate on the frames they share, so than the better one whichever
    // it is. The better camera shown: the one nearest the rig's position RMS on those frames.
    int best = -1;
    double best_ratio = 0;
    bool no_worse = rig_valid == pairs;
    for (int c = 0; c < 2; ++c) {
      if (2 * cam_valid[c] < pairs || cam_pos[c].empty()) continue;
      no_worse = no_worse && NoWorse(Rms(rig_ori_c[c]), Rms(cam_ori[c])) &&
                 NoWorse(Rms(rig_pos_c[c]), Rms(cam_pos[c]));
      const double ratio = Rms(cam_pos[c]) / Rms(rig_pos_c[c]);
      if (best < 0 || ratio < best_ratio) best = c, best_ratio = ratio;
    }
    no_worse = no_worse && best >= 0;
    no_worse_everywhere = no_worse_everywhere && no_worse;
    md << "| " << Fixed(lo, 1) << "-" << Fixed(hi, 1) << " | " << pairs << " | " << rig_valid
       << " | " << cam_valid[0] << " / " << cam_valid[1] << " | " << Cell(Rms(rig_ori), 4) << " / "
       << Cell(Rms(cam_ori[0]), 4) << " / " << Cell(Rms(cam_ori[1]), 4) << " | "
       << Cell(Rms(rig_pos), 3) << " / " << Cell(Rms(cam_pos[0]), 3) << " / "
       << Cell(Rms(cam_pos[1]), 3) << " | " << (best < 0 ? "-" : kCameraNames[best]) << " | "
       << (no_worse ? "yes" : "**no**") << " |\n";
    bins.push_back({{"lo_m", lo},
                    {"hi_m", hi},
                    {"pairs", pairs},
                    {"rig_valid", rig_valid},
                    {"better_camera", best < 0 ? "" : kCameraNames[best]},
                    {"no_worse", no_worse}});
  }
  md << "\nRig no worse than the better camera alone at every range: "
     << (no_worse_everywhere ? "met" : "**not met**")
     << ". The rig's RMS in the table is over all its frames; each camera's over the frames "
        "where it and the rig both have a pose, and the comparison is on those frames. "
        "Per frame: rig_frames.csv.\n";
  *met = nees_ok && below >= 0.9 && latency_ok && no_worse_everywhere;
  *summary = {{"frames", f.rows.size()},
              {"valid", valid},
              {"nees_mean", nees_mean},
              {"nees_below_12_59", below},
              {"latency_ms_median", lat_median},
              {"narrow_latency_ms_median", narrow_median},
              {"wide_latency_ms_median", wide_median},
              {"no_worse_everywhere", no_worse_everywhere},
              {"by_range", bins},
              {"targets_met", *met}};
  return md.str();
}

}  // namespace svms

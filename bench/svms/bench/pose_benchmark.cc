#include "svms/bench/pose_benchmark.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iostream>
#include <limits>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "svms/base/format.h"
#include "svms/bench/pose_benchmark_report.h"
#include "svms/bench/pose_rig_benchmark.h"
#include "svms/bench/stored_frames.h"
#include "svms/bench/truth_poses.h"
#include "svms/camera/bayer_luminance.h"
#include "svms/camera/photometric.h"
#include "svms/fusion/pose_estimator.h"
#include "svms/marker/model_io.h"
#include "svms/pipelines/dataset_run.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/pipelines/photometry.h"
#include "svms/pipelines/report_file.h"
#include "svms/pipelines/survey_run.h"

namespace svms {
namespace {

namespace fs = std::filesystem;

// Resident set size of this process, MiB.
double RssMiB() {
  std::ifstream f("/proc/self/statm");
  long pages = 0, resident = 0;
  f >> pages >> resident;
  return resident * static_cast<double>(sysconf(_SC_PAGESIZE)) / (1024.0 * 1024.0);
}

// `svms dataset NAME --out DIR`, in-process, with this run's threads and --quick.
int RenderDataset(const PoseBenchmarkOptions& o, const std::string& name, const std::string& dir) {
  std::cerr << "svms bench pose: rendering " << name << " into " << dir << "\n";
  DatasetRunOptions d;
  d.name = name, d.out = dir, d.threads = o.threads, d.quick = o.quick, d.quiet = true;
  d.profile = o.profile;
  return RunDataset(d);
}

// The approach (rendered here unless --data) into *approach, and the layout: surveyed here from
// the rendered mockup unless --layout names one, its file into *layout_path. kExitOk to go on.
int PrepareData(const PoseBenchmarkOptions& o, std::string* approach, std::string* layout_path) {
  const std::string D = o.data.empty() ? (fs::path(o.out) / "approach").string() : o.data;
  *approach = D;
  if (!o.profile.empty() && fs::exists(fs::path(D) / "truth.json"))
    std::cerr << "svms bench pose: note: " << D << " exists and is used as it was rendered; "
              << "--profile " << o.profile << " applies only to datasets rendered here\n";
  if (!fs::exists(fs::path(D) / "truth.json") && RenderDataset(o, "approach", D) != 0) {
    std::cerr << "svms bench pose: rendering the approach failed\n";
    return kExitFailed;
  }
  *layout_path = o.layout;
  if (!layout_path->empty()) return kExitOk;
  const std::string M = o.mockup.empty() ? (fs::path(o.out) / "mockup").string() : o.mockup;
  if (!fs::exists(fs::path(M) / "truth.json") && RenderDataset(o, "mockup", M) != 0) {
    std::cerr << "svms bench pose: rendering the mockup failed\n";
    return kExitFailed;
  }
  *layout_path = (fs::path(o.out) / "layout.json").string();
  const std::string survey_camera = o.camera.empty() ? M + "/true.cameramodel" : o.camera;
  SurveyRunOptions survey;
  survey.inputs = {M};
  survey.camera = survey_camera, survey.markers = M + "/markers.json";
  survey.reference = 10, survey.out = *layout_path, survey.quiet = true;
  survey.threads = o.threads;
  // The mockup's frames read as they were stored (the default rule, on linear PNGs, agrees).
  std::optional<PhotometricModel> stored;
  PhotometryOptions stored_options;
  if (Status s = ReadStoredPhotometry(M + "/truth.json", &stored, &stored_options); !s) {
    std::cerr << "svms bench pose: " << s.message() << "\n";
    return kExitBadInput;
  }
  if (stored) survey.photometry = stored_options;
  std::cerr << "svms bench pose: surveying " << M << " into " << *layout_path << "\n";
  if (RunSurveyFromImages(survey) != kExitOk) {
    std::cerr << "svms bench pose: the survey failed\n";
    return kExitFailed;
  }
  return kExitOk;
}

// The estimator's options from the benchmark's corner noise model.
PoseEstimatorOptions EstimatorOptions(const PoseBenchmarkOptions& o) {
  PoseEstimatorOptions options;
  options.fusion.corner_sigma_px = o.corner_sigma_px;
  options.fusion.corner_sigma_exponent = o.corner_sigma_exponent;
  options.fusion.variance_prior_dof = o.variance_prior_dof;
  options.fusion.corner_fit_scale = o.corner_fit_scale;
  options.fusion.min_corner_sigma_px = o.min_corner_sigma_px;
  options.fusion.corner_sigma_systematic_px = o.corner_sigma_systematic_px;
  options.fusion.corner_sigma_from_fit = !o.size_model;
  options.fusion.corner_covariance_from_fit = o.correlated_corners;
  options.fusion.min_tip_sigma_px = o.min_tip_sigma_px;
  options.fusion.use_calibration_covariance = !o.no_calibration_covariance;
  options.fusion.use_marker_pose_with_edges = !o.no_marker_pose_with_edges;
  options.fusion.use_edges = !o.no_edges;
  return options;
}

// Every view's cam_from_object in the layout's object frame: the renderer's cam_from_OBJECT
// (o.object) times OBJECT_from_object, placed through the reference marker (o.reference),
// whose pose is known in both (the survey's reference: identity in the layout; the true
// layout: the dataset object's frame). kExitOk to go on.
int ReadTruth(const PoseBenchmarkOptions& o, const std::string& D, const std::string& layout_path,
              const PoseEstimator& est, std::vector<std::pair<std::string, Pose>>* truth) {
  ModelFile truth_layout;
  for (Status s : {ReadModelFile(D + "/true_layout.json", &truth_layout),
                   ReadTruthPoses(D + "/truth.json", o.object, truth)})
    if (!s) {
      std::cerr << "svms bench pose: " << s.message() << "\n";
      return kExitBadInput;
    }
  const LayoutEntry* ref = truth_layout.layout.Find(o.reference);
  const LayoutEntry* ref_in_layout = est.layout().Find(o.reference);
  if (!ref || !ref_in_layout) {
    std::cerr << "svms bench pose: marker " << o.reference << " (the reference) is missing from "
              << (!ref ? D + "/true_layout.json" : layout_path) << "\n";
    return kExitBadInput;
  }
  const Pose module_from_object =
      ref->object_from_marker * ref_in_layout->object_from_marker.Inverse();
  for (auto& [name, pose] : *truth) pose = pose * module_from_object;
  return kExitOk;
}

// A given camera's frame against the true camera's (into f->aligned, alignment, not_aligned);
// *given_from_true the rotation between them. kExitOk to go on.
int AlignGivenCamera(const PoseBenchmarkOptions& o, const std::string& D, const PoseEstimator& est,
                     PoseFindings* f, Pose* given_from_true) {
  // A given camera's frame is its calibration's convention: rotated from the true camera's by
  // what the calibration could not tell from a shift of its principal point (frame_alignment.h).
  // The errors are reported as they are and with the truth carried into that frame. A camera
  // for another image size is bad input; a frame that cannot be aligned (no true model in the
  // dataset, a model mrcal cannot unproject) leaves those rows out, and the report says why.
  if (!o.camera.empty()) {
    CameraModel true_camera;
    Status s = CameraModel::Read(D + "/true.cameramodel", &true_camera);
    if (s) s = AlignCameraFrames(true_camera, est.camera(), {}, &f->alignment);
    if (!s && s.message().rfind("imagersize", 0) == 0) {
      std::cerr << "svms bench pose: --camera " << o.camera << " against " << D
                << "/true.cameramodel: " << s.message() << "\n";
      return kExitBadInput;
    }
    if (s) {
      f->aligned = true;
      *given_from_true = Pose::FromRotation(f->alignment.b_from_a, Eigen::Vector3d::Zero());
    } else {
      f->not_aligned = s.message();
      std::cerr << "svms bench pose: warning: the given camera's frame is not aligned to the "
                   "true one, its rows are left out: "
                << f->not_aligned << "\n";
    }
  }
  return kExitOk;
}

// Every frame once, in order, on this thread: fused pose, truth, best single marker.
void EstimateFrames(const std::vector<cv::Mat>& images,
                    const std::vector<std::pair<std::string, Pose>>& truth,
                    const PoseEstimatorOptions& options, const Pose& given_from_true,
                    PoseEstimator* est, PoseFindings* f) {
  std::vector<FrameRow>& rows = f->rows;
  FrameResult r;
  for (size_t i = 0; i < images.size(); ++i) {
    est->Estimate(images[i], 0.1 * i, &r);
    FrameRow row;
    row.name = truth[i].first;
    row.range = truth[i].second.tvec.norm();
    row.valid = r.pose.valid;
    row.markers = r.pose.markers_used;
    row.from_marker_pose = r.pose.from_marker_pose;
    row.rejected = static_cast<int>(r.pose.ids_rejected.size());
    row.latency_ms = r.latency_ms;
    row.chi2 = r.pose.chi2;
    row.dof = r.pose.dof;
    row.budget_exceeded = r.budget_exceeded;
    if (r.pose.valid) {
      row.error = PoseError(truth[i].second, r.pose.cam_from_object);
      row.sigma = r.pose.covariance.diagonal().cwiseSqrt();
      row.nees = Nees(truth[i].second, r.pose.cam_from_object, r.pose.covariance);
      row.covariance = r.pose.covariance;
      row.bias_factor = r.pose.bias_factor();
      row.position_mm = 1000 * row.error.tail<3>().norm();
      row.orientation_deg = row.error.head<3>().norm() * 180 / M_PI;
      row.range_error_mm = 1000 * (r.pose.cam_from_object.tvec.norm() - row.range);
      if (f->aligned) {
        const Pose truth_in_given = given_from_true * truth[i].second;
        const auto e = PoseError(truth_in_given, r.pose.cam_from_object);
        row.aligned_nees = Nees(truth_in_given, r.pose.cam_from_object, r.pose.covariance);
        row.aligned_position_mm = 1000 * e.tail<3>().norm();
        row.aligned_orientation_deg = e.head<3>().norm() * 180 / M_PI;
      }
      const std::vector<MarkerObservation> obs =
          ObservationsFromDetections(r.detections, est->layout());
      if (r.pose.calibration_in_covariance) {
        ObjectPoseOptions without = options.fusion;
        without.use_calibration_covariance = false;
        const ObjectPose p = SolveObjectPose(est->camera(), obs, without);
        if (p.valid)
          row.nees_without_calibration = Nees(truth[i].second, p.cam_from_object, p.covariance);
      }
      // The single marker a user would pick: the smallest predicted position sigma.
      double best = std::numeric_limits<double>::infinity();
      for (const MarkerObservation& one : obs) {
        const ObjectPose single = SolveObjectPose(est->camera(), {one}, options.fusion);
        if (!single.valid) continue;
        const double predicted = single.covariance.bottomRightCorner<3, 3>().trace();
        if (predicted < best) {
          best = predicted;
          const auto e = PoseError(truth[i].second, single.cam_from_object);
          row.single_position_mm = 1000 * e.tail<3>().norm();
          row.single_orientation_deg = e.head<3>().norm() * 180 / M_PI;
        }
      }
      // svms detect's own pose of each marker (with its stripe and decal edges where it used
      // them) moved to the object, the one with the smallest predicted position sigma (the
      // layout's covariance included): what a user of svms detect alone would have.
      double best_detect = std::numeric_limits<double>::infinity();
      for (const MarkerObservation& one : obs) {
        Pose cam_from_object;
        PoseCovariance covariance;
        if (!ObjectPoseFromMarker(one, options.fusion.use_layout_covariance, &cam_from_object,
                                  &covariance))
          continue;
        const double predicted = covariance.bottomRightCorner<3, 3>().trace();
        if (predicted < best_detect) {
          best_detect = predicted;
          const auto e = PoseError(truth[i].second, cam_from_object);
          row.detect_position_mm = 1000 * e.tail<3>().norm();
          row.detect_orientation_deg = e.head<3>().norm() * 180 / M_PI;
          row.detect_range_error_mm = 1000 * (cam_from_object.tvec.norm() - row.range);
          row.detect_edges = one.edge_points > 0;
        }
      }
    }
    rows.push_back(row);
    if ((i + 1) % 50 == 0)
      std::cerr << "svms bench pose: " << i + 1 << "/" << images.size() << " frames\n";
  }
}

// The long run: the approach again and again, latency and resident memory.
void LongRun(const PoseBenchmarkOptions& o, const std::vector<cv::Mat>& images, PoseEstimator* est,
             PoseFindings* f) {
  FrameResult r;
  std::vector<double>& latency = f->latency;
  std::vector<std::pair<size_t, double>>& rss = f->rss;
  const int passes = std::max(1, o.quick ? std::min(o.repeat, 2) : o.repeat);
  size_t frame = 0;
  rss.emplace_back(0, RssMiB());
  for (int pass = 0; pass < passes; ++pass) {
    for (size_t i = 0; i < images.size(); ++i, ++frame) {
      est->Estimate(images[i], 0.1 * frame, &r);
      latency.push_back(r.latency_ms);
      if ((frame + 1) % 100 == 0) rss.emplace_back(frame + 1, RssMiB());
    }
    std::cerr << "svms bench pose: long run " << frame << "/" << passes * images.size()
              << " frames, RSS " << Fixed(RssMiB(), 1) << " MiB\n";
  }
  rss.emplace_back(frame, RssMiB());
}

int RunBenchmark(const PoseBenchmarkOptions& o) {
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (!fs::is_directory(o.out)) {
    std::cerr << "svms bench pose: --out " << o.out << ": cannot create the directory\n";
    return kExitBadInput;
  }
  std::string D, layout_path;
  if (const int rc = PrepareData(o, &D, &layout_path); rc != kExitOk) return rc;
  // The rig's frames first (rendered with this run's threads), so that nothing measured below is
  // lost when they cannot be made.
  RigFindings rig;
  if (o.rig)
    if (const int rc = PrepareRigApproach(o, D, &rig); rc != kExitOk) return rc;
  PoseEstimatorOptions options = EstimatorOptions(o);
  std::vector<std::pair<std::string, Pose>> truth_names;
  if (Status s = ReadTruthPoses(D + "/truth.json", o.object, &truth_names); !s) {
    std::cerr << "svms bench pose: " << s.message() << "\n";
    return kExitBadInput;
  }
  std::vector<cv::Mat> images;
  PhotometryOptions unused;
  if (Status s = ReadStoredPhotometry(D + "/truth.json", &options.photometric, &unused); !s) {
    std::cerr << "svms bench pose: " << s.message() << "\n";
    return kExitBadInput;
  }
  if (const int rc = ReadStoredImages(D, truth_names, &images); rc != kExitOk) return rc;
  if (options.photometric)
    options.detector.refine.max_row_window_px = CornerRowWindowPx(*options.photometric);
  std::unique_ptr<PoseEstimator> est;
  const std::string camera_path = o.camera.empty() ? D + "/true.cameramodel" : o.camera;
  if (Status s = PoseEstimator::CreateFromFiles(camera_path, layout_path, options, &est); !s) {
    std::cerr << "svms bench pose: " << s.message() << "\n";
    return kExitBadInput;
  }
  std::vector<std::pair<std::string, Pose>> truth;
  if (const int rc = ReadTruth(o, D, layout_path, *est, &truth); rc != kExitOk) return rc;
  PoseFindings f;
  Pose given_from_true;
  if (const int rc = AlignGivenCamera(o, D, *est, &f, &given_from_true); rc != kExitOk) return rc;
  // One core: no OpenCV thread pool behind the timed calls either (the survey above is done).
  cv::setNumThreads(1);
  EstimateFrames(images, truth, options, given_from_true, est.get(), &f);
  LongRun(o, images, est.get(), &f);
  if (o.rig) {
    images.clear();
    f.rig = std::move(rig);
    RunRigApproach(layout_path, options, truth, &f.rig);
  }
  f.calibration_in_covariance =
      !o.no_calibration_covariance && est->camera().intrinsics_covariance_factor().size() > 0;
  f.lensmodel = est->camera().lensmodel();
  if (options.photometric) f.photometry = PhotometricToJson(*options.photometric);
  return WritePoseBenchmarkReport(o, f);
}

}  // namespace

int RunPoseBenchmark(const PoseBenchmarkOptions& options) {
  return FinishOutputs("svms bench pose", RunBenchmark(options));
}

}  // namespace svms

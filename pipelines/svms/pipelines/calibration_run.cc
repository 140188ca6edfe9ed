#include "svms/pipelines/calibration_run.h"

#include <algorithm>
#include <atomic>
#include <filesystem>
#include <iostream>
#include <map>
#include <mutex>
#include <set>
#include <thread>

#include "svms/base/file_io.h"
#include "svms/base/format.h"
#include "svms/calib/observations.h"
#include "svms/camera/camera_covariance.h"
#include "svms/detect/detector.h"
#include "svms/imageio/image_io.h"
#include "svms/pipelines/calibration_report.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/pipelines/gamma_refinement.h"
#include "svms/pipelines/item_failure.h"
#include "svms/pipelines/mrcal_optimization_inputs.h"
#include "svms/pipelines/output_checks.h"
#include "svms/pipelines/progress.h"

namespace svms {
namespace {

constexpr const char* kProg = "svms calibrate: ";

std::string IdList(const std::set<int>& ids, size_t max = 12) {
  std::string s;
  size_t k = 0;
  for (int id : ids) {
    if (k++ == max) return s + " ...";
    s += (s.empty() ? "" : " ") + std::to_string(id);
  }
  return s;
}

// Everything that can be checked before the first image is read: the photometry options, the
// request against the lens model, the outputs. kExitOk to go on, else the exit code.
int CheckRequest(const CalibrateRunOptions& o, Photometry* photometry) {
  if (o.images.empty()) {
    std::cerr << kProg << "no images given; expected image files, directories or globs\n";
    return kExitBadInput;
  }
  if (Status s = Photometry::Create(o.photometry, "", photometry, true); !s) {
    std::cerr << kProg << s.message() << "\n";
    return kExitBadInput;
  }
  if (Status s = CheckCalibrationRequest(o.calib.lensmodel, static_cast<int>(o.images.size()));
      !s) {
    std::cerr << kProg << "--lensmodel: " << s.message() << "\n";
    return kExitBadInput;
  }
  if (!o.out.empty()) {
    std::vector<std::string> inputs = o.images;
    inputs.push_back(o.board);
    for (const std::string& out_file : {o.out, CovarianceSidecarPath(o.out)}) {
      if (Status s = CheckNotAnInput("--out", out_file, inputs); !s) {
        std::cerr << kProg << s.message() << "\n";
        return kExitBadInput;
      }
    }
  }
  if (!o.report_dir.empty()) {
    if (Status s = PrepareOutputDirectory("--report", o.report_dir); !s) {
      std::cerr << kProg << s.message() << "\n";
      return kExitBadInput;
    }
  }
  return kExitOk;
}

// One detection pass over a list of images, each entry per image.
struct DetectionPass {
  std::vector<ViewObservations> views;  // the board's points seen (none when unreadable)
  std::vector<cv::Size> sizes;
  std::vector<std::string> errors;  // "" when the image was read
  // With --response estimate: patches across the markers' sides (response_estimate.h).
  std::vector<std::vector<EdgePatch>> patches;
};

// Detects on every image in `files`, on o.threads threads, with `camera` (empty: corners fitted
// in pixels); `what` names the pass in the progress line. Every ID is decoded (not only the
// board's), so that images of another board are named.
DetectionPass DetectBoards(const std::vector<std::string>& files, const CameraModel& camera,
                           const char* what, const CalibrateRunOptions& o,
                           const Photometry& photometry, bool collect_patches = false) {
  std::vector<MarkerModel> models;
  for (const LayoutEntry& e : o.layout.markers) models.push_back(e.marker);
  DetectorOptions dopt;
  dopt.known_ids_only = false;
  dopt.refine.max_row_window_px = photometry.CornerRowWindowPx();
  const double corner_sigma = DetectorOptions().pose.corner_sigma_px;
  const Detector detector(dopt, camera, models);
  const size_t n = files.size();
  DetectionPass pass;
  pass.views.resize(n);
  pass.errors.assign(n, "");
  pass.sizes.assign(n, cv::Size());
  pass.patches.assign(n, {});
  // With collect_patches: at most 25,000 patches in all (about 1 KB each; more do not sharpen
  // the estimate much).
  const size_t patches_per_image = std::max<size_t>(1, 25000 / std::max<size_t>(1, n));
  std::atomic<size_t> next{0};
  size_t done = 0;  // under io
  std::mutex io;
  Progress progress(std::string("svms calibrate: ") + what, n, "", !o.quiet);
  auto worker = [&] {
    for (size_t i; (i = next++) < n;) {
      cv::Mat img, stored;
      NoiseModel noise;  // a raw frame's, from its stored values (noise_model.h)
      try {
        if (Status s = photometry.Load(files[i], kDefaultMaxImagePixels, &img, nullptr,
                                       collect_patches ? &stored : nullptr, &noise);
            !s) {
          pass.errors[i] = s.message();
        } else {
          pass.sizes[i] = img.size();
          std::vector<Detection> found;
          detector.Detect(img, nullptr, std::chrono::steady_clock::time_point::max(), &found,
                          noise.valid() ? &noise : nullptr);
          pass.views[i] = ObservationsFromDetections(found, o.layout, files[i], corner_sigma);
          if (collect_patches) {
            // Evenly over the image's markers when there are more than its share (moved out
            // of a vector of its own, so that what is left out is freed now).
            std::vector<EdgePatch> all;
            CollectEdgePatches(stored, found, photometry.black_level(), photometry.white_level(),
                               &all);
            KeepEvenly(patches_per_image, &all);
            pass.patches[i].assign(std::make_move_iterator(all.begin()),
                                   std::make_move_iterator(all.end()));
          }
        }
      } catch (...) {
        pass.errors[i] = ItemFailure(files[i], std::current_exception());
      }
      std::lock_guard<std::mutex> lock(io);
      progress.Update(++done);
    }
  };
  std::vector<std::thread> pool;
  for (int t = 0; t < std::max(1, o.threads); ++t) pool.emplace_back(worker);
  for (std::thread& t : pool) t.join();
  progress.Finish();
  return pass;
}

// --response estimate: the response from the edges the first pass found, used from now on.
// kExitOk to go on.
int EstimateResponse(const DetectionPass& pass, const CalibrateRunOptions& o,
                     Photometry* photometry, CalibrateRunOutcome* out) {
  std::vector<EdgePatch> edges;
  for (const auto& p : pass.patches) edges.insert(edges.end(), p.begin(), p.end());
  out->response = EstimateGammaFromEdges(edges);
  if (out->response.patches == 0) {
    std::cerr << kProg
              << "--response estimate: too few marker sides of 20 px or more with blurred edges ("
              << edges.size() << " edge patches); expected images with larger markers, or "
              << "give --response\n";
    return kExitFailed;
  }
  if (!o.quiet)
    std::cerr << kProg << "response estimated from " << out->response.patches
              << " edge patches: gamma " << Fixed(out->response.gamma, 3) << " +- "
              << Fixed(out->response.sigma, 3) << " (asymmetry "
              << Scientific(out->response.asymmetry, 2) << "; read as linear "
              << Scientific(out->response.asymmetry_linear, 2) << ", as sRGB "
              << Scientific(out->response.asymmetry_srgb, 2) << ")\n";
  photometry->UseResponse(Response::Gamma(out->response.gamma));
  return kExitOk;
}

// The views to calibrate on: the readable images of the first image's size (the others get an
// error, printed), and a check that they show the board. kExitOk to go on.
int SelectViews(const CalibrateRunOptions& o, DetectionPass* pass, cv::Size* size,
                std::vector<ViewObservations>* views, CalibrateRunOutcome* out) {
  const size_t n = o.images.size();
  std::set<int> unknown, seen;
  for (size_t i = 0; i < n; ++i) {
    std::string& error = pass->errors[i];
    const cv::Size& s = pass->sizes[i];
    if (error.empty() && size->area() == 0) *size = s;
    if (error.empty() && s != *size) {
      error = o.images[i] + ": " + std::to_string(s.width) + "x" + std::to_string(s.height) +
              " pixels; expected " + std::to_string(size->width) + "x" +
              std::to_string(size->height) + " like the first image";
    }
    if (!error.empty()) {
      std::cerr << kProg << error << "\n";
      out->errors.push_back(error);
      continue;
    }
    for (int id : pass->views[i].unknown_ids) unknown.insert(id);
    for (const auto& p : pass->views[i].points) seen.insert(p.marker_id);
    views->push_back(pass->views[i]);
    out->image_of_view.push_back(o.images[i]);
  }
  if (views->empty()) {
    std::cerr << kProg << "none of the " << n << " images could be read\n";
    return kExitBadInput;
  }
  std::set<int> board_ids;
  for (const LayoutEntry& e : o.layout.markers) board_ids.insert(e.marker.id);
  if (seen.empty()) {
    if (!unknown.empty()) {
      std::cerr << kProg << o.board << ": the images show markers " << IdList(unknown)
                << " but none of the board's (" << IdList(board_ids)
                << "); expected the board file of the board in the images\n";
    } else {
      std::cerr << kProg << "no markers of the board " << o.board << " were found in any of the "
                << views->size() << " images; expected images of that board\n";
    }
    return kExitBadInput;
  }
  if (!unknown.empty() && !o.quiet)
    std::cerr << kProg << "note: markers " << IdList(unknown) << " are not on the board " << o.board
              << "; ignored\n";
  return kExitOk;
}

// Calibrates on `views`; with o.redetect, detects again with the first pass's lens model and
// calibrates again. Sets out->result, out->views (and pass1). kExitOk when solved.
int Solve(const CalibrateRunOptions& o, const cv::Size& size, const Photometry& photometry,
          std::vector<ViewObservations> views, CalibrateRunOutcome* out) {
  CalibrationOptions co = o.calib;
  co.width = size.width, co.height = size.height;
  co.verbose = !o.quiet;
  Status st = Calibrate(views, co, &out->result);
  if (st && o.redetect) {
    // Pass 2: the detector fits each marker side as a straight line; through a distorting lens
    // the side is curved, and lines fitted in pixels meet a little off the true corner, by an
    // amount that follows the distortion (a bias, not noise: it goes into the intrinsics).
    // Re-detect with the first pass's lens model, so the sides are fitted in the undistorted
    // plane, and calibrate again.
    if (!o.quiet)
      std::cerr << kProg << "pass 1: RMS " << out->result.rms_px
                << " px; re-detecting with that lens model\n";
    out->pass1 = out->result;
    out->pass1_views = views;
    DetectionPass again =
        DetectBoards(out->image_of_view, out->result.camera, "re-detected", o, photometry);
    for (size_t i = 0; i < again.views.size(); ++i) {
      if (!again.errors[i].empty()) {
        std::cerr << kProg << again.errors[i] << " (on re-reading)\n";
        return kExitFailed;
      }
    }
    views = std::move(again.views);
    st = Calibrate(views, co, &out->result);
  }
  out->views = views;
  for (const auto& [v, why] : out->result.skipped)
    if (!o.quiet) std::cerr << kProg << "skipped " << why << "\n";
  if (!st) {
    std::cerr << kProg << st.message() << "; no model written\n";
    return kExitFailed;
  }
  return kExitOk;
}

// With an estimated response and the edge bias fitted: the curve refined by the board's
// geometry (gamma_refinement.h). The bias is what the estimated curve's error does to every
// side; how far one unit of gamma moves them is measured on these images by detecting once more
// through a curve kGammaStep higher and taking the corners' mean move along their edge_shift
// (least squares over the inliers; a corner that moved more than kMaxMovePx found another edge
// or corner, not the curve's effect of about 0.01 px, and is left out). Optional: an image that
// cannot be read again leaves the edges' estimate in place, with the reason in refine_note.
void RefineGammaFromEdgeBias(const CalibrateRunOptions& o, Photometry* photometry,
                             CalibrateRunOutcome* out) {
  constexpr double kGammaStep = 0.05, kMaxMovePx = 0.2;
  const CalibrationResult& r = out->result;
  if (!(r.edge_bias_sigma_px > 0) || out->response.patches == 0) return;
  Photometry stepped = *photometry;
  stepped.UseResponse(Response::Gamma(out->response.gamma + kGammaStep));
  // Through the lens model the corners in out->views were detected with, so that only the
  // curve differs.
  const CameraModel detected_with = o.redetect ? out->pass1.camera : CameraModel();
  DetectionPass again = DetectBoards(out->image_of_view, detected_with,
                                     "re-detected to measure the curve's effect", o, stepped);
  double num = 0, den = 0;
  for (size_t k = 0; k < r.views.size(); ++k) {
    const int v = r.views[k];
    if (!again.errors[v].empty()) {
      out->refine_note = again.errors[v] + " (on re-reading); the edges' estimate is kept";
      std::cerr << kProg << "response not refined: " << out->refine_note << "\n";
      return;
    }
    std::map<std::pair<int, int>, Eigen::Vector2d> moved;
    for (const PointObservation& p : again.views[v].points)
      moved[{p.marker_id, p.corner}] = p.pixel;
    const std::vector<PointObservation>& points = out->views[v].points;
    for (size_t i = 0; i < points.size(); ++i) {
      const auto m = moved.find({points[i].marker_id, points[i].corner});
      if (r.outlier[k][i] || m == moved.end()) continue;
      if ((m->second - points[i].pixel).norm() > kMaxMovePx) continue;
      num += points[i].edge_shift.dot(m->second - points[i].pixel);
      den += points[i].edge_shift.squaredNorm();
    }
  }
  const double per_gamma = den > 0 ? num / den / kGammaStep : 0;
  out->edge_bias_per_gamma = per_gamma;
  const GammaRefinement g = RefineGammaByEdgeBias(out->response.gamma, out->response.sigma,
                                                  r.edge_bias_px, r.edge_bias_sigma_px, per_gamma);
  out->refine_note = g.note;
  if (!g.note.empty()) {
    if (!o.quiet) std::cerr << kProg << "response not refined: " << g.note << "\n";
    return;
  }
  out->refined_gamma = g.gamma;
  out->refined_gamma_sigma = g.sigma;
  photometry->UseResponse(Response::Gamma(g.gamma));
  if (!o.quiet)
    std::cerr << kProg << "response refined by the board's geometry: gamma " << Fixed(g.gamma, 4)
              << " +- " << Fixed(g.sigma, 4) << " (edge bias " << Fixed(r.edge_bias_px, 5)
              << " px at " << Fixed(per_gamma, 3) << " px per unit of gamma)\n";
}

// The range for the uncertainty, metres: the median board distance unless given.
double UncertaintyRange(const CalibrateRunOptions& o, const CalibrationResult& result) {
  if (o.uncertainty_range > 0) return o.uncertainty_range;
  std::vector<double> d;
  for (const Pose& p : result.cam_from_board) d.push_back(p.tvec.norm());
  std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
  return d[d.size() / 2];
}

// The report and the model with its sidecar, written as one group: a failed write (a full
// disk) leaves every earlier output as it was, and a model is never left without its report.
int WriteOutputs(const CalibrateRunOptions& o, const Photometry& photometry,
                 CalibrateRunOutcome* out) {
  AtomicFileSet files;
  if (!o.report_dir.empty()) {
    if (Status s = AddCalibrationReport(o, out->views, out, &files); !s) {
      std::cerr << kProg << "--report: " << s.message() << "; nothing written\n";
      return kExitFailed;
    }
  }
  Status written;
  if (!o.out.empty()) {
    written = AddCameraWithSidecar(o.out, out->result.camera, out->result.noise_sigma_px,
                                   static_cast<int>(out->result.views.size()), &files);
    // The model again, with mrcal's optimization_inputs (replacing the plain text just added):
    // the same camera, which mrcal's uncertainty and residual tools can also evaluate.
    if (written && o.mrcal_inputs) {
      std::string plain, with_inputs;
      MrcalInputsOptions mo;
      mo.python = o.python;
      mo.board_warp = o.calib.board_warp;
      Status s = out->result.camera.ToText(o.out, &plain);
      if (s)
        s = MrcalOptimizationInputsText(out->result, out->views, out->image_of_view, plain, mo,
                                        &with_inputs);
      if (s) {
        written = files.Add(o.out, with_inputs);
        out->has_optimization_inputs = written.ok();
      } else {
        out->optimization_inputs_note = s.message();
        // Said even with --quiet: the model lacks what mrcal's tools need.
        std::cerr << kProg << "note: " << o.out
                  << " is written without mrcal's optimization_inputs (" << s.message()
                  << "); mrcal's uncertainty tools cannot read it, " << CovarianceSidecarPath(o.out)
                  << " has the covariance\n";
      }
    }
    // A response given or estimated is stored with the camera (photometric.h), so that
    // detect, pose and survey read its images the same way.
    if (const std::optional<PhotometricModel> m = photometry.GivenModel(); written && m) {
      written = files.Add(PhotometricPath(o.out), PhotometricToJson(*m));
    } else {
      std::error_code ec;
      if (std::filesystem::exists(PhotometricPath(o.out), ec))
        std::cerr << kProg << "note: " << PhotometricPath(o.out)
                  << " (from an earlier calibration) is kept; detect, pose and survey will read "
                     "the images with it (give --response to replace it)\n";
    }
  }
  if (written) written = files.Commit();
  if (Status s = written; !s) {
    std::cerr << kProg << s.message() << "; nothing written\n";
    return kExitFailed;
  }
  return kExitOk;
}

}  // namespace

int RunCalibration(const CalibrateRunOptions& o, CalibrateRunOutcome* out) {
  *out = CalibrateRunOutcome();
  Photometry photometry;
  if (const int rc = CheckRequest(o, &photometry); rc != kExitOk) return rc;
  CalibrateRunOptions run = o;
  run.calib.edge_bias =
      o.edge_bias == CalibrateRunOptions::EdgeBias::kOn ||
      (o.edge_bias == CalibrateRunOptions::EdgeBias::kAuto && photometry.estimating());
  DetectionPass pass =
      DetectBoards(o.images, CameraModel(), "detected", o, photometry, photometry.estimating());
  if (photometry.estimating()) {
    // Every image again, with the response the first pass's edges gave.
    if (const int rc = EstimateResponse(pass, o, &photometry, out); rc != kExitOk) return rc;
    pass =
        DetectBoards(o.images, CameraModel(), "detected again with that response", o, photometry);
  }
  cv::Size size;
  std::vector<ViewObservations> views;
  if (const int rc = SelectViews(o, &pass, &size, &views, out); rc != kExitOk) return rc;
  if (const int rc = Solve(run, size, photometry, std::move(views), out); rc != kExitOk) return rc;
  RefineGammaFromEdgeBias(run, &photometry, out);
  out->uncertainty_range = UncertaintyRange(run, out->result);
  if (const int rc = WriteOutputs(run, photometry, out); rc != kExitOk) return rc;
  return out->errors.empty() ? kExitOk : kExitFailed;
}

}  // namespace svms

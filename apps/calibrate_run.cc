#include "calibrate_run.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>
#include <thread>

#include "cli_io.h"
#include "commands.h"
#include "gnuplot.h"
#include "progress.h"
#include "svms/base/file_io.h"
#include "svms/calib/observations.h"
#include "svms/camera/camera_covariance.h"
#include "svms/detect/detector.h"
#include "svms/imageio/image_io.h"

namespace svms::cli {
namespace {

namespace fs = std::filesystem;

std::string IdList(const std::set<int>& ids, size_t max = 12) {
  std::string s;
  size_t k = 0;
  for (int id : ids) {
    if (k++ == max) return s + " ...";
    s += (s.empty() ? "" : " ") + std::to_string(id);
  }
  return s;
}

// The uncertainty grid: cell centres of a 32 x 32 grid over the image.
constexpr int kGrid = 32;

// Adds the report's files to `files` (committed by the caller with the model).
Status WriteReport(const CalibrateRunOptions& o, const std::vector<ViewObservations>& views,
                   CalibrateRunOutcome* out, AtomicFileSet* files_out) {
  AtomicFileSet& files = *files_out;
  const CalibrationResult& r = out->result;
  const std::string& dir = o.report_dir;
  const int W = r.camera.width(), H = r.camera.height();
  // Residuals (inliers and outliers), vectors over the image, coverage.
  std::ostringstream res, outl;
  nlohmann::json outliers = nlohmann::json::array();
  std::vector<int> cells(16 * 16, 0);
  std::vector<double> comps;
  for (size_t v = 0; v < r.views.size(); ++v) {
    const ViewObservations& view = views[r.views[v]];
    for (size_t i = 0; i < view.points.size(); ++i) {
      const PointObservation& p = view.points[i];
      const Eigen::Vector2d& e = r.residuals[v][i];
      if (r.outlier[v][i]) {
        outl << p.pixel.x() << " " << p.pixel.y() << " " << e.x() << " " << e.y() << "\n";
        nlohmann::json oj;
        SetPath(oj, "image", out->image_of_view[r.views[v]]);
        oj.update(
            {{"marker", p.marker_id},
             {"point", p.corner == PointObservation::kTip ? std::string("tip")
                                                          : "corner " + std::to_string(p.corner)},
             {"pixel", {p.pixel.x(), p.pixel.y()}},
             {"residual_px", {e.x(), e.y()}}});
        outliers.push_back(oj);
        continue;
      }
      res << p.pixel.x() << " " << p.pixel.y() << " " << e.x() << " " << e.y() << "\n";
      comps.push_back(e.x()), comps.push_back(e.y());
      const int cx = std::clamp(static_cast<int>(16 * p.pixel.x() / W), 0, 15);
      const int cy = std::clamp(static_cast<int>(16 * p.pixel.y() / H), 0, 15);
      ++cells[cy * 16 + cx];
    }
  }
  files.Add(dir + "/residuals.dat", res.str());
  files.Add(dir + "/outliers.dat", outl.str());
  out->coverage = std::count_if(cells.begin(), cells.end(), [](int c) { return c > 0; }) / 256.0;
  {
    std::ostringstream cov;
    for (int y = 0; y < 16; ++y) {
      for (int x = 0; x < 16; ++x)
        cov << (x + 0.5) * W / 16 << " " << (y + 0.5) * H / 16 << " " << cells[y * 16 + x] << "\n";
      cov << "\n";
    }
    files.Add(dir + "/coverage.dat", cov.str());
  }
  // Histogram of residual components.
  double lim = 0;
  for (double c : comps) lim = std::max(lim, std::abs(c));
  lim = std::max(lim, 1e-3);
  const int bins = 41;
  std::vector<int> hist(bins, 0);
  for (double c : comps)
    ++hist[std::clamp(static_cast<int>((c + lim) / (2 * lim) * bins), 0, bins - 1)];
  {
    std::ostringstream h;
    for (int b = 0; b < bins; ++b) {
      const double x = -lim + (b + 0.5) * 2 * lim / bins;
      const double gauss = comps.size() * (2 * lim / bins) / (std::sqrt(2 * M_PI) * r.sigma_px) *
                           std::exp(-0.5 * x * x / (r.sigma_px * r.sigma_px));
      h << x << " " << hist[b] << " " << gauss << "\n";
    }
    files.Add(dir + "/histogram.dat", h.str());
  }
  // Uncertainty over the image.
  double u2 = 0, umax = 0;
  int un = 0;
  {
    std::ostringstream u;
    for (int y = 0; y < kGrid; ++y) {
      for (int x = 0; x < kGrid; ++x) {
        const Eigen::Vector2d px((x + 0.5) * W / kGrid - 0.5, (y + 0.5) * H / kGrid - 0.5);
        Eigen::Matrix2d C;
        double s = NAN;
        if (ProjectionCovariance(r, px, out->uncertainty_range, &C)) {
          s = std::sqrt(C.trace());
          u2 += s * s, umax = std::max(umax, s), ++un;
        }
        u << px.x() << " " << px.y() << " " << s << "\n";
      }
      u << "\n";
    }
    files.Add(dir + "/uncertainty.dat", u.str());
  }
  out->uncertainty_rms = un > 0 ? std::sqrt(u2 / un) : NAN;
  out->uncertainty_max = umax;

  const double scale = 0.05 * W / std::max(r.worst_px, 1e-6);  // longest arrow: 5 % of the width
  char buf[4096];
  std::vector<std::pair<std::string, std::string>> plots;
  std::snprintf(buf, sizeof buf,
                "set title 'Residuals (inliers), sigma %.3f px'\nset xlabel 'residual component "
                "(px)'\nset ylabel 'count'\nset style fill solid 0.5\nset grid\n"
                "plot 'histogram.dat' u 1:2 w boxes t 'x and y components', '' u 1:3 w l lw 2 t "
                "'Gaussian of that sigma'",
                r.sigma_px);
  plots.emplace_back("residual_histogram", buf);
  std::snprintf(buf, sizeof buf,
                "set title 'Residual vectors over the image (x %.0f), outliers in red'\nset "
                "xrange [0:%d]\nset yrange [%d:0]\nset size ratio -1\nset grid\n"
                "plot 'residuals.dat' u 1:2:($3*%g):($4*%g) w vectors lc rgb '#3060c0' nohead t "
                "'inliers', 'outliers.dat' u 1:2 w p pt 7 ps 0.6 lc rgb 'red' t 'outliers'",
                scale, W, H, scale, scale);
  plots.emplace_back("residual_vectors", buf);
  std::snprintf(buf, sizeof buf,
                "set title 'Coverage: observed points per cell (%.0f %% of cells)'\nset xrange "
                "[0:%d]\nset yrange [%d:0]\nset size ratio -1\nset view map\nset palette "
                "defined (0 'white', 1 '#c0d0f0', 10 '#3060c0', 40 '#102060')\n"
                "plot 'coverage.dat' u 1:2:3 w image t '', 'residuals.dat' u 1:2 w dots lc rgb "
                "'black' t ''",
                100 * out->coverage, W, H);
  plots.emplace_back("coverage", buf);
  std::snprintf(buf, sizeof buf,
                "set title 'Projection uncertainty at %.2f m: sqrt(trace) px'\nset xrange "
                "[0:%d]\nset yrange [%d:0]\nset size ratio -1\nset view map\nset cblabel "
                "'px'\nplot 'uncertainty.dat' u 1:2:3 w image t '', 'residuals.dat' u 1:2 w dots "
                "lc rgb 'white' t ''",
                out->uncertainty_range, W, H);
  plots.emplace_back("uncertainty", buf);
  for (const auto& [name, body] : plots)
    if (Status s = Gnuplot(dir, name, body, "900,700", &files); !s) return s;

  nlohmann::json j;
  j["camera"] = {{"lensmodel", r.camera.lensmodel()},
                 {"intrinsics", r.camera.intrinsics()},
                 {"imagersize", {W, H}}};
  if (!o.out.empty()) SetPath(j["camera"], "file", o.out);
  SetPath(j, "board", o.board);
  j["images"] = out->image_of_view.size();
  j["views_used"] = r.views.size();
  nlohmann::json skipped = nlohmann::json::array();
  for (const auto& [v, why] : r.skipped) skipped.push_back(why);
  j["views_skipped"] = skipped;
  j["image_errors"] = out->errors;
  j["points"] = {{"inliers", r.num_inliers}, {"outliers", r.num_outliers}};
  j["residuals_px"] = {{"rms", r.rms_px}, {"worst", r.worst_px}, {"sigma", r.sigma_px}};
  j["outliers"] = outliers;
  j["coverage"] = {{"cells_16x16_fraction", out->coverage}};
  j["uncertainty"] = {{"range_m", out->uncertainty_range},
                      {"what", "sqrt(trace(Var(q))) over a 32x32 grid, px"},
                      {"rms_px", out->uncertainty_rms},
                      {"max_px", out->uncertainty_max}};
  if (o.calib.board_warp) j["board_warp_m"] = {r.warp.x(), r.warp.y()};
  j["noise_sigma_px"] = r.noise_sigma_px;
  if (out->response.profiles > 0)
    j["response_estimate"] = {{"gamma", out->response.gamma},
                              {"sigma", out->response.sigma},
                              {"edge_profiles", out->response.profiles},
                              {"asymmetry", out->response.asymmetry},
                              {"asymmetry_as_linear", out->response.asymmetry_linear},
                              {"asymmetry_as_srgb", out->response.asymmetry_srgb}};
  if (o.redetect)
    j["pass1"] = {{"what", "corners fitted in pixels, before re-detection with the lens model"},
                  {"rms_px", out->pass1.rms_px},
                  {"noise_sigma_px", out->pass1.noise_sigma_px}};
  j["solver"] = {
      {"iterations", r.iterations}, {"outlier_rounds", r.outlier_rounds}, {"final", r.report}};
  return files.Add(dir + "/summary.json", DumpJson(j, 2) + "\n");
}

}  // namespace

int RunCalibration(const CalibrateRunOptions& o, CalibrateRunOutcome* out) {
  *out = CalibrateRunOutcome();
  const char* prog = "svms calibrate: ";
  if (o.images.empty()) {
    std::cerr << prog << "no images given; expected image files, directories or globs\n";
    return kExitBadInput;
  }
  // Everything that can be checked is checked before the first image is read.
  Photometry photometry;
  if (Status s = Photometry::Create(o.photometry, "", &photometry, true); !s) {
    std::cerr << prog << s.message() << "\n";
    return kExitBadInput;
  }
  if (Status s = CheckCalibrationRequest(o.calib.lensmodel, static_cast<int>(o.images.size()));
      !s) {
    std::cerr << prog << "--lensmodel: " << s.message() << "\n";
    return kExitBadInput;
  }
  if (!o.out.empty()) {
    std::vector<std::string> inputs = o.images;
    inputs.push_back(o.board);
    for (const std::string& out_file : {o.out, CovarianceSidecarPath(o.out)}) {
      if (Status s = CheckNotAnInput("--out", out_file, inputs); !s) {
        std::cerr << prog << s.message() << "\n";
        return kExitBadInput;
      }
    }
  }
  if (!o.report_dir.empty()) {
    if (Status s = PrepareOutputDirectory("--report", o.report_dir); !s) {
      std::cerr << prog << s.message() << "\n";
      return kExitBadInput;
    }
  }
  std::vector<MarkerModel> models;
  for (const LayoutEntry& e : o.layout.markers) models.push_back(e.marker);
  // Every ID is decoded (not only the board's), so that images of another board are named.
  DetectorOptions dopt;
  dopt.known_ids_only = false;
  const double corner_sigma = DetectorOptions().pose.corner_sigma_px;

  // Detects on every image in `files`, in parallel, with `camera` (empty: corners fitted in
  // pixels). Unreadable images get an error and no observations.
  std::vector<cv::Size> sizes;
  std::vector<std::string> errors;
  // With --response estimate: profiles across the markers' sides, per image (response_estimate.h).
  std::vector<std::vector<EdgeProfile>> profiles;
  auto detect_all = [&](const std::vector<std::string>& files, const CameraModel& camera,
                        const char* what) {
    const Detector detector(dopt, camera, models);
    const size_t n = files.size();
    std::vector<ViewObservations> all(n);
    errors.assign(n, "");
    sizes.assign(n, cv::Size());
    profiles.assign(n, {});
    std::atomic<size_t> next{0};
    size_t done = 0;  // under io
    std::mutex io;
    Progress progress(std::string("svms calibrate: ") + what, n, "", !o.quiet);
    auto worker = [&] {
      for (size_t i; (i = next++) < n;) {
        cv::Mat img, stored;
        try {
          if (Status s = photometry.Load(files[i], kDefaultMaxImagePixels, &img, nullptr,
                                         photometry.estimating() ? &stored : nullptr);
              !s) {
            errors[i] = s.message();
          } else {
            sizes[i] = img.size();
            const std::vector<Detection> found = detector.Detect(img);
            all[i] = ObservationsFromDetections(found, o.layout, files[i], corner_sigma);
            if (photometry.estimating())
              CollectEdgeProfiles(stored, found, photometry.black_level(), photometry.white_level(),
                                  &profiles[i]);
          }
        } catch (...) {
          errors[i] = ItemFailure(files[i], std::current_exception());
        }
        std::lock_guard<std::mutex> lock(io);
        progress.Update(++done);
      }
    };
    std::vector<std::thread> pool;
    for (int t = 0; t < std::max(1, o.threads); ++t) pool.emplace_back(worker);
    for (std::thread& t : pool) t.join();
    progress.Finish();
    return all;
  };
  const size_t n = o.images.size();
  std::vector<ViewObservations> all = detect_all(o.images, CameraModel(), "detected");
  if (photometry.estimating()) {
    // The response from the edges the first pass found, then every image again with it.
    std::vector<EdgeProfile> edges;
    for (const auto& p : profiles) edges.insert(edges.end(), p.begin(), p.end());
    out->response = EstimateGammaFromEdges(edges);
    if (out->response.profiles == 0) {
      std::cerr << prog << "--response estimate: too few marker sides of 12 px or more ("
                << edges.size() << " edge profiles); expected images with larger markers, or "
                << "give --response\n";
      return kExitFailed;
    }
    char line[256];
    std::snprintf(line, sizeof line,
                  "response estimated from %d edge profiles: gamma %.3f +- %.3f (asymmetry "
                  "%.2e; read as linear %.2e, as sRGB %.2e)",
                  out->response.profiles, out->response.gamma, out->response.sigma,
                  out->response.asymmetry, out->response.asymmetry_linear,
                  out->response.asymmetry_srgb);
    if (!o.quiet) std::cerr << prog << line << "\n";
    photometry.UseResponse(Response::Gamma(out->response.gamma));
    all = detect_all(o.images, CameraModel(), "detected again with that response");
  }

  // One image size; every image must have it.
  cv::Size size;
  std::vector<ViewObservations> views;
  std::set<int> unknown, seen;
  for (size_t i = 0; i < n; ++i) {
    if (errors[i].empty() && size.area() == 0) size = sizes[i];
    if (errors[i].empty() && sizes[i] != size) {
      errors[i] = o.images[i] + ": " + std::to_string(sizes[i].width) + "x" +
                  std::to_string(sizes[i].height) + " pixels; expected " +
                  std::to_string(size.width) + "x" + std::to_string(size.height) +
                  " like the first image";
    }
    if (!errors[i].empty()) {
      std::cerr << prog << errors[i] << "\n";
      out->errors.push_back(errors[i]);
      continue;
    }
    for (int id : all[i].unknown_ids) unknown.insert(id);
    for (const auto& p : all[i].points) seen.insert(p.marker_id);
    views.push_back(all[i]);
    out->image_of_view.push_back(o.images[i]);
  }
  if (views.empty()) {
    std::cerr << prog << "none of the " << n << " images could be read\n";
    return kExitBadInput;
  }
  std::set<int> board_ids;
  for (const LayoutEntry& e : o.layout.markers) board_ids.insert(e.marker.id);
  if (seen.empty()) {
    if (!unknown.empty()) {
      std::cerr << prog << o.board << ": the images show markers " << IdList(unknown)
                << " but none of the board's (" << IdList(board_ids)
                << "); expected the board file of the board in the images\n";
    } else {
      std::cerr << prog << "no markers of the board " << o.board << " were found in any of the "
                << views.size() << " images; expected images of that board\n";
    }
    return kExitBadInput;
  }
  if (!unknown.empty() && !o.quiet)
    std::cerr << prog << "note: markers " << IdList(unknown) << " are not on the board " << o.board
              << "; ignored\n";

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
      std::cerr << prog << "pass 1: RMS " << out->result.rms_px
                << " px; re-detecting with that lens model\n";
    out->pass1 = out->result;
    out->pass1_views = views;
    std::vector<ViewObservations> again =
        detect_all(out->image_of_view, out->result.camera, "re-detected");
    for (size_t i = 0; i < again.size(); ++i) {
      if (!errors[i].empty()) {
        std::cerr << prog << errors[i] << " (on re-reading)\n";
        return kExitFailed;
      }
    }
    views = std::move(again);
    st = Calibrate(views, co, &out->result);
  }
  out->views = views;
  for (const auto& [v, why] : out->result.skipped)
    if (!o.quiet) std::cerr << prog << "skipped " << why << "\n";
  if (!st) {
    std::cerr << prog << st.message() << "; no model written\n";
    return kExitFailed;
  }
  // The range for the uncertainty: the median board distance unless given.
  if (o.uncertainty_range > 0) {
    out->uncertainty_range = o.uncertainty_range;
  } else {
    std::vector<double> d;
    for (const Pose& p : out->result.cam_from_board) d.push_back(p.tvec.norm());
    std::nth_element(d.begin(), d.begin() + d.size() / 2, d.end());
    out->uncertainty_range = d[d.size() / 2];
  }
  // The report and the model with its sidecar are written as one group: a failed write (a full
  // disk) leaves every earlier output as it was, and a model is never left without its report.
  AtomicFileSet files;
  if (!o.report_dir.empty()) {
    if (Status s = WriteReport(o, views, out, &files); !s) {
      std::cerr << prog << "--report: " << s.message() << "; nothing written\n";
      return kExitFailed;
    }
  }
  Status written;
  if (!o.out.empty()) {
    written = AddCameraWithSidecar(o.out, out->result.camera, out->result.noise_sigma_px,
                                   static_cast<int>(out->result.views.size()), &files);
    // A response given or estimated is stored with the camera (photometric.h), so that
    // detect, pose and survey read its images the same way.
    if (const std::optional<PhotometricModel> m = photometry.GivenModel(); written && m) {
      written = files.Add(PhotometricPath(o.out), PhotometricToJson(*m));
    } else {
      std::error_code ec;
      if (std::filesystem::exists(PhotometricPath(o.out), ec))
        std::cerr << prog << "note: " << PhotometricPath(o.out)
                  << " (from an earlier calibration) is kept; detect, pose and survey will read "
                     "the images with it (give --response to replace it)\n";
    }
  }
  if (written) written = files.Commit();
  if (Status s = written; !s) {
    std::cerr << prog << s.message() << "; nothing written\n";
    return kExitFailed;
  }
  return out->errors.empty() ? kExitOk : kExitFailed;
}

}  // namespace svms::cli

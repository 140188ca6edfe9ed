#include "svms/pipelines/calibration_report.h"

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <utility>

#include "svms/base/format.h"
#include "svms/pipelines/gnuplot.h"
#include "svms/pipelines/json_text.h"

namespace svms {
namespace {

// The uncertainty grid: cell centres of a 32 x 32 grid over the image.
constexpr int kGrid = 32;

// What the residual files give the rest of the report.
struct Residuals {
  nlohmann::json outliers = nlohmann::json::array();  // one object per outlier
  std::vector<double> components;                     // x and y of every inlier's residual, px
};

// residuals.dat and outliers.dat (pixel x y, residual x y), coverage.dat (inliers per cell of a
// 16 x 16 grid); sets outcome->coverage.
Residuals AddResidualFiles(const std::vector<ViewObservations>& views, CalibrateRunOutcome* out,
                           const std::string& dir, AtomicFileSet* files) {
  const CalibrationResult& r = out->result;
  const int W = r.camera.width(), H = r.camera.height();
  Residuals residuals;
  std::ostringstream res, outl;
  std::vector<int> cells(16 * 16, 0);
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
        residuals.outliers.push_back(oj);
        continue;
      }
      res << p.pixel.x() << " " << p.pixel.y() << " " << e.x() << " " << e.y() << "\n";
      residuals.components.push_back(e.x()), residuals.components.push_back(e.y());
      const int cx = std::clamp(static_cast<int>(16 * p.pixel.x() / W), 0, 15);
      const int cy = std::clamp(static_cast<int>(16 * p.pixel.y() / H), 0, 15);
      ++cells[cy * 16 + cx];
    }
  }
  files->Add(dir + "/residuals.dat", res.str());
  files->Add(dir + "/outliers.dat", outl.str());
  out->coverage = std::count_if(cells.begin(), cells.end(), [](int c) { return c > 0; }) / 256.0;
  std::ostringstream cov;
  for (int y = 0; y < 16; ++y) {
    for (int x = 0; x < 16; ++x)
      cov << (x + 0.5) * W / 16 << " " << (y + 0.5) * H / 16 << " " << cells[y * 16 + x] << "\n";
    cov << "\n";
  }
  files->Add(dir + "/coverage.dat", cov.str());
  return residuals;
}

// histogram.dat: the residual components in 41 bins, and the Gaussian of the solve's sigma.
void AddHistogram(const std::vector<double>& comps, double sigma_px, const std::string& dir,
                  AtomicFileSet* files) {
  double lim = 0;
  for (double c : comps) lim = std::max(lim, std::abs(c));
  lim = std::max(lim, 1e-3);
  const int bins = 41;
  std::vector<int> hist(bins, 0);
  for (double c : comps)
    ++hist[std::clamp(static_cast<int>((c + lim) / (2 * lim) * bins), 0, bins - 1)];
  std::ostringstream h;
  for (int b = 0; b < bins; ++b) {
    const double x = -lim + (b + 0.5) * 2 * lim / bins;
    const double gauss = comps.size() * (2 * lim / bins) / (std::sqrt(2 * M_PI) * sigma_px) *
                         std::exp(-0.5 * x * x / (sigma_px * sigma_px));
    h << x << " " << hist[b] << " " << gauss << "\n";
  }
  files->Add(dir + "/histogram.dat", h.str());
}

// uncertainty.dat: sqrt(trace) of the projection covariance at the outcome's range over a
// kGrid x kGrid grid; sets the outcome's uncertainty RMS and maximum.
void AddUncertaintyGrid(CalibrateRunOutcome* out, const std::string& dir, AtomicFileSet* files) {
  const CalibrationResult& r = out->result;
  const int W = r.camera.width(), H = r.camera.height();
  double u2 = 0, umax = 0;
  int un = 0;
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
  files->Add(dir + "/uncertainty.dat", u.str());
  out->uncertainty_rms = un > 0 ? std::sqrt(u2 / un) : NAN;
  out->uncertainty_max = umax;
}

// The four pictures (residual histogram and vectors, coverage, uncertainty), through gnuplot.
Status AddPlots(const CalibrateRunOutcome& out, const std::string& dir, AtomicFileSet* files) {
  const CalibrationResult& r = out.result;
  const std::string W = std::to_string(r.camera.width()), H = std::to_string(r.camera.height());
  // The longest arrow of the residual vectors: 5 % of the width.
  const double scale = 0.05 * r.camera.width() / std::max(r.worst_px, 1e-6);
  const std::vector<std::pair<std::string, std::string>> plots = {
      {"residual_histogram",
       "set title 'Residuals (inliers), sigma " + Fixed(r.sigma_px, 3) +
           " px'\nset xlabel 'residual component (px)'\nset ylabel 'count'\nset style fill solid "
           "0.5\nset grid\nplot 'histogram.dat' u 1:2 w boxes t 'x and y components', '' u 1:3 "
           "w l lw 2 t 'Gaussian of that sigma'"},
      {"residual_vectors",
       "set title 'Residual vectors over the image (x " + Fixed(scale, 0) +
           "), outliers in red'\nset xrange [0:" + W + "]\nset yrange [" + H +
           ":0]\nset size ratio -1\nset grid\nplot 'residuals.dat' u 1:2:($3*" +
           Significant(scale, 6) + "):($4*" + Significant(scale, 6) +
           ") w vectors lc rgb '#3060c0' nohead t 'inliers', 'outliers.dat' u 1:2 w p pt 7 ps "
           "0.6 lc rgb 'red' t 'outliers'"},
      {"coverage",
       "set title 'Coverage: observed points per cell (" + Fixed(100 * out.coverage, 0) +
           " % of cells)'\nset xrange [0:" + W + "]\nset yrange [" + H +
           ":0]\nset size ratio -1\nset view map\nset palette defined (0 'white', 1 '#c0d0f0', "
           "10 '#3060c0', 40 '#102060')\nplot 'coverage.dat' u 1:2:3 w image t '', "
           "'residuals.dat' u 1:2 w dots lc rgb 'black' t ''"},
      {"uncertainty",
       "set title 'Projection uncertainty at " + Fixed(out.uncertainty_range, 2) +
           " m: sqrt(trace) px'\nset xrange [0:" + W + "]\nset yrange [" + H +
           ":0]\nset size ratio -1\nset view map\nset cblabel 'px'\nplot 'uncertainty.dat' u "
           "1:2:3 w image t '', 'residuals.dat' u 1:2 w dots lc rgb 'white' t ''"}};
  for (const auto& [name, body] : plots)
    if (Status s = Gnuplot(dir, name, body, "900,700", files); !s) return s;
  return Status::Ok();
}

// summary.json: the camera, the data used, residuals, outliers, coverage, uncertainty, solver.
nlohmann::json Summary(const CalibrateRunOptions& o, const CalibrateRunOutcome& out,
                       const nlohmann::json& outliers) {
  const CalibrationResult& r = out.result;
  nlohmann::json j;
  j["camera"] = {{"lensmodel", r.camera.lensmodel()},
                 {"intrinsics", r.camera.intrinsics()},
                 {"imagersize", {r.camera.width(), r.camera.height()}}};
  if (!o.out.empty()) SetPath(j["camera"], "file", o.out);
  SetPath(j, "board", o.board);
  j["images"] = out.image_of_view.size();
  j["views_used"] = r.views.size();
  nlohmann::json skipped = nlohmann::json::array();
  for (const auto& [v, why] : r.skipped) skipped.push_back(why);
  j["views_skipped"] = skipped;
  j["image_errors"] = out.errors;
  j["points"] = {{"inliers", r.num_inliers}, {"outliers", r.num_outliers}};
  j["residuals_px"] = {{"rms", r.rms_px}, {"worst", r.worst_px}, {"sigma", r.sigma_px}};
  j["outliers"] = outliers;
  j["coverage"] = {{"cells_16x16_fraction", out.coverage}};
  j["uncertainty"] = {{"range_m", out.uncertainty_range},
                      {"what", "sqrt(trace(Var(q))) over a 32x32 grid, px"},
                      {"rms_px", out.uncertainty_rms},
                      {"max_px", out.uncertainty_max}};
  if (o.calib.board_warp) j["board_warp_m"] = {r.warp.x(), r.warp.y()};
  if (o.calib.edge_bias)
    j["edge_bias_px"] = {{"value", r.edge_bias_px}, {"sigma", r.edge_bias_sigma_px}};
  j["noise_sigma_px"] = r.noise_sigma_px;
  if (out.response.patches > 0)
    j["response_estimate"] = {{"gamma", out.response.gamma},
                              {"sigma", out.response.sigma},
                              {"edge_patches", out.response.patches},
                              {"asymmetry", out.response.asymmetry},
                              {"asymmetry_as_linear", out.response.asymmetry_linear},
                              {"asymmetry_as_srgb", out.response.asymmetry_srgb}};
  if (out.refined_gamma > 0)
    j["response_refined"] = {{"gamma", out.refined_gamma},
                             {"sigma", out.refined_gamma_sigma},
                             {"edge_bias_px_per_gamma", out.edge_bias_per_gamma}};
  else if (!out.refine_note.empty())
    j["response_refined"] = {{"note", out.refine_note},
                             {"edge_bias_px_per_gamma", out.edge_bias_per_gamma}};
  if (o.redetect)
    j["pass1"] = {{"what", "corners fitted in pixels, before re-detection with the lens model"},
                  {"rms_px", out.pass1.rms_px},
                  {"noise_sigma_px", out.pass1.noise_sigma_px}};
  j["solver"] = {
      {"iterations", r.iterations}, {"outlier_rounds", r.outlier_rounds}, {"final", r.report}};
  return j;
}

}  // namespace

Status AddCalibrationReport(const CalibrateRunOptions& o,
                            const std::vector<ViewObservations>& views, CalibrateRunOutcome* out,
                            AtomicFileSet* files) {
  const std::string& dir = o.report_dir;
  const Residuals residuals = AddResidualFiles(views, out, dir, files);
  AddHistogram(residuals.components, out->result.sigma_px, dir, files);
  AddUncertaintyGrid(out, dir, files);
  if (Status s = AddPlots(*out, dir, files); !s) return s;
  return files->Add(dir + "/summary.json",
                    DumpJson(Summary(o, *out, residuals.outliers), 2) + "\n");
}

}  // namespace svms

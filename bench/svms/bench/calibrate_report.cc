#include "svms/bench/calibrate_report.h"

#include <cmath>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>
#include <string>

#include "svms/base/format.h"
#include "svms/bench/bench_targets.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/pipelines/gnuplot.h"
#include "svms/pipelines/report_file.h"

namespace svms {
namespace {

namespace fs = std::filesystem;

// The number of grid cells in the region (both boards' data).
int RegionCells(const CalibrationData& data) {
  int region_cells = 0;
  for (int c : data.cells) region_cells += c == kBothBoards;
  return region_cells;
}

// `v` with `digits` decimals and its sign always written ("+0.0012", "-0.0003").
std::string SignedFixed(double v, int digits) {
  return (std::signbit(v) ? "" : "+") + Fixed(v, digits);
}

// `text` padded with spaces on the right to `width` characters (never cut).
std::string PadRight(const std::string& text, size_t width) {
  return text.size() >= width ? text : text + std::string(width - text.size(), ' ');
}

// calibrate.csv (a row per tool) and calibrate_grid.dat (per grid cell: x y, then |error| and
// predicted for svms, mrcal, OpenCV, then the cell's data flags: 1 SVMS board, 2 chessboard,
// 3 both = the region).
void WriteTables(const CalibrateBenchmarkOptions& o, const CalibrationData& data,
                 const CalibrateFindings& f) {
  OutputFile csv(fs::path(o.out) / "calibrate.csv");
  csv << "tool,ok,views,reprojection_rms_px,region_error_rms_px,region_error_worst_px,"
         "region_predicted_rms_px,error_rms_px,error_worst_px,direct_error_rms_px,"
         "predicted_rms_px,seconds\n";
  for (const ToolResult* tp : {&f.tools[0], &f.tools[1], &f.tools[2], &f.response.gamma,
                               &f.response.linear, &f.response.known}) {
    const ToolResult& t = *tp;
    if (t.name.empty()) continue;  // a response-check run that did not start
    csv << '"' << t.name << "\"," << t.ok << "," << t.r.cam_from_board.size() << "," << t.rms_reproj
        << "," << t.region_err_rms << "," << t.region_err_worst << "," << t.region_pred_rms << ","
        << t.err_rms << "," << t.err_worst << "," << t.direct_rms << "," << t.pred_rms << ","
        << t.seconds << "\n";
  }
  // Per grid cell: x y, then |error| and predicted for svms, mrcal, OpenCV, then the cell's
  // data flags (1 SVMS board, 2 chessboard, 3 both = the region).
  OutputFile g(fs::path(o.out) / "calibrate_grid.dat");
  for (size_t k = 0; k < data.grid.size(); ++k) {
    g << data.grid[k].x() << " " << data.grid[k].y();
    for (const ToolResult& t : f.tools)
      g << " " << (k < t.error.size() ? t.error[k] : NAN) << " "
        << (k < t.predicted.size() ? t.predicted[k] : NAN);
    g << " " << data.cells[k] << "\n";
  }
}

// calibrate.json: every figure of the report.
void WriteJson(const CalibrateBenchmarkOptions& o, const CalibrationData& data,
               const CalibrateFindings& f) {
  nlohmann::json j;
  j["region"] = {{"what", "cells of the " + std::to_string(kCalibrateGrid) + "x" +
                              std::to_string(kCalibrateGrid) +
                              " grid holding both SVMS board and chessboard corners"},
                 {"cells", RegionCells(data)}};
  j["tools"] = nlohmann::json::array();
  for (const ToolResult& t : f.tools)
    j["tools"].push_back({{"tool", t.name},
                          {"ok", t.ok},
                          {"failure", t.failure},
                          {"views", t.r.cam_from_board.size()},
                          {"reprojection_rms_px", t.rms_reproj},
                          {"region_error_rms_px", t.region_err_rms},
                          {"region_error_worst_px", t.region_err_worst},
                          {"region_predicted_rms_px", t.region_pred_rms},
                          {"error_rms_px", t.err_rms},
                          {"error_worst_px", t.err_worst},
                          {"direct_error_rms_px", t.direct_rms},
                          {"predicted_rms_px", t.pred_rms},
                          {"seconds", t.seconds}});
  j["projection_diff"] = nlohmann::json::array();
  for (size_t k = 0; k < f.tools.size(); ++k)
    j["projection_diff"].push_back({{"tool", f.tools[k].name},
                                    {"focus_radius_px", f.projection_diff.focus_radius},
                                    {"region_rms_px", f.projection_diff.rms[k][0]},
                                    {"whole_image_rms_px", f.projection_diff.rms[k][1]},
                                    {"whole_image_worst_px", f.projection_diff.rms[k][2]}});
  j["svms_corner_noise"] = {{"a_posteriori_sigma_px", f.tools[0].r.noise_sigma_px},
                            {"true_rms_per_axis_px", f.corner_noise.rms},
                            {"true_mean_px", {f.corner_noise.mean_x, f.corner_noise.mean_y}},
                            {"pass1_a_posteriori_sigma_px", f.pass1.r.noise_sigma_px},
                            {"pass1_true_rms_per_axis_px", f.pass1_corner_noise.rms}};
  if (f.pass1.ok)
    j["svms_pass1"] = {{"region_error_rms_px", f.pass1.region_err_rms},
                       {"region_predicted_rms_px", f.pass1.region_pred_rms},
                       {"error_rms_px", f.pass1.err_rms}};
  j["monte_carlo"] = {{"trials", f.monte_carlo.trials},
                      {"solved", f.monte_carlo.solved},
                      {"region_error_rms_px", f.monte_carlo.error_rms},
                      {"region_predicted_rms_px", f.monte_carlo.predicted_rms},
                      {"seconds", f.monte_carlo.seconds},
                      {"failures", f.monte_carlo.failures}};
  const ResponseCheck& r = f.response;
  // A figure of a run that did not happen is null.
  auto figure = [](bool have, double v) { return have ? nlohmann::json(v) : nlohmann::json(); };
  j["seed"] = o.seed;
  j["response_check"] = {
      {"ok", r.ok},
      {"failure", r.failure},
      {"true_gamma", kCheckedGamma},
      {"defocus_sigma_px", kCheckedDefocusPx},
      {"estimated_gamma", figure(r.estimate.patches > 0, r.estimate.gamma)},
      {"estimated_gamma_sigma", figure(r.estimate.patches > 0, r.estimate.sigma)},
      {"patches", r.estimate.patches},
      {"refined_gamma", figure(r.refined_gamma > 0, r.refined_gamma)},
      {"refined_gamma_sigma", figure(r.refined_gamma > 0, r.refined_sigma)},
      {"refine_note", r.refine_note},
      {"gamma_region_error_rms_px", figure(r.gamma.ok, r.gamma.region_err_rms)},
      {"gamma_region_predicted_rms_px", figure(r.gamma.ok, r.gamma.region_pred_rms)},
      {"gamma_a_posteriori_sigma_px", figure(r.gamma.ok, r.gamma.r.noise_sigma_px)},
      {"gamma_edge_bias_px", figure(r.gamma.ok, r.gamma.r.edge_bias_px)},
      {"gamma_edge_bias_sigma_px", figure(r.gamma.ok, r.gamma.r.edge_bias_sigma_px)},
      {"gamma_corner_error_rms_per_axis_px", figure(r.gamma.ok, r.gamma_corners.rms)},
      {"gamma_corner_error_mean_px",
       {figure(r.gamma.ok, r.gamma_corners.mean_x), figure(r.gamma.ok, r.gamma_corners.mean_y)}},
      {"linear_twin_region_error_rms_px", figure(r.linear.ok, r.linear.region_err_rms)},
      {"linear_twin_region_predicted_rms_px", figure(r.linear.ok, r.linear.region_pred_rms)},
      {"linear_twin_a_posteriori_sigma_px", figure(r.linear.ok, r.linear.r.noise_sigma_px)},
      {"linear_twin_corner_error_rms_per_axis_px", figure(r.linear.ok, r.linear_corners.rms)},
      {"linear_twin_corner_error_mean_px",
       {figure(r.linear.ok, r.linear_corners.mean_x),
        figure(r.linear.ok, r.linear_corners.mean_y)}},
      {"true_curve_region_error_rms_px", figure(r.known.ok, r.known.region_err_rms)},
      {"true_curve_region_predicted_rms_px", figure(r.known.ok, r.known.region_pred_rms)},
      {"true_curve_corner_error_rms_per_axis_px", figure(r.known.ok, r.known_corners.rms)},
      {"gamma_seconds", r.gamma.seconds},
      {"linear_twin_seconds", r.linear.seconds},
      {"true_curve_seconds", r.known.seconds}};
  OutputFile(fs::path(o.out) / "calibrate.json") << j.dump(2) << "\n";
}

// The benchmark's own plots (error against the distance from the centre, predicted against
// true, the region), and svms calibrate's report plots copied beside them.
void WritePlots(const CalibrateBenchmarkOptions& o, const CalibrationData& data) {
  const int W = data.truth.width(), H = data.truth.height();
  const std::string range = Fixed(kCalibrateRange, 1);
  const std::vector<std::pair<std::string, std::string>> plots = {
      {"calibrate_error",
       "set title 'Projection error vs the true camera at " + range +
           " m (filled: in the region)'\n"
           "set xlabel 'distance of the pixel from the image centre (px)'\nset ylabel 'px'\n"
           "set logscale y\nset grid\nset key top left\n"
           "c(x,y) = sqrt((x-" +
           Significant(0.5 * (W - 1), 6) + ")**2 + (y-" + Significant(0.5 * (H - 1), 6) +
           ")**2)\n"
           "plot 'calibrate_grid.dat' u (c($1,$2)):($9==3?$3:1/0) w p pt 7 ps 0.5 lc rgb '#3060c0' "
           "t 'svms', '' u (c($1,$2)):($9==3?1/0:$3) w p pt 6 ps 0.5 lc rgb '#3060c0' t '', "
           "'' u (c($1,$2)):($9==3?$5:1/0) w p pt 7 ps 0.5 lc rgb '#20a040' t 'mrcal', "
           "'' u (c($1,$2)):($9==3?1/0:$5) w p pt 6 ps 0.5 lc rgb '#20a040' t '', "
           "'' u (c($1,$2)):($9==3?$7:1/0) w p pt 7 ps 0.5 lc rgb '#d04020' t 'OpenCV', "
           "'' u (c($1,$2)):($9==3?1/0:$7) w p pt 6 ps 0.5 lc rgb '#d04020' t ''"},
      {"calibrate_predicted_vs_true",
       "set title 'Predicted vs true projection error per grid cell in the region (" + range +
           " m)'\n"
           "set xlabel 'true |error| (px)'\nset ylabel 'predicted sqrt(trace Var q) (px)'\n"
           "set logscale xy\nset grid\nset key top left\nset size ratio -1\n"
           "set xrange [1e-4:0.1]\nset yrange [1e-4:0.1]\n"
           "plot 'calibrate_grid.dat' u ($9==3?$3:1/0):4 w p pt 7 ps 0.5 lc rgb '#3060c0' t "
           "'svms', '' u ($9==3?$5:1/0):6 w p pt 7 ps 0.5 lc rgb '#20a040' t 'mrcal', "
           "x w l lc rgb 'black' t 'predicted = true', 0.7*x w l dt 2 lc rgb 'gray' t '0.7, 1.4', "
           "1.4*x w l dt 2 lc rgb 'gray' t ''"},
      {"calibrate_region",
       "set title 'The evaluation region: grid cells with data'\nset xrange [0:" +
           std::to_string(W) + "]\nset yrange [" + std::to_string(H) +
           ":0]\nset size ratio -1\nset key outside bottom center horizontal\n"
           "plot 'calibrate_grid.dat' u 1:($9==3?$2:1/0) w p pt 5 ps 1.2 lc rgb '#3060c0' "
           "t 'both (region)', '' u 1:($9==1?$2:1/0) w p pt 5 ps 1.2 lc rgb '#a0b0e0' t "
           "'SVMS board only', '' u 1:($9==2?$2:1/0) w p pt 5 ps 1.2 lc rgb '#a0e0b0' t "
           "'chessboard only', '' u 1:($9==0?$2:1/0) w p pt 4 ps 1.2 lc rgb '#c0c0c0' t "
           "'no data'"}};
  for (const auto& [name, body] : plots)
    if (Status s = Gnuplot(o.out, name, body); !s)
      std::cerr << "svms bench calibrate: " << s.message() << "\n";
  std::error_code ec;
  for (const char* f : {"residual_histogram", "residual_vectors", "coverage", "uncertainty"}) {
    for (const char* ext : {".png", ".svg"})
      fs::copy_file(fs::path(o.out) / "svms_report" / (std::string(f) + ext),
                    fs::path(o.out) / ("calibrate_" + std::string(f) + ext),
                    fs::copy_options::overwrite_existing, ec);
  }
}

// A row of the tools' table (`emphasised`: the name in italics and no time, for pass 1).
std::string ToolRow(const ToolResult& t, bool emphasised) {
  return "| " + (emphasised ? "*" + t.name + "*" : t.name) + " | " +
         std::to_string(t.r.cam_from_board.size()) + " | " + Fixed(t.rms_reproj, 3) + " | " +
         Fixed(t.region_err_rms, 4) + " | " + Fixed(t.region_err_worst, 4) + " | " +
         Fixed(t.region_pred_rms, 4) + " | " + Fixed(t.region_pred_rms / t.region_err_rms, 2) +
         " | " + Fixed(t.err_rms, 3) + " | " + Fixed(t.err_worst, 2) + " | " +
         Significant(t.pred_rms, 3) + " | " + Fixed(t.direct_rms, 3) + " | " +
         (emphasised ? "" : Fixed(t.seconds, 1) + " ") + "|\n";
}

// The introduction and the tools' table.
void ToolsSection(const CalibrateBenchmarkOptions& o, const CalibrationData& data,
                  const CalibrateFindings& f, std::ostream* md) {
  *md << "## Camera calibration\n\n"
      << "`svms bench calibrate" << (o.quick ? " --quick" : "")
      << (o.seed != 1 ? " --seed " + std::to_string(o.seed) : std::string())
      << "` on the simulator's calibration dataset: " << data.views
      << " views of a 6x5 SVMS marker board and, at the same poses, of a 10x8 chessboard, "
      << "1024x1024 " << data.truth.lensmodel()
      << " camera (the true model is known and all three tools solve for that same model). "
      << "(a) `svms calibrate` on the marker board (two passes: the second re-detects the corners "
         "with the first pass's lens model, see the pass-1 row); (b) mrcal 2.2's "
         "`mrcal-calibrate-cameras` on "
         "the chessboard corners found by OpenCV's `findChessboardCornersSB`; (c) OpenCV's "
         "`calibrateCamera` (`CALIB_RATIONAL_MODEL`, the same 8 distortion terms) on the same "
         "corners.\n\n"
      << "Error: the projection error against the true camera at " << kCalibrateRange
      << " m at the "
      << "centres of a " << kCalibrateGrid << "x" << kCalibrateGrid
      << " grid of cells over the image, after mapping through the solved board poses as "
         "mrcal's uncertainty does (`AlignedProjectionError`). **Region**: the "
      << RegionCells(data) << " of the " << kCalibrateGrid * kCalibrateGrid
      << " cells that hold both SVMS board corners and chessboard corners "
      << "(map below); in the cells outside it "
         "a rational model only extrapolates, so the whole-image figures are given too but "
         "judge that extrapolation as well as the calibration (mrcal likewise evaluates where "
         "the data are: "
         "`valid_intrinsics_region`, `projection_diff`'s focus radius). \"Direct\" compares "
         "the two cameras over the whole image with no alignment. Predicted: each tool's own "
         "predicted standard deviation of that error, sqrt(trace(Var q)) (svms: propagated "
         "from the a-posteriori corner noise through the optimum as mrcal does; mrcal: "
         "`mrcal.projection_uncertainty`; OpenCV: its per-parameter sigmas through the "
         "projection, no correlations).\n\n"
      << "| tool | views | reprojection RMS (px) | region: error RMS (px) | region: error worst "
         "(px) | region: predicted RMS (px) | region: predicted / error | whole image: error "
         "RMS (px) | whole image: error worst (px) | whole image: predicted RMS (px) | direct "
         "error RMS (px) | time (s) |\n"
      << "|---|---|---|---|---|---|---|---|---|---|---|---|\n";
  for (const ToolResult& t : f.tools) {
    if (!t.ok) {
      *md << "| " << t.name << " | failed: " << t.failure << " | | | | | | | | | | |\n";
      continue;
    }
    *md << ToolRow(t, false);
  }
  if (f.pass1.ok) *md << ToolRow(f.pass1, true);
  const ResponseCheck& r = f.response;
  for (const ToolResult* t : {&r.gamma, &r.linear, &r.known}) {
    if (t->ok)
      *md << ToolRow(*t, false);
    else if (!t->name.empty())
      *md << "| " << t->name << " | failed: " << t->failure << " | | | | | | | | | | |\n";
  }
  *md << "\nThe response check (calibrate_response.h): the same board views rendered through a "
         "camera that encodes gamma "
      << Fixed(kCheckedGamma, 1) << " and through its linear twin, both behind "
      << Fixed(kCheckedDefocusPx, 1)
      << " px of defocus, calibrated with `--response estimate` and `--response linear` (the "
         "table's last rows, the very last a diagnostic). ";
  if (r.ok) {
    *md << "The response estimated from the board: gamma " << Fixed(r.estimate.gamma, 3) << " +- "
        << Fixed(r.estimate.sigma, 3) << " from " << r.estimate.patches << " edge patches";
    if (r.gamma.ok && r.gamma.r.edge_bias_sigma_px > 0)
      *md << "; the calibration with it fitted an edge bias (calibrate.h) of "
          << SignedFixed(r.gamma.r.edge_bias_px, 5) << " +- "
          << Fixed(r.gamma.r.edge_bias_sigma_px, 5)
          << " px, the sides' shift out of their squares that the estimate's error leaves";
    if (r.refined_gamma > 0)
      *md << "; the curve refined by it (calibration_run.cc): gamma " << Fixed(r.refined_gamma, 4)
          << " +- " << Fixed(r.refined_sigma, 4) << " ("
          << SignedFixed(r.refined_gamma - kCheckedGamma, 4) << " from the truth)";
    else if (!r.refine_note.empty())
      *md << "; the curve not refined: " << r.refine_note;
    *md << ". Their corners against the true projections: " << Fixed(r.gamma_corners.rms, 4)
        << " px RMS per axis, mean (" << SignedFixed(r.gamma_corners.mean_x, 4) << ", "
        << SignedFixed(r.gamma_corners.mean_y, 4) << ") px, a-posteriori sigma "
        << Fixed(r.gamma.r.noise_sigma_px, 4) << " px; the twin's "
        << Fixed(r.linear_corners.rms, 4) << " px, mean ("
        << SignedFixed(r.linear_corners.mean_x, 4) << ", "
        << SignedFixed(r.linear_corners.mean_y, 4) << ") px, a-posteriori "
        << Fixed(r.linear.r.noise_sigma_px, 4) << " px.\n";
    if (r.known.ok && r.gamma.ok && r.linear.ok) {
      // The diagnostic row: the same gamma views with the curve they were encoded with.
      *md << "\nWith the true curve declared instead of estimated (the table's last row, a "
             "diagnostic): region error "
          << Fixed(r.known.region_err_rms, 4) << " px, "
          << Fixed(r.known.region_err_rms / r.linear.region_err_rms, 2)
          << "x the twin's (the encoding alone: the same light in 8-bit codes spaced "
             "unevenly), where the estimated curve gave "
          << Fixed(r.gamma.region_err_rms / r.linear.region_err_rms, 2)
          << "x (the encoding and the estimate's error of "
          << SignedFixed(r.estimate.gamma - kCheckedGamma, 3) << " in gamma"
          << (r.gamma.r.edge_bias_sigma_px > 0 ? ", less what the edge bias took up" : "")
          << "); corners against the truth " << Fixed(r.known_corners.rms, 4)
          << " px RMS per axis, mean (" << SignedFixed(r.known_corners.mean_x, 4) << ", "
          << SignedFixed(r.known_corners.mean_y, 4) << ") px.\n";
    }
  } else {
    *md << "Failed: " << r.failure << ".\n";
  }
}

// The targets, over the region. The region error's predicted/true ratio of one calibration is
// one draw (its true error is one sample of the spread the covariance predicts): only the
// Monte-Carlo's ratio is judged.
BenchTargets Targets(const CalibrateBenchmarkOptions& o, const CalibrateFindings& f,
                     std::ostream* md) {
  const ToolResult &a = f.tools[0], &b = f.tools[1], &c = f.tools[2];
  const MonteCarlo& mc = f.monte_carlo;
  BenchTargets targets;
  if (a.ok && b.ok && c.ok) {
    const double ratio = a.region_pred_rms / a.region_err_rms;
    const double mc_ratio = mc.predicted_rms / mc.error_rms;
    targets.Add("Our region error within 10 % of mrcal's",
                a.region_err_rms <= 1.1 * b.region_err_rms,
                Fixed(a.region_err_rms, 4) + " vs " + Fixed(b.region_err_rms, 4) + " px");
    targets.Add("Below OpenCV's", a.region_err_rms < c.region_err_rms,
                Fixed(c.region_err_rms, 4) + " px");
    targets.NotJudged("Predicted / true region error in [0.7, 1.4] in this one calibration",
                      Fixed(ratio, 2) + ", one draw; the Monte-Carlo below judges the prediction");
    targets.Add("Predicted / true region error in [0.7, 1.4] over a " + std::to_string(mc.solved) +
                    "-trial Monte-Carlo on the same geometry",
                mc_ratio >= 0.7 && mc_ratio <= 1.4, Fixed(mc_ratio, 2));
  }
  const ResponseCheck& r = f.response;
  if (!r.ok) {
    targets.Add("The response estimated from boards seen through a gamma-" +
                    Fixed(kCheckedGamma, 1) + " camera, and the calibration from them",
                false, r.failure);
  } else {
    targets.Add("The response estimated from boards seen through a gamma-" +
                    Fixed(kCheckedGamma, 1) + " camera within 0.1 of " + Fixed(kCheckedGamma, 1),
                std::abs(r.estimate.gamma - kCheckedGamma) <= 0.1,
                Fixed(r.estimate.gamma, 3) + " +- " + Fixed(r.estimate.sigma, 3));
    const std::string what =
        "The calibration from them at most 10 % worse than from their linear twin (region error)";
    const std::string measured =
        Fixed(r.gamma.region_err_rms, 4) + " vs " + Fixed(r.linear.region_err_rms, 4) +
        " px, ratio " + Fixed(r.gamma.region_err_rms / r.linear.region_err_rms, 2) +
        "; each one draw of the spread its covariance predicts, " +
        Fixed(r.gamma.region_pred_rms, 4) + " and " + Fixed(r.linear.region_pred_rms, 4) + " px";
    // With --quick's 12 views the two errors are draws too small to compare (a smoke test).
    if (o.quick)
      targets.NotJudged(what, measured + "; --quick");
    else
      targets.Add(what, r.gamma.region_err_rms <= 1.1 * r.linear.region_err_rms, measured);
  }
  *md << "\nTargets, over the region:\n\n" << targets.Markdown();
  return targets;
}

// mrcal's own comparison, the corner noise, the Monte-Carlo, and the pictures.
void ChecksSection(const CalibrationData& data, const CalibrateFindings& f, std::ostream* md) {
  const ToolResult& a = f.tools[0];
  const MonteCarlo& mc = f.monte_carlo;
  *md << "\nCross-check with mrcal's own comparison, `mrcal.projection_diff` against the true "
         "model (the implied rotation fitted within "
      << static_cast<int>(f.projection_diff.focus_radius)
      << " px of the image centre, the largest circle holding only region cells; no board poses "
         "involved):\n\n| tool | region RMS (px) | whole image RMS (px) | whole image worst (px) "
         "|\n|---|---|---|---|\n";
  for (size_t k = 0; k < f.tools.size(); ++k) {
    const auto& d = f.projection_diff.rms[k];
    *md << "| " << f.tools[k].name << " | " << Fixed(d[0], 4) << " | " << Fixed(d[1], 3) << " | "
        << Fixed(d[2], 2) << " |\n";
  }
  *md << "\nOutside the region every tool extrapolates an 8-term rational model into cells "
         "no view reached, and the whole-image figures rank that extrapolation too. OpenCV "
         "and mrcal see identical corners; mrcal additionally regularises the distortion terms "
         "(its optimisation_inputs: `do_apply_regularization`), which biases its solution "
         "without showing in its predicted uncertainty. Where the data barely see a direction "
         "of the state (eigenvalues near svms's pseudo-inverse cutoff of 1e-15 of the largest), "
         "svms's prediction says 'unknown' (large) or, when a direction falls below the cutoff, "
         "too little: it means little outside the data.\n";
  *md << "\nsvms's corner noise: a-posteriori sigma " << Fixed(a.r.noise_sigma_px, 4)
      << " px per axis (from the residuals of the fit, what the prediction uses); the detected "
         "corners against the true projections: "
      << Fixed(f.corner_noise.rms, 4) << " px RMS per axis, mean ("
      << SignedFixed(f.corner_noise.mean_x, 4) << ", " << SignedFixed(f.corner_noise.mean_y, 4)
      << ") px. In pass 1 (sides fitted as straight lines in pixels): a-posteriori "
      << Fixed(f.pass1.r.noise_sigma_px, 4) << " px, against the truth "
      << Fixed(f.pass1_corner_noise.rms, 4) << " px RMS per axis.\n";
  *md << "\nMonte-Carlo: the same " << a.r.views.size()
      << " views and points, put at their true projections plus Gaussian noise of that sigma, "
         "calibrated "
      << mc.trials << " times (" << mc.solved << " solved, " << Fixed(mc.seconds, 0)
      << " s): aligned error over the region " << Fixed(mc.error_rms, 4) << " px RMS, predicted "
      << Fixed(mc.predicted_rms, 4) << " px RMS (ratio predicted / true "
      << Fixed(mc.predicted_rms / mc.error_rms, 2)
      << "). A single calibration's error is one draw, correlated over the image; this checks "
         "the propagation itself.\n";
  // One sentence each: the solver's messages carry their own semicolons and parentheses.
  for (const std::string& why : mc.failures) *md << "\nMonte-Carlo " << why << ".\n";
  *md << "\nThe boards differ: the SVMS board gives " << a.r.num_inliers << " corners ("
      << a.r.num_outliers << " rejected as outliers) in " << a.r.views.size() << " of "
      << data.views << " views, the chessboard " << 63 * f.chess.corners.size() << " corners in "
      << f.chess.corners.size()
      << " views, so (a) and (b) do not see the same number of points.\n\n"
      << "![](calibrate_region.png)\n\n"
      << "Error per grid cell against the distance from the image centre (filled: region; "
         "open: outside it):\n\n![](calibrate_error.png)\n\n"
      << "Predicted against true error per cell of the region (one calibration: the true error "
         "of a cell is one draw of a zero-mean variable of that predicted spread, so the points "
         "scatter about the diagonal):\n\n![](calibrate_predicted_vs_true.png)\n\n"
      << "svms calibrate's own report on the board: residuals, residual vectors, coverage and the "
      << "projection uncertainty map.\n\n"
      << "![](calibrate_residual_histogram.png)\n![](calibrate_residual_vectors.png)\n"
      << "![](calibrate_coverage.png)\n![](calibrate_uncertainty.png)\n";
}

// Each tool's figures on stdout.
void PrintSummary(const CalibrationData& data, const CalibrateFindings& f) {
  const int region_cells = RegionCells(data);
  for (const ToolResult& t : f.tools)
    std::cout << PadRight(t.name, 38) << " " << (t.ok ? "ok    " : "FAILED") << " region ("
              << region_cells << " cells): error RMS " << Fixed(t.region_err_rms, 4)
              << " px, worst " << Fixed(t.region_err_worst, 4) << ", predicted "
              << Fixed(t.region_pred_rms, 4) << "; whole image: error RMS " << Fixed(t.err_rms, 4)
              << ", worst " << Fixed(t.err_worst, 4) << ", predicted " << Significant(t.pred_rms, 4)
              << "\n";
  if (f.pass1.ok)
    std::cout << PadRight("svms pass 1 (corners fitted in pixels)", 38) << " region: error RMS "
              << Fixed(f.pass1.region_err_rms, 4) << " px, predicted "
              << Fixed(f.pass1.region_pred_rms, 4) << "; corner noise a-posteriori "
              << Fixed(f.pass1.r.noise_sigma_px, 4) << " px, true "
              << Fixed(f.pass1_corner_noise.rms, 4) << " px\n";
  for (const ToolResult* t : {&f.response.gamma, &f.response.linear, &f.response.known})
    if (t->ok)
      std::cout << PadRight(t->name, 38) << " region: error RMS " << Fixed(t->region_err_rms, 4)
                << " px, predicted " << Fixed(t->region_pred_rms, 4) << "\n";
  if (f.response.ok)
    std::cout << "response estimated from the gamma " << Fixed(kCheckedGamma, 1)
              << " boards: gamma " << Fixed(f.response.estimate.gamma, 3) << " +- "
              << Fixed(f.response.estimate.sigma, 3)
              << (f.response.gamma.ok && f.response.gamma.r.edge_bias_sigma_px > 0
                      ? "; edge bias fitted with it " +
                            SignedFixed(f.response.gamma.r.edge_bias_px, 5) + " +- " +
                            Fixed(f.response.gamma.r.edge_bias_sigma_px, 5) + " px"
                      : "")
              << (f.response.refined_gamma > 0
                      ? "; refined by it " + Fixed(f.response.refined_gamma, 4) + " +- " +
                            Fixed(f.response.refined_sigma, 4)
                      : "")
              << "\n";
  std::cout << "svms corner noise: a-posteriori " << Fixed(f.tools[0].r.noise_sigma_px, 4)
            << " px, true " << Fixed(f.corner_noise.rms, 4) << " px; Monte-Carlo ("
            << f.monte_carlo.solved << "/" << f.monte_carlo.trials << "): error "
            << Fixed(f.monte_carlo.error_rms, 4) << " px, predicted "
            << Fixed(f.monte_carlo.predicted_rms, 4) << " px\n";
}

}  // namespace

int WriteCalibrateReport(const CalibrateBenchmarkOptions& o, const CalibrationData& data,
                         const CalibrateFindings& f) {
  WriteTables(o, data, f);
  WriteJson(o, data, f);
  WritePlots(o, data);
  OutputFile md(fs::path(o.out) / "report.md");
  ToolsSection(o, data, f, &md);
  const BenchTargets targets = Targets(o, f, &md);
  ChecksSection(data, f, &md);
  md.close();
  std::cout << "wrote " << (fs::path(o.out) / "report.md").string() << "\n";
  PrintSummary(data, f);
  const bool all_ok = f.tools[0].ok && f.tools[1].ok && f.tools[2].ok && f.response.ok;
  return all_ok ? targets.ExitCode("svms bench calibrate", kExitOk) : kExitFailed;
}

}  // namespace svms

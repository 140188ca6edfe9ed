// The three calibrations of the calibration benchmark (calibrate_benchmark.h), each judged on
// the same grid of pixels against the true camera.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "svms/bench/calibrate_benchmark.h"
#include "svms/calib/calibrate.h"
#include "svms/datasets/datasets.h"
#include "svms/pipelines/calibration_run.h"

namespace svms {

constexpr int kChessCornersX = 9, kChessCornersY = 7;  // inner corners of the 10 x 8 chessboard
constexpr double kChessSquare = 0.075;                 // metres
constexpr double kCalibrateRange = 2.0;  // metres: the middle of the dataset's 1.3-2.4 m
constexpr int kCalibrateGrid = 24;       // the evaluation grid: 24 x 24 cells over the image

// Where each grid cell's data come from: bit 1 an SVMS board corner (inlier) fell in the cell,
// bit 2 a chessboard corner did. The evaluation region is the cells with both (kBothBoards):
// every tool is judged where both boards put data, none on extrapolation into empty corners.
constexpr int kSvmsBoard = 1, kChessboard = 2, kBothBoards = 3;

// The cell of the evaluation grid a pixel falls in (row-major index).
int GridCellOf(const Eigen::Vector2d& px, int width, int height);

// What one tool produced, as a CalibrationResult (camera, used views, cam_from_frame) so that
// AlignedProjectionError applies; `predicted` is sqrt(trace) per grid pixel.
struct ToolResult {
  std::string name;
  bool ok = false;
  std::string failure;
  CalibrationResult r;
  std::vector<Pose> true_cam_from_frame;  // per used view
  std::vector<double> predicted;          // per grid pixel, px (NaN where unavailable)
  std::vector<double> error;              // per grid pixel, |aligned error| px (NaN: none)
  double rms_reproj = 0;
  double seconds = 0;
  // Measured over the whole grid, and over the covered cells (the region):
  double err_rms = 0, err_worst = 0, direct_rms = 0, pred_rms = 0;
  double region_err_rms = 0, region_err_worst = 0, region_pred_rms = 0;
};

// The rendered dataset and what every tool is judged on.
struct CalibrationData {
  Dataset dataset;  // scenes[0]: the SVMS board, scenes[1]: the chessboard, same poses
  size_t views = 0;
  CameraModel truth;
  std::vector<Pose> true_cam_from_board;  // per view; the boards sit at the world origin
  std::vector<Eigen::Vector2d> grid;      // the evaluation grid's cell centres, px
  std::vector<int> cells;                 // kSvmsBoard | kChessboard per grid cell
};

// The chessboard corners OpenCV found, shared by mrcal and OpenCV.
struct ChessCorners {
  std::vector<std::string> files;                 // per view with corners
  std::vector<std::vector<cv::Point2f>> corners;  // its 63 corners
  std::vector<Pose> true_cam_from_frame;          // its true frame (mrcal's convention)
};

// svms calibrate on the board's images: the tool's result, the pipeline's run (its
// observations) in *run and *outcome, its first pass in *pass1. Marks the cells with inliers.
ToolResult RunSvmsCalibrate(const CalibrateBenchmarkOptions& o, CalibrationData* data,
                            CalibrateRunOptions* run, CalibrateRunOutcome* outcome,
                            ToolResult* pass1);

// Renders `scene` into OUT/data/SUBDIR unless every view's image is there; `what` names it on
// stderr. kExitOk to go on.
int RenderUnlessPresent(const CalibrateBenchmarkOptions& o, const Scene& scene,
                        const std::string& subdir, const std::string& what);

// svms calibrate's options for the board images in OUT/data/SUBDIR (the dataset's views),
// writing OUT/OUT_NAME.cameramodel; no report unless the caller sets one.
CalibrateRunOptions SvmsCalibrateOptions(const CalibrateBenchmarkOptions& o,
                                         const CalibrationData& data, const std::string& subdir,
                                         const std::string& out_name);

// A finished svms calibrate run (its exit code `rc`) as a ToolResult: the true frames of its
// used views and its prediction over the grid, ready for Measure.
ToolResult MeasuredSvmsResult(const CalibrationData& data, const std::string& name, int rc,
                              const CalibrateRunOutcome& out);

// findChessboardCornersSB on the chessboard's images (writes OUT/corners.vnl, mrcal's corner
// cache). Marks the cells with corners.
ChessCorners FindChessboards(const CalibrateBenchmarkOptions& o, CalibrationData* data);

// mrcal-calibrate-cameras on those corners, its uncertainty from mrcal's Python API.
ToolResult RunMrcal(const CalibrateBenchmarkOptions& o, const CalibrationData& data,
                    const ChessCorners& chess);

// OpenCV's calibrateCamera on the same corners (rational model = OPENCV8), its prediction from
// its per-parameter sigmas (no correlations) through the projection.
ToolResult RunOpenCv(const CalibrationData& data, const ChessCorners& chess);

// The tool's errors over the grid and the region against the true camera at kCalibrateRange.
void Measure(const CalibrationData& data, ToolResult* t);

// Seconds since an arbitrary origin (steady clock).
double Now();

}  // namespace svms

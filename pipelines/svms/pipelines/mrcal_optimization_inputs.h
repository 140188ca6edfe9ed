// An SVMS calibration as mrcal's 'optimization_inputs', so that mrcal's own tools
// (mrcal-show-projection-uncertainty, mrcal-show-residuals-board-observation, ...,
// mrcal.projection_uncertainty) work on a model `svms calibrate` wrote.
//
// What is written is the problem SVMS solved, in mrcal 2.2's terms: one camera at the reference
// (no extrinsics), the board poses as frames_rt_toref, the board's points laid on mrcal's
// regular calibration-object grid (board_grid.h: observations_board (views, H, W, 3) of x, y,
// weight; the grid nodes that are no marker corner, and the outliers SVMS rejected, at weight
// -1), weight = reference sigma / the point's sigma as in SVMS's own residuals, the board warp
// (optimised only when SVMS optimised it), the corners moved by SVMS's fitted edge bias
// (calibrate.h; mrcal has no such parameter, so its covariance lacks that one dimension), mrcal's
// regularisation off for the models SVMS solves without a prior (it would add rows SVMS's
// covariance does not have) and on for the splined models (which need one; mrcal's then differs
// from SVMS's spline prior). mrcal re-evaluates this problem at the stored optimum, so its
// covariance is SVMS's up to the estimate of the corner noise (mrcal: the residuals' standard
// deviation; SVMS: over the degrees of freedom) and the splined models' prior.
//
// Written by mrcal's own Python (`/usr/bin/python3`, no shell: run_program.h): the key is a
// base85-encoded compressed numpy archive that only numpy writes conveniently, and mrcal's
// cameramodel writer is the one reader the format must satisfy. Python then reads the result
// back and checks that mrcal's residuals at the stored optimum are SVMS's. The model text that
// SVMS writes is kept byte for byte; the two keys are added before its closing brace.
#pragma once

#include <string>
#include <vector>

#include "svms/base/status.h"
#include "svms/calib/calibrate.h"
#include "svms/calib/observations.h"

namespace svms {

struct MrcalInputsOptions {
  std::string python = "/usr/bin/python3";  // a Python with numpy and mrcal 2.2
  bool board_warp = false;                  // the calibration optimised the warp
  // Largest grid (nodes per board view) written: a finer grid makes mrcal evaluate that many
  // points per view (about 24 bytes each per view in the file before compression).
  int max_grid_nodes = 20000;
};

// `model_text`: the model as CameraModel::ToText wrote it for `result.camera`. `views`: every
// input view (result.views indexes into it); `image_names`: per input view, its file (mrcal's
// imagepaths). On success *text is model_text with 'icam_intrinsics' and 'optimization_inputs'
// added. Errors are one line saying why mrcal 2.2 cannot carry this calibration (points off one
// regular grid, a post tip, two points on one node), or why its Python failed (not there: exit
// 127 or an ImportError; mrcal refusing the problem; residuals that differ from SVMS's).
Status MrcalOptimizationInputsText(const CalibrationResult& result,
                                   const std::vector<ViewObservations>& views,
                                   const std::vector<std::string>& image_names,
                                   const std::string& model_text, const MrcalInputsOptions& options,
                                   std::string* text);

}  // namespace svms

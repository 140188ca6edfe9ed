// The report of a calibration run (`svms calibrate --report DIR`): residuals, coverage and
// projection uncertainty as data files, gnuplot pictures and summary.json.
#pragma once

#include <vector>

#include "svms/base/file_io.h"
#include "svms/base/status.h"
#include "svms/pipelines/calibration_run.h"

namespace svms {

// Adds the report's files for options.report_dir to `files` (committed by the caller with the
// model) and fills the outcome's coverage and uncertainty figures. `views` are the observations
// outcome->result was solved on.
Status AddCalibrationReport(const CalibrateRunOptions& options,
                            const std::vector<ViewObservations>& views,
                            CalibrateRunOutcome* outcome, AtomicFileSet* files);

}  // namespace svms

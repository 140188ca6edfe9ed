// Plots for the benchmark reports: a gnuplot script rendered to PNG and SVG.
#pragma once

#include <string>

#include "svms/status.h"

namespace svms::cli {

// Runs gnuplot on `script` (plot commands only: no `set terminal`/`set output`) twice, writing
// BASE.png (1000 x 650) and BASE.svg. The script is kept as BASE.gp next to them so that a
// reader can re-plot. Fails with gnuplot's message if gnuplot is missing or the script is bad.
Status PlotPngSvg(const std::string& script, const std::string& base);

}  // namespace svms::cli

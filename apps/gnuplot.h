// Plots for reports: runs gnuplot on a script, once for PNG and once for SVG.
#pragma once

#include <string>

#include "svms/status.h"

namespace svms::cli {

// Writes DIR/NAME.gp (the `body` after a terminal and output line for NAME.png, then again for
// NAME.svg) and runs gnuplot in DIR; gnuplot's messages go to DIR/NAME.gp.log. `body` refers to
// data files by names relative to DIR. `size` is the picture's "width,height" in pixels.
Status Gnuplot(const std::string& dir, const std::string& name, const std::string& body,
               const std::string& size = "900,700");

}  // namespace svms::cli

// Plots for reports: the one place that runs gnuplot (through RunProgram: no shell).
#pragma once

#include <string>

#include "svms/base/file_io.h"
#include "svms/base/status.h"

namespace svms {

// Writes DIR/NAME.gp (the `body` after a terminal and output line for NAME.png, then again for
// NAME.svg) and runs gnuplot on it in DIR; gnuplot's messages go to DIR/NAME.gp.log. `body`
// refers to data files by names relative to DIR. `size` is the picture's "width,height" in
// pixels. The pictures are drawn into temporaries and renamed into place when gnuplot
// succeeds (with `into`: handed to that set, renamed at its Commit), so a failed plot leaves
// earlier pictures as they were.
Status Gnuplot(const std::string& dir, const std::string& name, const std::string& body,
               const std::string& size = "900,700", AtomicFileSet* into = nullptr);

}  // namespace svms

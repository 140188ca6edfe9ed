// The photometry options of every command that reads images (--response, --black-level,
// --white-level, --bayer), registered on a command (svms/pipelines/photometry.h resolves them).
#pragma once

#include <CLI/CLI.hpp>

#include "svms/pipelines/photometry.h"

namespace svms::cli {

void AddPhotometryOptions(CLI::App* command, PhotometryOptions* options);

}  // namespace svms::cli

// Rendering a scene to files: every view's image and truth.json (docs/simulator.md).
#pragma once

#include <string>

#include "svms/base/file_io.h"
#include "svms/sim/scene.h"

namespace svms {

// Renders every view of `scene` into `out_dir` (VIEW.png or the sensor's format, truth.json;
// with `write_radiance` also VIEW.exr, the noise-free radiance) on `threads` threads, progress on
// stderr unless `quiet`; `source` names the scene in messages ("svms render: ..."). Returns an
// exit code (exit_codes.h) and prints what it rendered on stdout. The files are written as one
// group (file_io.h); with `into` they are added to that group instead, for the caller to
// commit with its own.
int RenderScene(const Scene& scene, const std::string& source, const std::string& out_dir,
                int threads, bool write_radiance, bool quiet, AtomicFileSet* into = nullptr);

}  // namespace svms

// Rendering a scene to files: every view's image and truth.json (docs/simulator.md).
#pragma once

#include <string>
#include <vector>

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

// One camera pipeline of RenderSceneThrough: the sensor a view's light is exposed through and
// the directory its images and truth.json go to.
struct SensorOutput {
  Sensor sensor;
  std::string out_dir;
};

// The scene seen through several camera pipelines from one ray cast: each view's radiance is
// rendered once and exposed through every output's sensor. Each directory gets, byte for byte,
// what RenderScene writes for `scene` with scene.sensor = that output's sensor (same radiance,
// same noise seed; tested), for the ray casting's cost of one. Every sensor must pass
// CheckSensor and cast the same rays as scene.sensor (SharesRadiance, render.h), and each
// output needs a directory of its own; otherwise no directory is made, nothing is rendered and
// the exit code is kExitBadInput. All outputs are committed as one group, or none.
int RenderSceneThrough(const Scene& scene, const std::vector<SensorOutput>& outputs,
                       const std::string& source, int threads, bool quiet);

}  // namespace svms

// Checks of a run's outputs made before any work: an output never replaces an input, and an
// output directory exists and is writable (docs/reliability.md).
#pragma once

#include <string>
#include <vector>

#include "svms/base/status.h"

namespace svms {

// Checks that the output file `out` is none of `inputs` (same device and inode, so links and
// other spellings count): "FLAG OUT: is the input INPUT; expected a new file name". Ok when it
// does not exist yet. `flag` names the option that gave `out` in the message.
Status CheckNotAnInput(const std::string& flag, const std::string& out,
                       const std::vector<std::string>& inputs);

// Creates the directory `dir` for an option `flag` (with its parents) and checks that files can
// be written in it: "FLAG DIR: is a file; expected a directory", "...: cannot create the
// directory: Permission denied", "...: cannot write in it: Read-only file system".
Status PrepareOutputDirectory(const std::string& flag, const std::string& dir);

}  // namespace svms

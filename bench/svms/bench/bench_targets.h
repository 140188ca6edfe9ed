// The targets a benchmark holds the method to, judged on the benchmark's own run.
#pragma once

#include <string>
#include <vector>

namespace svms {

// Each target is written into the report with its verdict and what the run measured; a run that
// misses any of them ends with kExitTargetMissed (after writing every output), so that the
// --quick runs in `make test` fail when the method regresses instead of printing "not met".
// A target that a run cannot judge (too small a sample with --quick) is listed with the reason
// and does not count.
class BenchTargets {
 public:
  // "what: **met** (measured)." or "**not met**".
  void Add(const std::string& what, bool met, const std::string& measured);
  void NotJudged(const std::string& what, const std::string& why);
  // One markdown list item per target, in the order added.
  std::string Markdown() const;
  bool all_met() const;
  // kExitTargetMissed when a target was missed, else `otherwise`. Prints which on stderr.
  int ExitCode(const std::string& command, int otherwise) const;

 private:
  struct Target {
    std::string what, measured;
    bool judged = true, met = false;
  };
  std::vector<Target> targets_;
};

}  // namespace svms

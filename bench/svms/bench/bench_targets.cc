#include "svms/bench/bench_targets.h"

#include <iostream>

#include "svms/pipelines/exit_codes.h"

namespace svms {

void BenchTargets::Add(const std::string& what, bool met, const std::string& measured) {
  targets_.push_back({what, measured, true, met});
}

void BenchTargets::NotJudged(const std::string& what, const std::string& why) {
  targets_.push_back({what, why, false, false});
}

std::string BenchTargets::Markdown() const {
  std::string md;
  for (const Target& t : targets_) {
    md += "- " + t.what + ": ";
    md += !t.judged ? "not judged" : t.met ? "**met**" : "**not met**";
    if (!t.measured.empty()) md += " (" + t.measured + ")";
    md += ".\n";
  }
  return md;
}

bool BenchTargets::all_met() const {
  for (const Target& t : targets_)
    if (t.judged && !t.met) return false;
  return true;
}

int BenchTargets::ExitCode(const std::string& command, int otherwise) const {
  int missed = 0;
  for (const Target& t : targets_)
    if (t.judged && !t.met) {
      std::cerr << command << ": target not met: " << t.what << " (" << t.measured << ")\n";
      ++missed;
    }
  return missed ? kExitTargetMissed : otherwise;
}

}  // namespace svms

// The survey benchmark (`svms bench survey`): the survey (bundle/) on the rendered mockup
// dataset against its truth, a NEES Monte-Carlo, timing, and the naive pairwise-averaging
// approach as the baseline. Writes markers.csv, errors.dat, plots, survey_report/ and report.md
// to options.out.
#pragma once

#include <string>

namespace svms {

struct SurveyBenchmarkOptions {
  std::string out;     // the output directory
  std::string data;    // a rendered mockup dataset to reuse ("" = render one into OUT/mockup)
  bool quick = false;  // the quick mockup, 10 Monte-Carlo runs, 300 x 40 timing
  int runs = 100;      // Monte-Carlo runs
  int threads = 2;     // rendering and detection
};

// Runs the benchmark. Returns an exit code (exit_codes.h): 3 when a target was missed, 1 when
// the survey failed or an output could not be written; report.md also on stdout.
int RunSurveyBenchmark(const SurveyBenchmarkOptions& options);

}  // namespace svms

// The detector benchmark's outputs (detect_benchmark.h): the CSV tables, and report.md with
// its plots and summary.json, every target judged on the run's own numbers.
#pragma once

#include <map>
#include <string>

#include "svms/bench/detect_benchmark.h"
#include "svms/bench/detect_scoring.h"

namespace svms {

// markers.csv and views.csv in options.out, `results` by set name.
void WriteDetectTables(const DetectBenchmarkOptions& options,
                       const std::map<std::string, SetResult>& results);

// report.md, summary.json and the plots in options.out; `seconds` the run's wall time. Returns
// whether every target was met.
bool WriteDetectReport(const DetectBenchmarkOptions& options,
                       const std::map<std::string, SetResult>& results, double seconds);

}  // namespace svms

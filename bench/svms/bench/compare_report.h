// The comparison benchmark's outputs (compare_benchmark.h): the data files (compare_tables.h),
// and report.md with the targets judged on this run's numbers, also on stdout.
#pragma once

#include "svms/bench/compare_benchmark.h"
#include "svms/bench/compare_records.h"

namespace svms {

// Writes every output of `run` to options.out; returns the benchmark's exit code (exit_codes.h):
// 1 when a scene or a plot failed, 3 when a target was missed.
int WriteCompareReport(const CompareBenchmarkOptions& options, const CompareRun& run);

}  // namespace svms

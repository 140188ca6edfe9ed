// The comparison benchmark's data files (compare_benchmark.h): per marker, image and Fig. 9
// view as CSV, the figures as summary.json, and the plots with their per-sweep data.
#pragma once

#include <filesystem>
#include <nlohmann/json.hpp>

#include "svms/bench/compare_benchmark.h"
#include "svms/bench/compare_records.h"

namespace svms {

// markers.csv, images.csv and fig9.csv in `dir`.
void WriteCompareCsv(const std::filesystem::path& dir, const CompareRun& run);

// summary.json and fig9_summary.csv in `dir`; returns the Fig. 9 rows by distance (each
// {distance_m, views, found, range_err_mm_rms, orientation_err_deg_rms}) for the report.
nlohmann::json WriteCompareSummary(const std::filesystem::path& dir,
                                   const CompareBenchmarkOptions& o, const CompareRun& run,
                                   CompareTallies& tallies);

// The per-sweep CSVs and the plots (compare_size, compare_size_orientation, compare_angle,
// compare_occlusion, fig9). False when gnuplot failed (the message on stderr).
bool WriteComparePlots(const std::filesystem::path& dir, const CompareRun& run,
                       CompareTallies& tallies);

}  // namespace svms

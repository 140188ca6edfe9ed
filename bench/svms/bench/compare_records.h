// The comparison benchmark's records (compare_benchmark.h): what each system found in each
// image, and the tallies the tables are made of.
#pragma once

#include <chrono>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "svms/peers/compare_metrics.h"
#include "svms/peers/compare_scenes.h"

namespace svms {

// One image as one system saw it: time (detection + pose, one core) and what it reported.
struct ImageRecord {
  std::string sweep, view, config;
  double ms = 0;
  int detections = 0, false_positives = 0, wrong_ids = 0;
};

// One true marker of one image as one system saw it, with the condition the sweep bins it by.
struct MarkerRecord {
  std::string sweep, view, condition, config, family;
  MarkerOutcome m;
};

// One view of the range set (Fig. 9): the SVMS dual marker's errors.
struct Fig9Row {
  std::string view;
  double distance = 0;
  std::string used;  // "outer", "inner" or "none"
  double range_err_mm = NAN, orient_err_deg = NAN;
};

// The condition a sweep bins a marker by: the size ("030"), the angle ("60"), the occluded
// fraction ("10-20%") or the light ("sun", "lowsun", "edge", "shadow").
std::string Condition(const std::string& sweep, const std::string& view, const MarkerOutcome& m);

// The markers of one system under one condition (or all), counted.
struct Tally {
  int eligible = 0, detected = 0, wrong = 0;
  std::vector<double> side, corner, range_rel, orient, nees;
  int flips = 0, planar_flips = 0, unflagged_flips = 0, flagged = 0, posed = 0;
  int flips_alternative_right = 0;  // flips whose alternative pose is within kFlipDeg
  // The flips the system's own ambiguity weights predict: the sum of the alternative poses'
  // likelihood shares, where an alternative lies more than kFlipDeg from its pose.
  double expected_flips = 0;
  void Add(const MarkerOutcome& m);
  // Mean NEES (6 for an honest covariance) and the share below chi-square(6)'s 95th percentile.
  double nees_mean() const;
  double nees_within_95() const;
  double rate() const { return eligible ? static_cast<double>(detected) / eligible : NAN; }
  nlohmann::json Json() const;
};

// Times and false positives of one system over the images.
struct Timing {
  std::vector<double> all, clutter;  // ms per image
  int fp_clutter = 0, fp_scenes = 0, wrong = 0, clutter_images = 0;
};

// Everything the run measured.
struct CompareRun {
  CompareOptions scenes;  // how the sweeps' scenes were made
  std::vector<CompareSweep> sweeps;
  std::vector<std::string> names;                     // the systems, svms first
  nlohmann::json settings = nlohmann::json::array();  // each system's settings
  std::vector<ImageRecord> images;
  std::vector<MarkerRecord> markers;
  std::vector<Fig9Row> fig9;
  int failures = 0;  // scenes that could not be rendered
  std::chrono::steady_clock::time_point start;
};

// The run's tallies per system (config name). Looked up with operator[], as the tables do.
struct CompareTallies {
  std::map<std::string, Tally> overall, small;  // small: size sweep, min side <= 30 px
  std::map<std::string, std::map<std::string, std::map<std::string, Tally>>> by;  // sweep/cond/cfg
  std::map<std::string, Timing> timing;
};
CompareTallies TallyRun(const CompareRun& run);

// Milliseconds of a duration.
double Ms(std::chrono::steady_clock::duration d);

}  // namespace svms

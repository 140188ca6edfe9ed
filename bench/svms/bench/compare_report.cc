#include "svms/bench/compare_report.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "svms/base/statistics.h"
#include "svms/bench/bench_targets.h"
#include "svms/bench/compare_tables.h"
#include "svms/bench/report_numbers.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/pipelines/report_file.h"

namespace svms {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// report.md, every number from this run, built section by section.
class Report {
 public:
  Report(const CompareBenchmarkOptions& o, const CompareRun& run, CompareTallies& tallies,
         const json& fig9_by_distance)
      : o_(o), run_(run), t_(tallies), jf_(fig9_by_distance) {}

  // What was compared and how, and a row per system.
  void Systems() {
    md_ << "## Comparison with AprilTag 3 and OpenCV ArUco\n\n"
        << "Written by `svms bench compare" << (o_.quick ? " --quick" : "")
        << (o_.size_views != 8 ? " --size-views " + std::to_string(o_.size_views) : "")
        << (o_.post_height != CompareOptions{}.post_height_fraction
                ? " --post-height " + Cell(o_.post_height, 2)
                : "")
        << (o_.edge_rays != CompareOptions{}.edge_rays_per_pixel
                ? " --edge-rays " + std::to_string(o_.edge_rays)
                : "")
        << " --seed " << o_.seed << "` ("
        << Cell(Ms(std::chrono::steady_clock::now() - run_.start) / 1000, 0)
        << " s). The same scenes are rendered three times, with an SVMS marker, an AprilTag "
           "tag36h11 and an ArUco DICT_6X6_1000 tag printed on the same geometry: same camera "
           "(1024x1024 pinhole, f = 1111.1 px), poses, light, occluders, sensor noise and seed; "
        << run_.sweeps[0].scene.sensor.rays_per_pixel << " rays per pixel"
        << (run_.scenes.edge_rays_per_pixel > run_.sweeps[0].scene.sensor.rays_per_pixel
                ? ", " + std::to_string(run_.scenes.edge_rays_per_pixel) + " on edge pixels"
                : "")
        << ". "
           "Every tag's outer black edge is the SVMS black square (side "
        << Cell(run_.scenes.marker_size * 1000, 0) << " mm; the SVMS post "
        << Cell(run_.scenes.post_height_fraction * run_.scenes.marker_size * 1000, 0)
        << " mm tall), so all systems report the same four corners in space; the peers' 8x8 "
           "cells are side/8, and the SVMS data ring lies outside the square (its decal is twice "
           "as wide: for equal footprint, read the SVMS curves at twice the pixel size). Every "
           "system decodes its whole family (SVMS 32768 IDs, no known-ID filter). Peer poses: IPPE "
           "(`SOLVEPNP_IPPE_SQUARE`) on the four corners, undistorted by the same camera model. "
           "Times: detection + pose, one core, on a shared machine. All settings: `summary.json`; "
           "per marker: `markers.csv`; per image: `images.csv`.\n\n";
    md_ << "| system | detected | at <= 30 px | wrong IDs | false pos. (clutter, "
        << t_.timing["svms"].clutter_images
        << " images) | corner RMS px (median) | range err % (median) | orientation err deg "
           "(median / p95) | pose flips (>10 deg) | of them planar / not flagged | poses flagged "
           "ambiguous | ms/image median | ms p99 | ms clutter median |\n"
        << "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const std::string& n : run_.names) {
      const Tally& t = t_.overall[n];
      const Tally& s = t_.small[n];
      const Timing& tm = t_.timing[n];
      md_ << "| " << n << " | " << t.detected << "/" << t.eligible << " ("
          << Cell(100 * t.rate(), 1) << " %) | " << s.detected << "/" << s.eligible << " ("
          << Cell(100 * s.rate(), 1) << " %) | " << tm.wrong << " | " << tm.fp_clutter << " | "
          << Cell(Median(t.corner), 3) << " | " << Cell(Median(t.range_rel), 2) << " | "
          << Cell(Median(t.orient), 2) << " / " << Cell(Percentile(t.orient, 0.95), 2) << " | "
          << t.flips << "/" << t.posed << " (" << Cell(t.posed ? 100.0 * t.flips / t.posed : NAN, 1)
          << " %) | " << t.planar_flips << " / " << t.unflagged_flips << " | " << t.flagged << " | "
          << Cell(Median(tm.all), 1) << " | " << Cell(Percentile(tm.all, 0.99), 1) << " | "
          << Cell(Median(tm.clutter), 1) << " |\n";
    }
    md_ << "\nA flip is *planar* when the pose is nearer the truth's planar twin (its normal "
           "mirrored about the line of sight: what four coplanar corners cannot tell from the "
           "truth under weak perspective) than the truth, the twin being itself more than 10 deg "
           "from the truth (a view angle above 5 deg). The other flips are measurement noise: a "
           "head-on marker's twin is its own pose. SVMS flags a pose *ambiguous* when its planar "
           "twin keeps more than 1 % of "
           "the likelihood (the peers flag nothing).\n";
  }

  // The comparison's targets, checked on this run's numbers.
  void Targets() {
    {
      const Tally& sv = t_.small["svms"];
      bool ahead = true, orient_all = true, has_peer_orient = false;
      std::string slower_than;
      double fastest_peer_ms = INFINITY;
      for (const std::string& n : run_.names) {
        if (n == "svms") continue;
        // Ahead, or both find every marker (nothing is left to be ahead by).
        ahead = ahead &&
                (sv.rate() > t_.small[n].rate() || (sv.rate() == 1 && t_.small[n].rate() == 1));
        for (const auto& [cond, cfgs] : t_.by["size"]) {
          const auto a = cfgs.find("svms"), b = cfgs.find(n);
          if (a == cfgs.end() || b == cfgs.end() || b->second.orient.empty()) continue;
          has_peer_orient = true;
          if (a->second.orient.empty() || Median(a->second.orient) >= Median(b->second.orient))
            orient_all = false;
        }
        if (t_.overall[n].detected >= t_.overall["svms"].detected) {
          fastest_peer_ms = std::min(fastest_peer_ms, Median(t_.timing[n].all));
          if (Median(t_.timing[n].all) <= Median(t_.timing["svms"].all)) slower_than += " " + n;
        }
      }
      const double svms_ms = Median(t_.timing["svms"].all);
      targets_.Add(
          "Detection rate at 30 px and below ahead of every peer configuration (or both find "
          "every marker)",
          ahead, "svms " + Cell(100 * sv.rate(), 1) + " %");
      targets_.Add(
          "Orientation error (median) below every peer configuration at every size of the size "
          "sweep",
          orient_all && has_peer_orient, "");
      const auto& ov = t_.overall["svms"];
      targets_.Add(
          "No pose flips", ov.flips == 0,
          std::to_string(ov.flips) + ", of them planar " + std::to_string(ov.planar_flips) +
              ", not flagged ambiguous " + std::to_string(ov.unflagged_flips) +
              ", with the alternative pose given beside the flag within " + Cell(kFlipDeg, 0) +
              " deg of the truth " + std::to_string(ov.flips_alternative_right));
      const std::string faster =
          "Faster per image (median) than every peer configuration that detects at least as many "
          "markers";
      const std::string twice = "at least 2x faster than the fastest of them";
      if (!std::isfinite(fastest_peer_ms)) {
        targets_.Add(faster + ", and " + twice, true,
                     "no peer configuration detects as many markers");
      } else {
        const std::string measured =
            "svms " + Cell(svms_ms, 1) + " ms, fastest such peer " + Cell(fastest_peer_ms, 1) +
            " ms" + (slower_than.empty() ? "" : "; not faster than:" + slower_than);
        // The quick run times few images on a machine that may be busy (make test runs two tests
        // at once), and a peer may tie: speed is judged by the full run only.
        if (o_.quick) {
          targets_.NotJudged(
              faster + ", and " + twice,
              "the quick run times too few images on a machine that may be busy: " + measured);
        } else {
          targets_.Add(faster + ", and " + twice, svms_ms * 2 <= fastest_peer_ms, measured);
        }
      }
      md_ << "\nTargets, on this run:\n\n" << targets_.Markdown();
    }
  }

  // The plots, and detected / eligible per sweep.
  void PerSweep() {
    md_ << "\n![](compare_size.png)\n\n![](compare_size_orientation.png)\n\n![](compare_angle.png)"
           "\n\n![](compare_occlusion.png)\n\n";
    md_ << "Per sweep, detected / eligible (and orientation error, median deg):\n\n| sweep |";
    for (const std::string& n : run_.names) md_ << " " << n << " |";
    md_ << "\n|---|";
    for (size_t i = 0; i < run_.names.size(); ++i) md_ << "---|";
    md_ << "\n";
    for (const CompareSweep& sw : run_.sweeps) {
      md_ << "| " << sw.name << " |";
      for (const std::string& n : run_.names) {
        Tally t;
        for (const MarkerRecord& r : run_.markers)
          if (r.sweep == sw.name && r.config == n) t.Add(r.m);
        md_ << " " << t.detected << "/" << t.eligible << " (" << Cell(Median(t.orient), 2) << ") |";
      }
      md_ << "\n";
    }
    md_ << "\n";
  }

  // Flips are rare events at the smallest sizes: per size, so that a larger sample
  // (--size-views) shows where they are.
  void Flips() {
    md_ << "Pose flips (orientation error > 10 deg) by size, up to 30 px: flips / posed (of them "
           "planar):\n\n| size (px) |";
    for (const std::string& n : run_.names) md_ << " " << n << " |";
    md_ << "\n|---|";
    for (size_t i = 0; i < run_.names.size(); ++i) md_ << "---|";
    md_ << "\n";
    for (const auto& [c, cfgs] : t_.by["size"]) {
      if (std::stoi(c) > 30) continue;
      md_ << "| " << std::stoi(c) << " |";
      for (const std::string& n : run_.names) {
        const auto it = cfgs.find(n);
        const int flips = it == cfgs.end() ? 0 : it->second.flips;
        const int posed = it == cfgs.end() ? 0 : it->second.posed;
        const int planar = it == cfgs.end() ? 0 : it->second.planar_flips;
        md_ << " " << flips << "/" << posed << " (" << planar << ") |";
      }
      md_ << "\n";
    }
    md_ << "\n";
  }

  // The flag's weight is a probability: do the flips it predicts match the flips seen?
  void Flags() {
    md_ << "SVMS ambiguity flags by size, up to 30 px: poses flagged, flips, and the flips the "
           "detector's own weights predict (the sum of each flagged pose's alternative's share of "
           "the likelihood, where the alternative is more than "
        << Cell(kFlipDeg, 0)
        << " deg from the pose). Honest weights give about as many flips as predicted.\n\n"
           "| size (px) | posed | flagged | flips | predicted |\n|---|---|---|---|---|\n";
    {
      for (const auto& [c, cfgs] : t_.by["size"]) {
        if (std::stoi(c) > 30) continue;
        const auto it = cfgs.find("svms");
        if (it == cfgs.end()) continue;
        const Tally& t = it->second;
        md_ << "| " << std::stoi(c) << " | " << t.posed << " | " << t.flagged << " | " << t.flips
            << " | " << Cell(t.expected_flips, 2) << " |\n";
      }
      const Tally& all = t_.overall["svms"];
      md_ << "| all sweeps | " << all.posed << " | " << all.flagged << " | " << all.flips << " | "
          << Cell(all.expected_flips, 2) << " |\n\n";
    }
  }

  // The covariance is what a user fuses and gates with: is it honest, by size and sweep?
  void Nees() {
    md_ << "SVMS pose covariance (the peers give none): each pose's 6-dof NEES against the truth, "
           "with the detector's covariance (the planar twin's share included where the pose is "
           "flagged ambiguous). An honest covariance gives a mean of 6, a median of 5.35 and 95 % "
           "of the poses below "
        << Cell(kChi2Dof6P95, 2)
        << " (chi-square, 6 dof); a mean above 6 is overconfidence, or a few large errors.\n\n"
           "| size (px) | posed | NEES mean | median | below "
        << Cell(kChi2Dof6P95, 2) << " |\n|---|---|---|---|---|\n";
    auto nees_row = [&](const std::string& label, const Tally& t) {
      md_ << "| " << label << " | " << t.nees.size() << " | " << Cell(t.nees_mean(), 2) << " | "
          << Cell(Median(t.nees), 2) << " | " << Cell(100 * t.nees_within_95(), 0) << " % |\n";
    };
    for (const auto& [c, cfgs] : t_.by["size"]) {
      const auto it = cfgs.find("svms");
      if (it != cfgs.end()) nees_row(std::to_string(std::stoi(c)), it->second);
    }
    for (const CompareSweep& sw : run_.sweeps) {
      Tally t;
      for (const MarkerRecord& r : run_.markers)
        if (r.sweep == sw.name && r.config == "svms") t.Add(r.m);
      nees_row("all of the " + sw.name + " sweep", t);
    }
    nees_row("all sweeps", t_.overall["svms"]);
    {
      // The poses that weigh most in the means: where the covariance is least honest.
      std::vector<const MarkerRecord*> worst;
      for (const MarkerRecord& r : run_.markers)
        if (r.config == "svms" && std::isfinite(r.m.pose_nees)) worst.push_back(&r);
      const size_t k = std::min<size_t>(3, worst.size());
      std::partial_sort(worst.begin(), worst.begin() + k, worst.end(),
                        [](const MarkerRecord* a, const MarkerRecord* b) {
                          return a->m.pose_nees > b->m.pose_nees;
                        });
      md_ << "\nLargest NEES:";
      for (size_t i = 0; i < k; ++i) {
        const MarkerOutcome& m = worst[i]->m;
        md_ << (i ? ";" : "") << " " << worst[i]->view << " (" << Cell(m.min_side_px, 0) << " px, "
            << Cell(m.view_angle_deg, 0) << " deg off-axis): NEES " << Cell(m.pose_nees, 1)
            << ", orientation error " << Cell(m.orientation_err_deg, 2) << " deg, range error "
            << Cell(1000 * m.range_err_m, 1) << " mm"
            << (m.pose_ambiguous ? ", flagged ambiguous" : "");
      }
      md_ << ".\n";
    }
    md_ << "\n";
  }

  // Sun and shadow.
  void Sun() {
    md_ << "Sun and shadow (75 px, camera 20 deg off-axis), detected:\n\n| condition |";
    for (const std::string& n : run_.names) md_ << " " << n << " |";
    md_ << "\n|---|";
    for (size_t i = 0; i < run_.names.size(); ++i) md_ << "---|";
    md_ << "\n";
    for (const std::string c : {"sun", "lowsun", "edge", "shadow"}) {
      if (!t_.by["sun"].count(c)) continue;
      md_ << "| "
          << (c == "sun"      ? "sun, elevation > 15 deg"
              : c == "lowsun" ? "low sun, <= 15 deg"
              : c == "edge"   ? "shadow edge across the marker"
                              : "whole marker in shadow")
          << " |";
      for (const std::string& n : run_.names) {
        const Tally& t = t_.by["sun"][c][n];
        md_ << " " << t.detected << "/" << t.eligible << " |";
      }
      md_ << "\n";
    }
  }

  // The sweeps, and the range and orientation error against distance.
  void SweepsAndFig9() {
    md_ << "\nSweeps:\n\n";
    for (const CompareSweep& sw : run_.sweeps)
      md_ << "- " << sw.name << ": " << sw.description << ".\n";
    md_ << "- clutter: the standard clutter set (" << t_.timing["svms"].clutter_images
        << " images, OPENCV8 camera, no markers): every detection is a false positive.\n\n";
    md_ << "### Range and orientation error against distance (cf. the paper's Fig. 9)\n\n"
        << "The dual SVMS marker (0.432 m, inner 0.108 m) of the range set, 1024x1024 pinhole "
           "(0.432 m = 30 px at 16 m), nearly head-on; the pose of the larger marker found. RMS "
           "over the views at each distance; the paper's two reported points in black.\n\n"
        << "| distance (m) | views | found | range error RMS (mm) | orientation error RMS (deg) |\n"
        << "|---|---|---|---|---|\n";
    for (const json& r : jf_)
      md_ << "| " << Cell(r["distance_m"].get<double>(), 2) << " | " << r["views"] << " | "
          << r["found"] << " | "
          << (r["range_err_mm_rms"].is_null() ? "-" : Cell(r["range_err_mm_rms"].get<double>(), 2))
          << " | "
          << (r["orientation_err_deg_rms"].is_null()
                  ? "-"
                  : Cell(r["orientation_err_deg_rms"].get<double>(), 3))
          << " |\n";
    md_ << "| paper | | | 1 at 0.8 m, 42 at 16 m | 0.16 at 0.8 m, 1.7 at 16 m |\n\n![](fig9.png)\n";
  }

  std::string text() const { return md_.str(); }
  const BenchTargets& targets() const { return targets_; }

 private:
  const CompareBenchmarkOptions& o_;
  const CompareRun& run_;
  CompareTallies& t_;
  const json& jf_;
  std::ostringstream md_;
  BenchTargets targets_;
};

}  // namespace

int WriteCompareReport(const CompareBenchmarkOptions& o, const CompareRun& run) {
  const fs::path dir(o.out);
  WriteCompareCsv(dir, run);
  CompareTallies tallies = TallyRun(run);
  const json jf = WriteCompareSummary(dir, o, run, tallies);
  const bool plots_ok = WriteComparePlots(dir, run, tallies);
  Report report(o, run, tallies, jf);
  report.Systems();
  report.Targets();
  report.PerSweep();
  report.Flips();
  report.Flags();
  report.Nees();
  report.Sun();
  report.SweepsAndFig9();
  OutputFile(dir / "report.md") << report.text();
  std::cout << report.text();
  std::cout << "wrote " << (dir / "report.md").string() << ", summary.json, markers.csv, "
            << "images.csv, fig9.csv and plots\n";
  if (run.failures > 0 || !plots_ok) {
    std::cerr << "svms bench compare: " << run.failures << " scene(s) failed"
              << (plots_ok ? "" : ", plotting failed") << "\n";
    return kExitFailed;
  }
  return report.targets().ExitCode("svms bench compare", kExitOk);
}

}  // namespace svms

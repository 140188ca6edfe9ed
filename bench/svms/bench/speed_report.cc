#include "svms/bench/speed_report.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <map>
#include <sstream>
#include <thread>

#include "svms/base/statistics.h"
#include "svms/bench/bench_targets.h"
#include "svms/bench/report_numbers.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/pipelines/gnuplot.h"
#include "svms/pipelines/report_file.h"

namespace svms {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

const std::map<std::string, std::string>& ClassDescriptions() {
  static const std::map<std::string, std::string> d = {
      {"photo_1024", "marker-free crops, 1024 x 1024"},
      {"photo_640", "marker-free crops, 640 x 480"},
      {"markers_1024", "the same crops with 4 markers rendered in, 1024 x 1024"},
      {"markers_640", "the same crops with 2 markers rendered in, 640 x 480"}};
  return d;
}

// Size bins of the detection table: the projected square's shortest side, px.
const std::vector<std::pair<double, double>>& SizeBins() {
  static const std::vector<std::pair<double, double>> b = {{0, 16},  {16, 24},  {24, 40},
                                                           {40, 70}, {70, 120}, {120, 1e9}};
  return b;
}
std::string BinName(const std::pair<double, double>& b) {
  if (b.first == 0) return "< " + Cell(b.second, 0);
  if (b.second > 1e8) return ">= " + Cell(b.first, 0);
  return Cell(b.first, 0) + "-" + Cell(b.second, 0);
}

// Times and counts of one system on one class.
struct Stats {
  std::vector<double> ms;
  int images = 0, detections = 0, false_positives = 0, wrong_ids = 0, flagged = 0;
  int eligible = 0, detected = 0;
  const SpeedRecord* slowest = nullptr;
  double median() const { return Median(ms); }
  double p90() const { return Percentile(ms, 0.90); }
  double p99() const { return Percentile(ms, 0.99); }
  double max() const { return ms.empty() ? NAN : *std::max_element(ms.begin(), ms.end()); }
  double rate() const { return eligible ? static_cast<double>(detected) / eligible : NAN; }
  json Json() const {
    return {{"images", images},
            {"median_ms", median()},
            {"p90_ms", p90()},
            {"p99_ms", p99()},
            {"max_ms", max()},
            {"detections", detections},
            {"false_positives", false_positives},
            {"wrong_ids", wrong_ids},
            {"budget_exceeded", flagged},
            {"markers", eligible},
            {"markers_detected", detected},
            {"detection_rate", eligible ? json(rate()) : json()}};
  }
};

using StatsTable = std::map<std::string, std::map<std::string, Stats>>;  // class, system

StatsTable Tally(const SpeedRun& run) {
  StatsTable t;
  for (const SpeedRecord& r : run.images) {
    Stats& s = t[r.cls][r.system];
    s.ms.push_back(r.ms);
    ++s.images;
    s.detections += r.detections;
    s.false_positives += r.false_positives;
    s.wrong_ids += r.wrong_ids;
    s.flagged += r.budget_exceeded;
    if (!s.slowest || r.ms > s.slowest->ms) s.slowest = &r;
  }
  for (const SpeedMarker& m : run.markers) {
    if (!m.eligible) continue;
    Stats& s = t[m.cls][m.system];
    ++s.eligible;
    s.detected += m.detected;
  }
  return t;
}

// Found / eligible per system and size bin, over both markers classes.
std::map<std::string, std::vector<std::pair<int, int>>> BySize(const SpeedRun& run) {
  std::map<std::string, std::vector<std::pair<int, int>>> out;
  for (const std::string& sys : run.systems) out[sys].assign(SizeBins().size(), {0, 0});
  for (const SpeedMarker& m : run.markers) {
    if (!m.eligible || !out.count(m.system)) continue;
    for (size_t b = 0; b < SizeBins().size(); ++b)
      if (m.min_side_px >= SizeBins()[b].first && m.min_side_px < SizeBins()[b].second) {
        out[m.system][b].first += m.detected;
        ++out[m.system][b].second;
      }
  }
  return out;
}

void WriteCsvs(const fs::path& dir, const SpeedRun& run) {
  {
    OutputFile f((dir / "images.csv").string());
    f << "class,image,source,system,ms,detections,false_positives,wrong_ids,budget_exceeded";
    for (const char* step : DetectionStats::kStepNames) f << "," << step << "_ms";
    f << "\n";
    for (const SpeedRecord& r : run.images) {
      f << r.cls << "," << r.image << "," << r.source << "," << r.system << "," << Cell(r.ms, 3)
        << "," << r.detections << "," << r.false_positives << "," << r.wrong_ids << ","
        << (r.budget_exceeded ? 1 : 0);
      const bool svms = r.system.rfind("svms", 0) == 0;
      for (double ms : r.step_ms) f << "," << (svms ? Cell(ms, 3) : std::string("-"));
      f << "\n";
    }
  }
  {
    OutputFile f((dir / "markers.csv").string());
    f << "class,image,system,min_side_px,eligible,detected,wrong_id\n";
    for (const SpeedMarker& m : run.markers)
      f << m.cls << "," << m.image << "," << m.system << "," << Cell(m.min_side_px, 1) << ","
        << m.eligible << "," << m.detected << "," << m.wrong_id << "\n";
  }
}

// speed_times.png/.svg: the distribution (cumulative share of images against the time, log
// scale) of every system's time per image, one panel per class.
void Plot(const fs::path& dir, const SpeedRun& run, const StatsTable& t) {
  std::vector<std::string> systems = run.systems;
  for (double b : run.budgets_ms) systems.push_back(BudgetSystem(b));
  std::ostringstream gp;
  gp << "# drawn by svms bench speed; run in this directory\n"
        "set termoption noenhanced\nset grid\nset logscale x\nset key bottom right\n"
        "set xlabel 'ms per image (one core)'\nset ylabel 'share of images'\n"
        "set yrange [0:1]\nset multiplot layout 2,2\n";
  std::string names;
  for (const std::string& s : systems) names += (names.empty() ? "" : " ") + s;
  for (const std::string& cls : SpeedClasses()) {
    OutputFile f((dir / ("times_" + cls + ".dat")).string());
    f << "# ms share; one block per system: " << names << "\n";
    for (const std::string& s : systems) {
      std::vector<double> v;
      if (t.count(cls) && t.at(cls).count(s)) v = t.at(cls).at(s).ms;
      std::sort(v.begin(), v.end());
      for (size_t i = 0; i < v.size(); ++i)
        f << Cell(v[i], 3) << " " << Cell((i + 1.0) / v.size(), 4) << "\n";
      if (v.empty()) f << "NaN NaN\n";
      f << "\n\n";
    }
    f.close();
    gp << "set title '" << cls << ": " << ClassDescriptions().at(cls) << "'\n"
       << "names = '" << names << "'\n"
       << "plot for [i=1:words(names)] 'times_" << cls
       << ".dat' index (i-1) using 1:2 with steps lw 2 title word(names, i)\n";
  }
  gp << "unset multiplot\n";
  if (Status s = Gnuplot(dir.string(), "speed_times", gp.str(), "1400,1000"); !s)
    NoteOutputFailure(s.message());
}

}  // namespace

const std::vector<std::string>& SpeedClasses() {
  static const std::vector<std::string> c = {"photo_1024", "photo_640", "markers_1024",
                                             "markers_640"};
  return c;
}

std::string BudgetSystem(double budget_ms) { return "svms_b" + Cell(budget_ms, 0); }

int WriteSpeedReport(const SpeedBenchmarkOptions& o, const SpeedRun& run) {
  const fs::path dir(o.out);
  const StatsTable t = Tally(run);
  auto stat = [&](const std::string& cls, const std::string& sys) -> const Stats& {
    static const Stats empty;
    if (!t.count(cls) || !t.at(cls).count(sys)) return empty;
    return t.at(cls).at(sys);
  };
  WriteCsvs(dir, run);
  Plot(dir, run, t);
  const auto by_size = BySize(run);

  std::ostringstream md;
  int photos_found = 0;
  for (const PhotoSource& s : run.sources) photos_found += static_cast<int>(s.files.size());
  md << "## Speed on real photographs (`svms bench speed`)\n\n"
     << "Command: `svms bench speed --out " << o.out << (o.quick ? " --quick" : "") << "`"
     << (o.quick ? " (**quick**: two photographs per source, one crop per size)" : "") << ". "
     << run.photos_used << " photographs used (of " << photos_found << " found), up to "
     << (o.quick ? 1 : o.crops_per_size)
     << " crops of each size per photograph (seeded positions), grey, in linear light (the "
        "JPEGs' sRGB undone as every image the detector reads, then 8 bits). The markers classes "
        "are the same crops with markers rendered in by the simulator (the crop as the image "
        "background; 12 to 200 px black squares, tilted up to 25 deg; SVMS markers for svms, "
        "each peer's own tags for the peers; "
     << run.markers_placed << " markers placed, " << run.markers_not_placed
     << " left out for want of room). Every system detects and locates corners only (no pose), "
        "on one thread (svms_t2: svms on two threads per frame), all interleaved in one run; svms "
        "decodes all 32,768 IDs. "
     << std::thread::hardware_concurrency() << " hardware threads on this machine.\n\n";
  md << "Photographs looked for:\n\n| package | directory | photographs |\n|---|---|---|\n";
  for (const PhotoSource& s : run.sources)
    md << "| " << s.package << " | " << s.dir << " | "
       << (s.present ? std::to_string(s.files.size())
                     : std::string("**missing** (scripts/install_bench_photos)"))
       << " |\n";
  for (const std::string& f : run.photo_failures) md << "\nNot read: " << f << "\n";
  md << "\nTime per image (ms; one core, svms_t2 two), detections and false positives:\n\n"
        "| class | system | images | median | p90 | p99 | max | detection rate | false positives "
        "| wrong IDs |\n|---|---|---|---|---|---|---|---|---|---|\n";
  for (const std::string& cls : SpeedClasses())
    for (const std::string& sys : run.systems) {
      const Stats& s = stat(cls, sys);
      if (!s.images) continue;
      md << "| " << cls << " | " << sys << " | " << s.images << " | " << Cell(s.median(), 2)
         << " | " << Cell(s.p90(), 2) << " | " << Cell(s.p99(), 2) << " | " << Cell(s.max(), 2)
         << " | "
         << (s.eligible ? Cell(100 * s.rate(), 1) + " % (" + std::to_string(s.detected) + "/" +
                              std::to_string(s.eligible) + ")"
                        : std::string("-"))
         << " | " << s.false_positives << " | " << s.wrong_ids << " |\n";
    }
  {
    // The same by source: the packages' photographs differ (wallpapers: large, often smooth;
    // opencv-doc: small, busy).
    StatsTable by_source;
    for (const SpeedRecord& r : run.images)
      if (r.system == "svms" || r.system == "svms_d2" || r.system == "apriltag_d2")
        by_source[r.cls + " | " + r.source][r.system].ms.push_back(r.ms);
    md << "\nBy source, svms (defaults, and decimate 2) against apriltag_d2 (ms per image):\n\n"
          "| class | source | images | svms median | svms_d2 median | apriltag_d2 median | ratio "
          "| ratio d2 | svms p99 | svms_d2 p99 | apriltag_d2 p99 |\n"
          "|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const std::string& cls : SpeedClasses())
      for (const PhotoSource& src : run.sources) {
        const std::string key = cls + " | " + src.package;
        if (!by_source.count(key)) continue;
        const Stats &a = by_source[key]["svms"], &d = by_source[key]["svms_d2"],
                    &b = by_source[key]["apriltag_d2"];
        md << "| " << key << " | " << a.ms.size() << " | " << Cell(a.median(), 2) << " | "
           << Cell(d.median(), 2) << " | " << Cell(b.median(), 2) << " | "
           << Cell(a.median() / b.median(), 2) << " | " << Cell(d.median() / b.median(), 2) << " | "
           << Cell(a.p99(), 2) << " | " << Cell(d.p99(), 2) << " | " << Cell(b.p99(), 2) << " |\n";
      }
  }
  // svms on two threads per frame against one, image by image (the same image, the same run).
  std::map<std::string, std::vector<double>> speedup;  // by class
  std::map<std::string, int> differing;                // images whose detections differ
  {
    std::map<std::string, const SpeedRecord*> one;  // class | image -> svms's record
    for (const SpeedRecord& r : run.images)
      if (r.system == "svms") one[r.cls + " | " + r.image] = &r;
    for (const SpeedRecord& r : run.images) {
      if (r.system != "svms_t2") continue;
      const auto it = one.find(r.cls + " | " + r.image);
      if (it == one.end() || !(r.ms > 0)) continue;
      speedup[r.cls].push_back(it->second->ms / r.ms);
      differing[r.cls] += r.detections != it->second->detections;
    }
    md << "\nsvms with its defaults on two threads per frame (svms_t2, "
          "`DetectorOptions::threads` 2) against one thread (svms), image by image: the speed-up "
          "is svms's time over svms_t2's on the same image. The two give the same detections to "
          "the last bit (a unit test's promise); here their counts are compared.\n\n"
          "| class | images | median speed-up | 10th percentile | 90th percentile | svms median "
          "ms | svms_t2 median ms | images whose detection counts differ |\n"
          "|---|---|---|---|---|---|---|---|\n";
    for (const std::string& cls : SpeedClasses()) {
      const std::vector<double>& v = speedup[cls];
      if (v.empty()) continue;
      md << "| " << cls << " | " << v.size() << " | " << Cell(Median(v), 2) << " | "
         << Cell(Percentile(v, 0.10), 2) << " | " << Cell(Percentile(v, 0.90), 2) << " | "
         << Cell(stat(cls, "svms").median(), 2) << " | " << Cell(stat(cls, "svms_t2").median(), 2)
         << " | " << differing[cls] << " |\n";
    }
  }
  md << "\n![](speed_times.png)\n\nMarkers found by size (shortest projected side, px; both "
        "markers classes):\n\n| size px |";
  for (const std::string& sys : run.systems) md << " " << sys << " |";
  md << "\n|---|";
  for (size_t k = 0; k < run.systems.size(); ++k) md << "---|";
  md << "\n";
  for (size_t b = 0; b < SizeBins().size(); ++b) {
    md << "| " << BinName(SizeBins()[b]) << " |";
    for (const std::string& sys : run.systems) {
      const auto& [hit, total] = by_size.at(sys)[b];
      md << " " << hit << "/" << total << " |";
    }
    md << "\n";
  }
  md << "\nsvms under a per-frame deadline B (`Detector::Detect(image, stats, deadline)`, the "
        "deadline B after the call starts): time per frame and the frames flagged "
        "budget_exceeded. \"max - 1.25 B\" is the overhead beyond 1.25 B of the slowest frame; "
        "its steps' times (ms) follow: segments (edge map, chains, lines), quads, decode, refine, "
        "pose, nesting.\n\n"
        "| class | B ms | frames | median | p99 | max | max - 1.25 B | flagged | markers found "
        "| slowest frame: steps |\n|---|---|---|---|---|---|---|---|---|---|\n";
  for (const std::string& cls : SpeedClasses())
    for (double b : run.budgets_ms) {
      const Stats& s = stat(cls, BudgetSystem(b));
      if (!s.images) continue;
      md << "| " << cls << " | " << Cell(b, 0) << " | " << s.images << " | " << Cell(s.median(), 2)
         << " | " << Cell(s.p99(), 2) << " | " << Cell(s.max(), 2) << " | "
         << Cell(s.max() - 1.25 * b, 2) << " | " << Cell(100.0 * s.flagged / s.images, 1) << " % | "
         << (s.eligible ? std::to_string(s.detected) + "/" + std::to_string(s.eligible) : "-")
         << " | " << s.slowest->image << ":";
      for (double ms : s.slowest->step_ms) md << " " << Cell(ms, 1);
      md << " |\n";
    }

  // Targets, with their verdicts.
  BenchTargets targets;
  const std::string why_quick = "--quick: too few images to time";
  // Judged for svms with its defaults and for svms with steps 1-4 on a 2x decimated image
  // (DetectorOptions::decimate): the second trades its smallest markers for time, as AprilTag's
  // decimate 2 does, and its rows say whether that trade meets the targets.
  for (const std::string& sys : {std::string("svms"), std::string("svms_d2")}) {
    if (!by_size.count(sys)) continue;
    const std::string label = sys == "svms" ? "" : sys + " (decimate 2): ";
    for (const std::string& kind : {std::string("photo"), std::string("markers")}) {
      const std::string what =
          label + "Median time per image at most 1/3 of apriltag_d2's on the " +
          std::string(kind == "photo" ? "marker-free photographs" : "photographs with markers");
      bool met = true, any = false;
      std::string measured;
      for (const std::string& size : {std::string("1024"), std::string("640")}) {
        const Stats &a = stat(kind + "_" + size, sys), &b = stat(kind + "_" + size, "apriltag_d2");
        if (!a.images || !b.images) continue;
        any = true;
        const double ratio = a.median() / b.median();
        met = met && ratio <= 1.0 / 3;
        measured += std::string(measured.empty() ? "" : "; ") + size + ": " + Cell(a.median(), 2) +
                    " vs " + Cell(b.median(), 2) + " ms, ratio " + Cell(ratio, 2);
      }
      if (o.quick || !any)
        targets.NotJudged(what, o.quick ? why_quick : "no images");
      else
        targets.Add(what, met, measured);
    }
    {
      const std::string what =
          label + "p99 and max per image no higher than apriltag_d2's in every class";
      bool met = true;
      std::string measured;
      for (const std::string& cls : SpeedClasses()) {
        const Stats &a = stat(cls, sys), &b = stat(cls, "apriltag_d2");
        if (!a.images || !b.images) continue;
        met = met && a.p99() <= b.p99() && a.max() <= b.max();
        measured += std::string(measured.empty() ? "" : "; ") + cls + ": p99 " + Cell(a.p99(), 1) +
                    " vs " + Cell(b.p99(), 1) + ", max " + Cell(a.max(), 1) + " vs " +
                    Cell(b.max(), 1) + " ms";
      }
      if (o.quick)
        targets.NotJudged(what, why_quick);
      else
        targets.Add(what, met, measured);
    }
    {
      // The bar is AprilTag decimate 1's; svms_d2, which gives up the smallest markers
      // by design as AprilTag decimate 2 does, is held to decimate 2's instead.
      const std::string peer = sys == "svms" ? "apriltag_d1" : "apriltag_d2";
      const std::string what =
          label + "At least as many markers found as " + peer + " at every size";
      bool met = true;
      std::string measured;
      for (size_t b = 0; b < SizeBins().size(); ++b) {
        const auto& s = by_size.at(sys)[b];
        const auto& a = by_size.at(peer)[b];
        if (!s.second && !a.second) continue;
        met = met && s.first * std::max(1, a.second) >= a.first * std::max(1, s.second);
        measured += std::string(measured.empty() ? "" : "; ") + BinName(SizeBins()[b]) +
                    " px: " + std::to_string(s.first) + "/" + std::to_string(s.second) + " vs " +
                    std::to_string(a.first) + "/" + std::to_string(a.second);
      }
      if (o.quick)
        targets.NotJudged(what, "--quick: too few markers per size");
      else
        targets.Add(what, met, measured);
    }
    {
      int fp = 0, images = 0;
      std::string measured;
      for (const std::string& cls : SpeedClasses()) {
        const Stats& s = stat(cls, sys);
        fp += s.false_positives;
        images += s.images;
        measured += std::string(measured.empty() ? "" : ", ") + cls + " " +
                    std::to_string(s.false_positives);
      }
      targets.Add(label + "0 false positives on every photograph (all 32,768 IDs allowed)", fp == 0,
                  std::to_string(fp) + " in " + std::to_string(images) + " images: " + measured);
    }
  }
  {
    // Intra-frame parallelism, judged on the 1024 x 1024 frames (the issue's "a 1024 x 1024
    // frame"): the median of the per-image speed-ups over both 1024 classes.
    std::vector<double> big = speedup["photo_1024"];
    big.insert(big.end(), speedup["markers_1024"].begin(), speedup["markers_1024"].end());
    const std::string what =
        "svms on 2 threads at least 1.6x faster than on one on a 1024 x 1024 frame (median "
        "per-image speed-up over the 1024 x 1024 photographs, with and without markers)";
    const int differ = differing["photo_1024"] + differing["markers_1024"] +
                       differing["photo_640"] + differing["markers_640"];
    const std::string measured =
        big.empty() ? std::string("no images")
                    : Cell(Median(big), 2) + "x over " + std::to_string(big.size()) + " images; " +
                          std::to_string(differ) +
                          " images of all four classes with other detection counts";
    if (o.quick || big.empty())
      targets.NotJudged(what, o.quick ? why_quick : measured);
    else
      targets.Add(what, Median(big) >= 1.6 && differ == 0, measured);
  }
  md << "\nTargets:\n\n" << targets.Markdown();

  json summary;
  summary["command"] = "svms bench speed";
  summary["quick"] = o.quick;
  summary["seed"] = o.seed;
  summary["crops_per_size"] = o.quick ? 1 : o.crops_per_size;
  summary["hardware_threads"] = std::thread::hardware_concurrency();
  json sources = json::array();
  for (const PhotoSource& s : run.sources)
    sources.push_back({{"package", s.package},
                       {"dir", s.dir},
                       {"present", s.present},
                       {"photographs", s.files.size()}});
  summary["sources"] = sources;
  summary["photos_used"] = run.photos_used;
  summary["photo_failures"] = run.photo_failures;
  summary["markers_placed"] = run.markers_placed;
  summary["markers_not_placed"] = run.markers_not_placed;
  summary["render_failures"] = run.render_failures;
  summary["systems"] = run.systems;
  summary["settings"] = run.settings;
  summary["budgets_ms"] = run.budgets_ms;
  json classes = json::object();
  for (const std::string& cls : SpeedClasses()) {
    json c = {{"description", ClassDescriptions().at(cls)}};
    int images = 0;
    for (const std::string& sys : run.systems) {
      c["systems"][sys] = stat(cls, sys).Json();
      images = std::max(images, stat(cls, sys).images);
    }
    for (double b : run.budgets_ms)
      c["budgets"][BudgetSystem(b)] = stat(cls, BudgetSystem(b)).Json();
    c["images"] = images;
    classes[cls] = c;
  }
  summary["classes"] = classes;
  json sizes = json::object();
  for (const std::string& sys : run.systems) {
    json a = json::array();
    for (size_t b = 0; b < SizeBins().size(); ++b)
      a.push_back({{"bin", BinName(SizeBins()[b])},
                   {"found", by_size.at(sys)[b].first},
                   {"total", by_size.at(sys)[b].second}});
    sizes[sys] = a;
  }
  summary["found_by_size"] = sizes;
  json speedups = json::object();
  for (const auto& [cls, v] : speedup)
    speedups[cls] = {{"images", v.size()},
                     {"median", v.empty() ? json() : json(Median(v))},
                     {"differing_detection_counts", differing[cls]}};
  summary["two_thread_speedup"] = speedups;
  summary["targets_met"] = targets.all_met();
  {
    OutputFile f((dir / "summary.json").string());
    f << summary.dump(2) << "\n";
  }
  {
    OutputFile f((dir / "report.md").string());
    f << md.str();
  }
  std::cout << md.str();
  return targets.ExitCode("svms bench speed", kExitOk);
}

}  // namespace svms

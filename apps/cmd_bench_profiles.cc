// svms bench profiles: the detector on the pixels real cameras deliver, every sensor profile
// side by side in one run.
//
// Each view of the range and angle sets is rendered once (radiance); each profile then exposes
// it through its own camera pipeline (scene.h: response, bits, black level, Bayer mosaic,
// defocus) and its own codec (libjpeg for JPEG, render.h ThroughCodec), and the image is
// turned back into linear light as a reader with the camera's photometric file would
// (photometric.h LinearizeImage) before detection. Every marker is scored against the
// renderer's truth: detection rate by size, the corners' bias along their outward diagonal
// and RMS, the single-marker pose's orientation error and NEES. The angle set is also rendered
// on a textured (Earth) background to time black-background frames against textured ones; the
// noise the detector estimates on 16-bit images is compared with the sensor's. Writes
// DIR/markers.csv, DIR/summary.json and DIR/report.md.
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "bench_util.h"
#include "cli_io.h"
#include "commands.h"
#include "svms/base/statistics.h"
#include "svms/camera/photometric.h"
#include "svms/datasets/datasets.h"
#include "svms/detect/detector.h"
#include "svms/fusion/object_pose.h"
#include "svms/geometry/pose.h"
#include "svms/pipelines/item_failure.h"
#include "svms/pipelines/json_text.h"
#include "svms/pipelines/output_checks.h"
#include "svms/pipelines/progress.h"
#include "svms/pipelines/report_file.h"
#include "svms/sim/render.h"
#include "svms/sim/truth.h"

namespace svms::cli {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

const double kNaN = std::numeric_limits<double>::quiet_NaN();

struct BenchProfilesOptions {
  std::string out;
  bool quick = false;
  uint64_t seed = 1;
  int threads = static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  std::vector<std::string> profiles;  // empty: every profile
};

// What the camera's photometric file would say of a sensor: the reader's model.
PhotometricModel SensorPhotometry(const Sensor& s) {
  PhotometricModel m;
  Response::Parse(s.response, &m.response);
  m.black_level = s.black_level;
  m.white_level = s.white_level();
  ParseBayerPattern(s.bayer, &m.bayer);
  return m;
}

struct Row {
  std::string profile, set, view;
  int id = -1;
  double min_side_px = 0, view_angle_deg = 0;
  bool fully_visible = false, found = false;
  double corner_rms_px = kNaN, corner_bias_px = kNaN;  // bias: mean outward error of the 4
  double orient_err_deg = kNaN, range_err_rel = kNaN, nees = kNaN;
};

struct ViewTiming {
  std::string profile, set;
  bool textured = false;
  double ms = 0;
  NoiseModel noise;
};

void Score(const std::string& profile, const std::string& set, const ViewTruth& truth,
           const std::vector<Detection>& found, std::vector<Row>* rows) {
  std::vector<bool> used(found.size(), false);
  for (const MarkerTruth& m : truth.markers) {
    Row r;
    r.profile = profile, r.set = set, r.view = truth.name, r.id = m.id;
    r.min_side_px = m.min_side_px;
    r.view_angle_deg = ViewAngleDeg(m.cam_from_marker);
    r.fully_visible = m.fully_visible() && r.view_angle_deg <= 75.0 + 1e-6;
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();
    for (const PointTruth& c : m.corners) centre += 0.25 * c.pixel;
    for (size_t i = 0; i < found.size(); ++i) {
      const Detection& d = found[i];
      if (d.id != m.id || used[i]) continue;
      double sum2 = 0, worst = 0, bias = 0;
      for (int k = 0; k < 4; ++k) {
        const Eigen::Vector2d e = d.corners[k] - m.corners[k].pixel;
        sum2 += e.squaredNorm();
        worst = std::max(worst, e.norm());
        bias += 0.25 * e.dot((m.corners[k].pixel - centre).normalized());
      }
      if (worst > std::max(3.0, 0.1 * m.side_px)) continue;
      used[i] = true;
      r.found = true;
      r.corner_rms_px = std::sqrt(sum2 / 4);
      r.corner_bias_px = bias;
      if (d.cam_from_marker) {
        r.orient_err_deg = AngleBetweenDeg(*d.cam_from_marker, m.cam_from_marker);
        r.range_err_rel = d.cam_from_marker->tvec.norm() / m.cam_from_marker.tvec.norm() - 1;
        r.nees = Nees(m.cam_from_marker, *d.cam_from_marker, d.covariance);
      }
      break;
    }
    rows->push_back(r);
  }
}

// The sets: range and angle as the datasets make them, and the angle set again on the Earth.
struct SetRun {
  std::string name;
  std::string dataset;
  bool textured = false;
};

Status RunSet(const SetRun& run, const BenchProfilesOptions& o,
              const std::vector<std::string>& profiles, std::vector<Row>* rows,
              std::vector<ViewTiming>* timings) {
  DatasetOptions dopt;
  dopt.seed = o.seed;
  dopt.quick = o.quick;
  Dataset dataset;
  if (Status s = MakeDataset(run.dataset, dopt, &dataset); !s) return s;
  for (auto& [subdir, scene_in] : dataset.scenes) {
    Scene scene = scene_in;
    if (run.textured) {
      scene.background.kind = Background::Kind::kEarth;
      scene.background.brightness = 0.7;
    }
    std::unique_ptr<Renderer> renderer;
    if (Status s = Renderer::Create(scene, &renderer); !s)
      return Status::Error(run.name + ": " + s.message());
    std::vector<MarkerModel> models;
    for (const SceneObject& ob : scene.objects)
      for (const SceneMarker& m : ob.markers) models.push_back(m.model);
    const Detector detector(DetectorOptions{}, scene.camera, models);
    std::vector<Sensor> sensors;
    std::vector<Linearizer> readers;
    for (const std::string& p : profiles) {
      Sensor s = scene.sensor;
      if (Status st = ApplySensorProfile(p, &s); !st) return st;
      sensors.push_back(s);
      readers.emplace_back(SensorPhotometry(s));
    }
    const int n = static_cast<int>(scene.views.size());
    std::vector<std::vector<Row>> view_rows(n);
    std::vector<std::vector<ViewTiming>> view_timings(n);
    std::atomic<int> next{0};
    int done = 0;
    std::mutex io;
    std::string failure;
    Progress progress("svms bench profiles: " + run.name, n);
    auto worker = [&] {
      for (int v; (v = next++) < n;) {
        const cv::Mat radiance = renderer->RenderRadiance(v);
        const ViewTruth truth = ComputeTruth(*renderer, v);
        for (size_t p = 0; p < profiles.size(); ++p) {
          const cv::Mat exposed = renderer->Expose(radiance, v, sensors[p]);
          cv::Mat decoded, linear;
          Status s = ThroughCodec(sensors[p], exposed, &decoded);
          if (s) s = readers[p].Apply(decoded, &linear);
          if (!s) {
            std::lock_guard<std::mutex> lock(io);
            failure = profiles[p] + ", " + truth.name + ": " + s.message();
            continue;
          }
          DetectionStats stats;
          const auto t0 = std::chrono::steady_clock::now();
          const std::vector<Detection> found = detector.Detect(linear, &stats);
          ViewTiming t;
          t.profile = profiles[p], t.set = run.name, t.textured = run.textured;
          t.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                     .count();
          t.noise = stats.noise;
          view_timings[v].push_back(t);
          if (!run.textured) Score(profiles[p], run.name, truth, found, &view_rows[v]);
        }
        std::lock_guard<std::mutex> lock(io);
        progress.Update(++done);
      }
    };
    std::vector<std::thread> pool;
    for (int t = 0; t < std::min(o.threads, n); ++t) pool.emplace_back(worker);
    for (auto& t : pool) t.join();
    progress.Finish();
    if (!failure.empty()) return Status::Error(failure);
    for (int v = 0; v < n; ++v) {
      rows->insert(rows->end(), view_rows[v].begin(), view_rows[v].end());
      timings->insert(timings->end(), view_timings[v].begin(), view_timings[v].end());
    }
  }
  return Status::Ok();
}

std::string F(double v, int digits) { return std::isfinite(v) ? Fixed(v, digits) : "-"; }

// The size buckets of the detection-rate table (shortest projected side, px).
const std::vector<std::pair<double, double>>& SizeBuckets() {
  static const std::vector<std::pair<double, double>> b = {{8, 12},  {12, 20},  {20, 30},
                                                           {30, 60}, {60, 120}, {120, 1e9}};
  return b;
}

int RunBenchProfiles(const BenchProfilesOptions& o) {
  std::vector<std::string> profiles = o.profiles;
  if (profiles.empty()) profiles = SensorProfileNames();
  for (const std::string& p : profiles) {
    Sensor s;
    if (Status st = ApplySensorProfile(p, &s); !st) {
      std::cerr << "svms bench profiles: --profiles: " << st.message() << "\n";
      return kExitBadInput;
    }
  }
  if (Status s = PrepareOutputDirectory("--out", o.out); !s) {
    std::cerr << "svms bench profiles: " << s.message() << "\n";
    return kExitBadInput;
  }
  std::vector<Row> rows;
  std::vector<ViewTiming> timings;
  const auto t_start = std::chrono::steady_clock::now();
  for (const SetRun& run : {SetRun{"range", "range", false}, SetRun{"angle", "angle", false},
                            SetRun{"angle_earth", "angle", true}}) {
    if (Status s = RunSet(run, o, profiles, &rows, &timings); !s) {
      std::cerr << "svms bench profiles: " << s.message() << "\n";
      return kExitFailed;
    }
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();

  // Per profile figures.
  json summary;
  summary["profiles"] = profiles;
  summary["seed"] = o.seed;
  summary["quick"] = o.quick;
  std::map<std::string, json> per;
  for (const std::string& p : profiles) {
    json j;
    std::vector<double> bias20, rms16, orient, nees;
    std::vector<json> rate;
    for (const auto& [lo, hi] : SizeBuckets()) {
      int hit = 0, total = 0;
      for (const Row& r : rows)
        if (r.profile == p && r.fully_visible && r.min_side_px >= lo && r.min_side_px < hi)
          ++total, hit += r.found;
      rate.push_back({{"lo", lo}, {"hi", hi}, {"found", hit}, {"total", total}});
    }
    for (const Row& r : rows) {
      if (r.profile != p || !r.found) continue;
      if (r.min_side_px >= 20) bias20.push_back(r.corner_bias_px);
      if (r.min_side_px >= 14 && r.min_side_px < 18) rms16.push_back(r.corner_rms_px);
      if (std::isfinite(r.orient_err_deg)) orient.push_back(r.orient_err_deg);
      if (std::isfinite(r.nees)) nees.push_back(r.nees);
    }
    j["rate_by_size"] = rate;
    j["corner_bias_px_20plus"] = Mean(bias20);
    double sum2 = 0;
    for (double x : rms16) sum2 += x * x;
    j["corner_rms_px_16"] = rms16.empty() ? kNaN : std::sqrt(sum2 / rms16.size());
    j["orientation_median_deg"] = Median(orient);
    j["nees_mean"] = Mean(nees);
    j["nees_below_12_59"] =
        nees.empty() ? kNaN : std::count_if(nees.begin(), nees.end(), [](double x) {
                                return x < kChi2Dof6P95;
                              }) / static_cast<double>(nees.size());
    j["poses"] = nees.size();
    std::vector<double> black_ms, earth_ms;
    for (const ViewTiming& t : timings) {
      if (t.profile != p || t.set == "range") continue;
      (t.textured ? earth_ms : black_ms).push_back(t.ms);
    }
    j["ms_median_black"] = Median(black_ms);
    j["ms_median_textured"] = Median(earth_ms);
    per[p] = j;
  }
  // The noise the detector estimated on 16-bit images against the sensor's, in linear 16-bit
  // units: read sigma and the sigma at mid-grey.
  for (const std::string& p : profiles) {
    Dataset d;
    DatasetOptions dopt;
    dopt.seed = o.seed;
    dopt.quick = true;
    MakeDataset("angle", dopt, &d);
    Sensor s = d.scenes.front().second.sensor;
    ApplySensorProfile(p, &s);
    const double unit = 65535.0 / s.full_well;  // linear units per electron
    std::vector<double> read_ratio, mid_ratio;
    for (const ViewTiming& t : timings) {
      if (t.profile != p || !t.noise.valid()) continue;
      const double true_read = s.read_noise * unit;
      const double mid = 0.25 * 65535, true_mid = std::sqrt(true_read * true_read + unit * mid);
      read_ratio.push_back(t.noise.read_sigma / true_read);
      mid_ratio.push_back(t.noise.Sigma(mid) / true_mid);
    }
    per[p]["noise_read_ratio_median"] = Median(read_ratio);
    per[p]["noise_mid_ratio_median"] = Median(mid_ratio);
    per[p]["noise_views"] = read_ratio.size();
  }
  for (const std::string& p : profiles) summary["per_profile"][p] = per[p];
  summary["seconds"] = seconds;

  // The report.
  std::ostringstream md;
  md << "## Sensor profiles (`svms bench profiles" << (o.quick ? " --quick" : "") << "`)\n\n";
  md << "Every view of the range and angle sets rendered once and exposed through each "
        "profile's camera pipeline and codec (docs/simulator.md), read back into linear light "
        "with the camera's photometric model (photometric.h), then detected; "
     << rows.size() / std::max<size_t>(profiles.size(), 1) << " markers per profile, seed "
     << o.seed << ", " << F(seconds, 0) << " s.\n\n";
  md << "| figure |";
  for (const std::string& p : profiles) md << " " << p << " |";
  md << "\n|---|";
  for (size_t i = 0; i < profiles.size(); ++i) md << "---|";
  md << "\n";
  for (size_t b = 0; b < SizeBuckets().size(); ++b) {
    const auto [lo, hi] = SizeBuckets()[b];
    md << "| found, " << lo << (hi > 1e8 ? "+" : "-" + F(hi, 0)) << " px |";
    for (const std::string& p : profiles) {
      const json& r = per[p]["rate_by_size"][b];
      const int tot = r["total"];
      md << " "
         << (tot ? F(100.0 * r["found"].get<int>() / tot, 1) + " % (" +
                       std::to_string(r["found"].get<int>()) + "/" + std::to_string(tot) + ")"
                 : "-")
         << " |";
    }
    md << "\n";
  }
  auto line = [&](const std::string& name, const std::string& key, int digits) {
    md << "| " << name << " |";
    for (const std::string& p : profiles)
      md << " " << (per[p][key].is_number() ? F(per[p][key].get<double>(), digits) : "-") << " |";
    md << "\n";
  };
  line("corner bias outward, >= 20 px (px)", "corner_bias_px_20plus", 4);
  line("corner RMS, 14-18 px (px)", "corner_rms_px_16", 4);
  line("orientation error median (deg)", "orientation_median_deg", 3);
  line("pose NEES mean (6 dof: 6)", "nees_mean", 2);
  line("share of NEES below 12.59 (0.95)", "nees_below_12_59", 3);
  line("detect ms median, black background", "ms_median_black", 2);
  line("detect ms median, textured background", "ms_median_textured", 2);
  line("noise estimate / truth, read (16-bit)", "noise_read_ratio_median", 2);
  line("noise estimate / truth, mid grey (16-bit)", "noise_mid_ratio_median", 2);
  // The real-camera targets, where the profiles they name were run.
  auto has = [&](const std::string& p) { return per.count(p) > 0; };
  auto num = [&](const std::string& p, const std::string& k) {
    return per[p][k].is_number() ? per[p][k].get<double>() : kNaN;
  };
  bool all_met = true;  // a missed target: exit kExitTargetMissed after writing everything
  auto verdict = [&all_met](bool ok) {
    all_met = all_met && ok;
    return ok ? "**met**" : "**not met**";
  };
  md << "\nTargets:\n\n";
  if (has("linear") && has("jpeg_srgb")) {
    double worst = 0;
    std::string where;
    for (size_t b = 0; b < SizeBuckets().size(); ++b) {
      const json &l = per["linear"]["rate_by_size"][b], &g = per["jpeg_srgb"]["rate_by_size"][b];
      if (l["total"].get<int>() == 0) continue;
      const double d = 100.0 * l["found"].get<int>() / l["total"].get<int>() -
                       100.0 * g["found"].get<int>() / std::max(1, g["total"].get<int>());
      if (d > worst) worst = d, where = F(SizeBuckets()[b].first, 0) + " px";
    }
    md << "- jpeg_srgb detection within 2 points of linear at every size: " << verdict(worst <= 2)
       << " (largest shortfall " << F(worst, 1) << " points" << (where.empty() ? "" : ", " + where)
       << ")\n";
    const double bias = num("jpeg_srgb", "corner_bias_px_20plus");
    md << "- jpeg_srgb corner bias below 0.01 px at 20 px and more: "
       << verdict(std::abs(bias) < 0.01) << " (" << F(bias, 4) << ")\n";
    const double nees = num("jpeg_srgb", "nees_mean"), below = num("jpeg_srgb", "nees_below_12_59");
    md << "- jpeg_srgb NEES mean in [4.5, 7.5] with 90 % below 12.59: "
       << verdict(nees >= 4.5 && nees <= 7.5 && below >= 0.9) << " (" << F(nees, 2) << ", "
       << F(100 * below, 1) << " %)\n";
    const double ratio =
        num("jpeg_srgb", "orientation_median_deg") / num("linear", "orientation_median_deg");
    md << "- jpeg_srgb orientation median within 1.5x linear's: " << verdict(ratio <= 1.5) << " ("
       << F(ratio, 2) << "x)\n";
  }
  if (has("linear") && has("raw12")) {
    const double gain = 1 - num("raw12", "corner_rms_px_16") / num("linear", "corner_rms_px_16");
    md << "- raw12 corner RMS at 16 px at least 20 % better than 8 bits: " << verdict(gain >= 0.2)
       << " (" << F(100 * gain, 0) << " %)\n";
  }
  for (const std::string& p : profiles) {
    const double r = num(p, "ms_median_black") / num(p, "ms_median_textured");
    md << "- " << p << ": black-background frames within 30 % of textured ones' median time: "
       << verdict(std::abs(r - 1) <= 0.3) << " (" << F(r, 2) << "x)\n";
  }
  md << "\nCorner bias: each found marker's four corner errors along their outward diagonal, "
        "averaged (positive: the square found too large). NEES: the single-marker pose's error "
        "against its own 6x6 covariance. The noise rows compare the detector's estimate "
        "(noise_model.h, made only for 16-bit images) with the sensor's read noise and its "
        "noise at a quarter of full scale, in linear units.\n";
  if (Status s = WriteFileAtomically((fs::path(o.out) / "report.md").string(), md.str()); !s)
    NoteOutputFailure(s.message());
  if (Status s = WriteFileAtomically((fs::path(o.out) / "summary.json").string(),
                                     DumpJson(summary, 2) + "\n");
      !s)
    NoteOutputFailure(s.message());
  OutputFile csv((fs::path(o.out) / "markers.csv").string());
  csv << "profile,set,view,id,min_side_px,view_angle_deg,fully_visible,found,corner_rms_px,"
         "corner_bias_px,orient_err_deg,range_err_rel,nees\n";
  for (const Row& r : rows)
    csv << r.profile << "," << r.set << "," << r.view << "," << r.id << "," << r.min_side_px << ","
        << r.view_angle_deg << "," << r.fully_visible << "," << r.found << "," << r.corner_rms_px
        << "," << r.corner_bias_px << "," << r.orient_err_deg << "," << r.range_err_rel << ","
        << r.nees << "\n";
  csv.close();
  std::cout << md.str();
  if (!all_met) std::cerr << "svms bench profiles: some targets not met (report.md)\n";
  return all_met ? kExitOk : kExitTargetMissed;
}

}  // namespace

void AddBenchProfiles(CLI::App& bench, int* exit_code) {
  auto o = std::make_shared<BenchProfilesOptions>();
  CLI::App* c = bench.add_subcommand(
      "profiles", "The detector through each sensor profile's camera pipeline and codec");
  c->add_option("--out", o->out, "Output directory (report.md, summary.json, markers.csv)")
      ->required();
  c->add_flag("--quick", o->quick, "The datasets' quick subsets");
  c->add_option("--seed", o->seed, "Dataset seed")->capture_default_str();
  c->add_option("--threads", o->threads, "Views in parallel")->check(CLI::Range(1, 256));
  c->add_option("--profiles", o->profiles, "Profiles to run (default: all)")->delimiter(',');
  c->footer("Example:\n  svms bench profiles --out out/bench/profiles");
  c->callback(
      [o, exit_code] { *exit_code = FinishOutputs("svms bench profiles", RunBenchProfiles(*o)); });
}

}  // namespace svms::cli

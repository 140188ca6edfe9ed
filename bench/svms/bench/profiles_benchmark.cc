#include "svms/bench/profiles_benchmark.h"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <iostream>
#include <limits>
#include <memory>
#include <mutex>

#include "svms/bench/profiles_report.h"
#include "svms/bench/truth_poses.h"
#include "svms/camera/bayer_luminance.h"
#include "svms/camera/photometric.h"
#include "svms/datasets/datasets.h"
#include "svms/detect/detector.h"
#include "svms/fusion/object_pose.h"
#include "svms/geometry/pose.h"
#include "svms/pipelines/exit_codes.h"
#include "svms/pipelines/output_checks.h"
#include "svms/pipelines/progress.h"
#include "svms/pipelines/report_file.h"
#include "svms/sim/render.h"
#include "svms/sim/truth.h"

namespace svms {
namespace {

// What the camera's photometric file would say of a sensor: the reader's model.
PhotometricModel SensorPhotometry(const Sensor& s) {
  PhotometricModel m;
  Response::Parse(s.response, &m.response);
  m.black_level = s.black_level;
  m.white_level = s.white_level();
  ParseBayerPattern(s.bayer, &m.bayer);
  return m;
}

// Scores the detections of one view through `profile` against its truth, a row per marker.
void Score(const std::string& profile, const std::string& set, const ViewTruth& truth,
           const std::vector<Detection>& found, std::vector<ProfileRow>* rows) {
  std::vector<bool> used(found.size(), false);
  for (const MarkerTruth& m : truth.markers) {
    ProfileRow r;
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
      double z2 = 0, axis_deg = 45;
      for (int k = 0; k < 4; ++k) {
        if (d.corner_sigma[k] > 0)
          z2 += (d.corners[k] - m.corners[k].pixel).squaredNorm() /
                (d.corner_sigma[k] * d.corner_sigma[k]) / 8;
        else
          z2 = ProfileRow::kNaN;
        const Eigen::Vector2d side = m.corners[(k + 1) % 4].pixel - m.corners[k].pixel;
        const double deg = std::atan2(std::abs(side.y()), std::abs(side.x())) * 180 / M_PI;
        axis_deg = std::min(axis_deg, std::min(deg, 90 - deg));
      }
      r.corner_z2 = z2;
      r.side_axis_deg = axis_deg;
      if (d.cam_from_marker) {
        r.orient_err_deg = AngleBetweenDeg(*d.cam_from_marker, m.cam_from_marker);
        r.range_err_rel = d.cam_from_marker->tvec.norm() / m.cam_from_marker.tvec.norm() - 1;
        r.nees = Nees(m.cam_from_marker, *d.cam_from_marker, d.covariance);
        const Eigen::Vector3d e = PoseError(m.cam_from_marker, *d.cam_from_marker).head<3>();
        const Eigen::LDLT<Eigen::Matrix3d> rot(d.covariance.topLeftCorner<3, 3>());
        if (rot.info() == Eigen::Success && rot.isPositive()) r.nees_rotation = e.dot(rot.solve(e));
      }
      break;
    }
    rows->push_back(r);
  }
}

// The sets: range, angle and small as the datasets make them, the angle set again on the
// Earth, the small set again exposed kDimExposureScale as long.
struct SetRun {
  std::string name;
  std::string dataset;
  bool textured = false;
  double exposure_scale = 1;
};

// Whether two sensors have one camera pipeline and light but for how the frame is stored.
bool SameButTheCodec(Sensor a, const Sensor& b) {
  a.format = b.format, a.jpeg_quality = b.jpeg_quality;
  return a.bits == b.bits && a.exposure == b.exposure && a.full_well == b.full_well &&
         a.read_noise == b.read_noise && a.shot_noise == b.shot_noise &&
         a.defocus_sigma_px == b.defocus_sigma_px && a.vignetting == b.vignetting &&
         a.response == b.response && a.signal_bits == b.signal_bits &&
         a.black_level == b.black_level && a.bayer == b.bayer && a.channel_gain == b.channel_gain &&
         a.format == b.format;
}

// The pixels whose centres lie within 1.5 px of the true sides of the fully visible markers of
// 12-30 px (the sizes whose corners the codec's error moves most; CodecTally). Pixel centres
// are at whole coordinates (truth.h). Measured point to segment, not drawn with cv::polylines,
// whose thick lines reach about 2.5 px.
cv::Mat SideBand(const ViewTruth& truth, cv::Size size) {
  constexpr double kReach = 1.5;
  cv::Mat band = cv::Mat::zeros(size, CV_8UC1);
  for (const MarkerTruth& m : truth.markers) {
    if (!m.fully_visible() || m.min_side_px < 12 || m.min_side_px >= 30) continue;
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector2d a = m.corners[k].pixel, b = m.corners[(k + 1) % 4].pixel;
      const Eigen::Vector2d ab = b - a;
      const int x0 = std::max(0, static_cast<int>(std::floor(std::min(a.x(), b.x()) - kReach)));
      const int x1 =
          std::min(size.width - 1, static_cast<int>(std::ceil(std::max(a.x(), b.x()) + kReach)));
      const int y0 = std::max(0, static_cast<int>(std::floor(std::min(a.y(), b.y()) - kReach)));
      const int y1 =
          std::min(size.height - 1, static_cast<int>(std::ceil(std::max(a.y(), b.y()) + kReach)));
      for (int y = y0; y <= y1; ++y)
        for (int x = x0; x <= x1; ++x) {
          const Eigen::Vector2d p(x, y);
          const double t = std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
          if ((p - a - t * ab).norm() <= kReach) band.at<uint8_t>(y, x) = 255;
        }
    }
  }
  return band;
}

// A view index no view has: Expose seeds the sensor's noise by the view, so this exposes the
// same light with a noise draw of its own.
constexpr int kSecondNoiseDraw = 1 << 20;

Status RunSet(const SetRun& run, const ProfilesBenchmarkOptions& o,
              const std::vector<std::string>& profiles, std::vector<ProfileRow>* rows,
              std::vector<ViewTiming>* timings, std::vector<CodecTally>* codec) {
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
    scene.sensor.exposure *= run.exposure_scale;
    std::unique_ptr<Renderer> renderer;
    if (Status s = Renderer::Create(scene, &renderer); !s)
      return Status::Error(run.name + ": " + s.message());
    std::vector<MarkerModel> models;
    for (const SceneObject& ob : scene.objects)
      for (const SceneMarker& m : ob.markers) models.push_back(m.model);
    std::vector<Sensor> sensors;
    std::vector<Linearizer> readers;
    std::vector<std::unique_ptr<Detector>> detectors;  // per profile: its corner row window
    for (const std::string& p : profiles) {
      Sensor s = scene.sensor;
      if (Status st = ApplySensorProfile(p, &s); !st) return st;
      sensors.push_back(s);
      readers.emplace_back(SensorPhotometry(s));
      DetectorOptions options;
      options.refine.max_row_window_px = CornerRowWindowPx(readers.back().model());
      options.pose.corner_covariance_from_fit = o.correlated_corners;
      options.decimate = o.decimate;
      if (o.corner_fit_scale > 0) {  // both, as the fusion's CornerFitScale does: a marker
        // without a joint covariance falls back to the independent corners
        options.pose.corner_fit_scale = o.corner_fit_scale;
        if (o.correlated_corners) options.pose.corner_covariance_scale = o.corner_fit_scale;
      }
      detectors.push_back(std::make_unique<Detector>(options, scene.camera, models));
    }
    // Each JPEG profile and its lossless twin (CodecTally), on the well-exposed plain sets.
    std::vector<std::pair<size_t, size_t>> twins;
    std::vector<CodecTally> tallies;
    if (!run.textured && run.exposure_scale == 1) {
      double reference_defocus = std::numeric_limits<double>::quiet_NaN();
      for (size_t p = 0; p < profiles.size(); ++p)
        if (profiles[p] == "linear") reference_defocus = sensors[p].defocus_sigma_px;
      for (size_t a = 0; a < profiles.size(); ++a)
        for (size_t b = 0; b < profiles.size(); ++b)
          if (sensors[a].format == "jpeg" && sensors[b].format == "png" &&
              SameButTheCodec(sensors[a], sensors[b])) {
            twins.push_back({a, b});
            CodecTally t;
            t.profile = profiles[a], t.twin = profiles[b];
            t.defocus_px = sensors[a].defocus_sigma_px;
            t.reference_defocus_px = reference_defocus;
            tallies.push_back(t);
            break;
          }
    }
    const std::vector<CodecTally> blank_tallies = tallies;  // each worker's view starts from it
    bool any_defocus = false;
    for (const Sensor& s : sensors) any_defocus = any_defocus || s.defocus_sigma_px > 0;
    const int n = static_cast<int>(scene.views.size());
    std::vector<std::vector<ProfileRow>> view_rows(n);
    std::vector<std::vector<ViewTiming>> view_timings(n);
    std::atomic<int> next{0};
    int done = 0;
    std::mutex io;
    std::string failure;
    Progress progress("svms bench profiles: " + run.name, n);
    auto worker = [&] {
      for (int v; (v = next++) < n;) {
        // The light on the finer grid where any profile's lens blurs (render.h); the others'
        // pixels integrate it unblurred.
        const cv::Mat radiance =
            any_defocus ? renderer->RenderRadianceFine(v) : renderer->RenderRadiance(v);
        const ViewTruth truth = ComputeTruth(*renderer, v);
        std::vector<cv::Mat> decoded_by(profiles.size());
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
          decoded_by[p] = decoded;
          DetectionStats stats;
          const auto t0 = std::chrono::steady_clock::now();
          // A raw frame's noise from its stored values, as svms detect and PoseEstimator take it.
          NoiseModel stored_noise;
          const bool have_noise =
              EstimateStoredNoise(decoded, readers[p].model(),
                                  std::chrono::steady_clock::time_point::max(), &stored_noise);
          std::vector<Detection> found;
          detectors[p]->Detect(linear, &stats, std::chrono::steady_clock::time_point::max(), &found,
                               have_noise ? &stored_noise : nullptr);
          ViewTiming t;
          t.profile = profiles[p], t.set = run.name, t.textured = run.textured;
          t.ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0)
                     .count();
          t.noise = stats.noise;
          view_timings[v].push_back(t);
          if (!run.textured) Score(profiles[p], run.name, truth, found, &view_rows[v]);
        }
        std::vector<CodecTally> view_tallies = blank_tallies;
        for (size_t k = 0; k < twins.size(); ++k) {
          const auto [a, b] = twins[k];
          if (decoded_by[a].empty() || decoded_by[b].empty()) continue;
          const cv::Mat band = SideBand(truth, decoded_by[a].size());
          cv::Mat second;
          if (!ThroughCodec(sensors[b],
                            renderer->Expose(radiance, v + kSecondNoiseDraw, sensors[b]), &second))
            continue;
          cv::Mat lossy, lossless, again;
          decoded_by[a].convertTo(lossy, CV_64F);
          decoded_by[b].convertTo(lossless, CV_64F);
          second.convertTo(again, CV_64F);
          CodecTally& t = view_tallies[k];
          for (int y = 0; y < band.rows; ++y)
            for (int x = 0; x < band.cols; ++x) {
              if (!band.at<uint8_t>(y, x)) continue;
              const double e = lossy.at<double>(y, x) - lossless.at<double>(y, x);
              const double n = lossless.at<double>(y, x) - again.at<double>(y, x);
              t.codec_sq += e * e, t.noise_sq += 0.5 * n * n, ++t.pixels;
            }
        }
        std::lock_guard<std::mutex> lock(io);
        for (size_t k = 0; k < tallies.size(); ++k) {
          tallies[k].codec_sq += view_tallies[k].codec_sq;
          tallies[k].noise_sq += view_tallies[k].noise_sq;
          tallies[k].pixels += view_tallies[k].pixels;
        }
        progress.Update(++done);
      }
    };
    std::vector<std::thread> pool;
    for (int t = 0; t < std::min(o.threads, n); ++t) pool.emplace_back(worker);
    for (auto& t : pool) t.join();
    progress.Finish();
    if (!failure.empty()) return Status::Error(failure);
    for (const CodecTally& t : tallies) {
      auto it = std::find_if(codec->begin(), codec->end(), [&](const CodecTally& c) {
        return c.profile == t.profile && c.twin == t.twin;
      });
      if (it == codec->end()) {
        codec->push_back(t);
      } else {
        it->codec_sq += t.codec_sq, it->noise_sq += t.noise_sq, it->pixels += t.pixels;
      }
    }
    for (int v = 0; v < n; ++v) {
      rows->insert(rows->end(), view_rows[v].begin(), view_rows[v].end());
      timings->insert(timings->end(), view_timings[v].begin(), view_timings[v].end());
    }
  }
  return Status::Ok();
}

int RunBenchmark(const ProfilesBenchmarkOptions& o) {
  std::vector<std::string> profiles = o.profiles;
  if (profiles.empty()) profiles = SensorProfileNames();
  for (const std::string& p : profiles) {
    Sensor s;
    if (Status st = ApplySensorProfile(p, &s); !st) {
      std::cerr << "svms bench profiles: --profiles: " << st.message() << "\n";
      return kExitBadInput;
    }
  }
  if (o.decimate < 1 || o.decimate > kMaxDecimate) {
    std::cerr << "svms bench profiles: --decimate: " << o.decimate << " is not a factor in 1-"
              << kMaxDecimate << "\n";
    return kExitBadInput;
  }
  if (Status s = PrepareOutputDirectory("--out", o.out); !s) {
    std::cerr << "svms bench profiles: " << s.message() << "\n";
    return kExitBadInput;
  }
  std::vector<ProfileRow> rows;
  std::vector<ViewTiming> timings;
  std::vector<CodecTally> codec;
  const auto t_start = std::chrono::steady_clock::now();
  // The angle set on black and on the Earth one after the other: their times are compared.
  for (const SetRun& run : {SetRun{"range", "range"}, SetRun{"small", "small"},
                            SetRun{kDimSet, "small", false, kDimExposureScale},
                            SetRun{"angle", "angle"}, SetRun{"angle_earth", "angle", true}}) {
    if (Status s = RunSet(run, o, profiles, &rows, &timings, &codec); !s) {
      std::cerr << "svms bench profiles: " << s.message() << "\n";
      return kExitFailed;
    }
  }
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  return WriteProfilesReport(o, profiles, rows, timings, codec, seconds);
}

}  // namespace

int RunProfilesBenchmark(const ProfilesBenchmarkOptions& options) {
  return FinishOutputs("svms bench profiles", RunBenchmark(options));
}

}  // namespace svms

#include "svms/bench/compare_tables.h"

#include <cmath>
#include <iostream>
#include <string>

#include "svms/base/statistics.h"
#include "svms/bench/report_numbers.h"
#include "svms/pipelines/gnuplot.h"
#include "svms/pipelines/report_file.h"

namespace svms {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// Draws NAME.png and NAME.svg in `dir` from `script` (gnuplot, terminal lines left to Gnuplot())
// after the settings every compare plot shares. False (with a message) if gnuplot fails.
bool Plot(const fs::path& dir, const std::string& name, const std::string& script,
          const std::string& size = "900,560") {
  const std::string body =
      "# drawn by svms bench compare; run in this directory\n"
      "set termoption noenhanced\nset datafile separator ','\nset key outside right top\n"
      "set grid\n" +
      script;
  if (Status s = Gnuplot(dir.string(), name, body, size); !s) {
    std::cerr << "svms bench compare: " << s.message() << "\n";
    return false;
  }
  return true;
}

}  // namespace

void WriteCompareCsv(const fs::path& dir, const CompareRun& run) {
  OutputFile f(dir / "markers.csv");
  f << "sweep,view,condition,config,family,truth_id,eligible,detected,wrong_id,min_side_px,"
       "view_angle_deg,occluded_fraction,distance_m,corner_rms_px,range_err_m,"
       "orientation_err_deg,twin_err_deg,pose_ambiguous,pose_nees,alternative_err_deg,"
       "alternative_weight\n";
  for (const MarkerRecord& r : run.markers) {
    const MarkerOutcome& m = r.m;
    f << r.sweep << "," << r.view << "," << r.condition << "," << r.config << "," << r.family << ","
      << m.truth_id << "," << m.eligible << "," << m.detected << "," << m.wrong_id << ","
      << Cell(m.min_side_px, 3) << "," << Cell(m.view_angle_deg, 3) << ","
      << Cell(m.occluded_fraction, 4) << "," << Cell(m.distance_m, 4) << ","
      << Cell(m.corner_rms_px, 4) << "," << Cell(m.range_err_m, 6) << ","
      << Cell(m.orientation_err_deg, 4) << "," << Cell(m.twin_err_deg, 4) << ","
      << (m.detected && std::isfinite(m.orientation_err_deg) ? std::to_string(m.pose_ambiguous)
                                                             : "-")
      << "," << Cell(m.pose_nees, 3) << "," << Cell(m.alternative_err_deg, 4) << ","
      << (std::isfinite(m.alternative_err_deg) ? Cell(m.alternative_weight, 4) : "-") << "\n";
  }
  OutputFile g(dir / "images.csv");
  g << "sweep,view,config,time_ms,detections,false_positives,wrong_ids\n";
  for (const ImageRecord& r : run.images)
    g << r.sweep << "," << r.view << "," << r.config << "," << Cell(r.ms, 3) << "," << r.detections
      << "," << r.false_positives << "," << r.wrong_ids << "\n";
  OutputFile h(dir / "fig9.csv");
  h << "view,distance_m,used,range_err_mm,orientation_err_deg\n";
  for (const Fig9Row& r : run.fig9)
    h << r.view << "," << Cell(r.distance, 4) << "," << r.used << "," << Cell(r.range_err_mm, 3)
      << "," << Cell(r.orient_err_deg, 4) << "\n";
}

json WriteCompareSummary(const fs::path& dir, const CompareBenchmarkOptions& o,
                         const CompareRun& run, CompareTallies& tallies) {
  json summary;
  summary["type"] = "svms.bench.compare";
  summary["seed"] = o.seed;
  summary["quick"] = o.quick;
  summary["size_views"] = o.quick ? 1 : o.size_views;
  summary["marker_size_m"] = run.scenes.marker_size;
  summary["svms_post_height_m"] = run.scenes.post_height_fraction * run.scenes.marker_size;
  summary["fairness"] = {
      {"size", "every tag's outer black edge = the SVMS black square (same corners in space)"},
      {"peer_cells", "8 x 8 cells of size/8 at that edge; SVMS data ring outside it (2x size)"},
      {"scenes", "same camera, poses, light, occluders, sensor and noise seed per view"},
      {"ids", "every system decodes its whole family (svms44 32768, tag36h11 587, aruco 1000)"},
      {"threads", "one core per detector; rendering on --threads"},
      {"peer_post", "peer tags have no post; the SVMS markers carry the standard post"}};
  summary["systems"] = run.settings;
  json jsw = json::array();
  for (const CompareSweep& sw : run.sweeps)
    jsw.push_back({{"name", sw.name},
                   {"description", sw.description},
                   {"views", sw.scene.views.size()},
                   {"scene_files", "scenes/" + sw.name + "_{svms44,tag36h11,aruco6x6}.json"}});
  summary["sweeps"] = jsw;
  summary["camera"] = "1024x1024 pinhole, f = 1111.1 px (the range set's)";
  summary["sensor"] = {{"bits", run.sweeps[0].scene.sensor.bits},
                       {"exposure", run.sweeps[0].scene.sensor.exposure},
                       {"full_well", run.sweeps[0].scene.sensor.full_well},
                       {"read_noise", run.sweeps[0].scene.sensor.read_noise},
                       {"shot_noise", run.sweeps[0].scene.sensor.shot_noise},
                       {"rays_per_pixel", run.sweeps[0].scene.sensor.rays_per_pixel},
                       {"edge_rays_per_pixel", run.sweeps[0].scene.sensor.edge_rays_per_pixel}};
  json res = json::object();
  for (const std::string& n : run.names) {
    const Timing& t = tallies.timing[n];
    json j = tallies.overall[n].Json();
    j["small_30px"] = tallies.small[n].Json();
    j["time_ms_median"] = Median(t.all);
    j["time_ms_p99"] = Percentile(t.all, 0.99);
    j["time_ms_median_clutter"] = t.clutter.empty() ? json() : json(Median(t.clutter));
    j["time_ms_p99_clutter"] = t.clutter.empty() ? json() : json(Percentile(t.clutter, 0.99));
    j["false_positives_clutter"] = t.fp_clutter;
    j["clutter_images"] = t.clutter_images;
    j["false_positives_scenes"] = t.fp_scenes;
    j["wrong_id_detections"] = t.wrong;
    json bs = json::object();
    for (const auto& [sweep, conds] : tallies.by) {
      json c = json::object();
      for (const auto& [cond, cfgs] : conds)
        if (cfgs.count(n)) c[cond] = cfgs.at(n).Json();
      bs[sweep] = c;
    }
    j["by_sweep"] = bs;
    res[n] = j;
  }
  summary["results"] = res;
  // Fig. 9 by distance (the range set's distances, several views each).
  std::map<double, std::vector<const Fig9Row*>> by_d;
  for (const Fig9Row& r : run.fig9) by_d[std::round(r.distance * 20) / 20].push_back(&r);
  json jf = json::array();
  {
    OutputFile f(dir / "fig9_summary.csv");
    f << "distance_m,views,found,range_err_mm_rms,orientation_err_deg_rms\n";
    for (const auto& [D, rows] : by_d) {
      double sr = 0, so = 0;
      int k = 0;
      for (const Fig9Row* r : rows)
        if (std::isfinite(r->range_err_mm)) {
          sr += r->range_err_mm * r->range_err_mm;
          so += r->orient_err_deg * r->orient_err_deg;
          ++k;
        }
      const double rr = k ? std::sqrt(sr / k) : NAN, ro = k ? std::sqrt(so / k) : NAN;
      f << Cell(D, 3) << "," << rows.size() << "," << k << "," << Cell(rr, 3) << "," << Cell(ro, 4)
        << "\n";
      jf.push_back({{"distance_m", D},
                    {"views", rows.size()},
                    {"found", k},
                    {"range_err_mm_rms", k ? json(rr) : json()},
                    {"orientation_err_deg_rms", k ? json(ro) : json()}});
    }
  }
  summary["fig9"] = {{"marker", "dual 0.432 / 0.108 m, post 27 mm"},
                     {"camera", "1024x1024 pinhole, f = 1111.1 px"},
                     {"paper",
                      {{{"distance_m", 0.8}, {"range_err_mm", 1}, {"orientation_err_deg", 0.16}},
                       {{"distance_m", 16}, {"range_err_mm", 42}, {"orientation_err_deg", 1.7}}}},
                     {"by_distance", jf}};
  OutputFile(dir / "summary.json") << summary.dump(1) << "\n";
  return jf;
}

bool WriteComparePlots(const fs::path& dir, const CompareRun& run, CompareTallies& tallies) {
  auto write_sweep = [&](const std::string& sweep, const std::string& file, bool numeric_x,
                         const std::vector<std::string>& order) {
    OutputFile f(dir / file);
    f << "condition,x";
    for (const std::string& n : run.names) f << "," << n << "_rate," << n << "_orient_med";
    f << "\n";
    int row = 0;
    for (const std::string& cond : order) {
      if (!tallies.by[sweep].count(cond)) continue;
      const auto& cfgs = tallies.by[sweep][cond];
      double x = row++;
      if (numeric_x) {
        std::vector<double> sides;
        for (const auto& [n, t] : cfgs) sides.insert(sides.end(), t.side.begin(), t.side.end());
        x = sweep == "size" ? Median(sides) : std::stod(cond);
      }
      f << cond << "," << Cell(x, 2);
      for (const std::string& n : run.names) {
        const auto it = cfgs.find(n);
        const Tally* t = it == cfgs.end() ? nullptr : &it->second;
        f << "," << (t && t->eligible ? Cell(100 * t->rate(), 2) : "NaN") << ","
          << (t && !t->orient.empty() ? Cell(Median(t->orient), 4) : "NaN");
      }
      f << "\n";
    }
  };
  std::vector<std::string> size_conds, angle_conds;
  for (const auto& [c, _] : tallies.by["size"]) size_conds.push_back(c);
  for (const auto& [c, _] : tallies.by["angle"]) angle_conds.push_back(c);
  write_sweep("size", "compare_size.csv", true, size_conds);
  write_sweep("angle", "compare_angle.csv", true, angle_conds);
  write_sweep("occlusion", "compare_occlusion.csv", false,
              {"0", "0-10%", "10-20%", "20-35%", ">35%"});
  write_sweep("sun", "compare_sun.csv", false, {"sun", "lowsun", "edge", "shadow"});

  std::string lines_rate, lines_orient;
  const char* styles[] = {"lw 3 pt 7 lc rgb '#d62728'", "lw 2 pt 5 lc rgb '#1f77b4'",
                          "lw 2 pt 4 lc rgb '#17becf'", "lw 2 pt 9 lc rgb '#2ca02c'",
                          "lw 2 pt 8 lc rgb '#98df8a'"};
  for (size_t i = 0; i < run.names.size(); ++i) {
    const std::string sep = i ? ", '' " : "";
    lines_rate += sep + "using 2:" + std::to_string(3 + 2 * i) + " with linespoints " +
                  styles[i % 5] + " title '" + run.names[i] + "'";
    lines_orient += sep + "using 2:" + std::to_string(4 + 2 * i) + " with linespoints " +
                    styles[i % 5] + " title '" + run.names[i] + "'";
  }
  bool plots_ok = true;
  plots_ok &=
      Plot(dir, "compare_size",
           "set title 'Detection rate vs marker size (black square = peer outer black edge)'\n"
           "set xlabel 'shortest side of the black square in the image (px)'\n"
           "set ylabel 'detected (%)'\nset logscale x\nset yrange [0:105]\nset xrange [7:130]\n"
           "set xtics (8,10,12,15,20,30,40,60,80,120)\n"
           "plot 'compare_size.csv' skip 1 " +
               lines_rate);
  plots_ok &= Plot(dir, "compare_size_orientation",
                   "set title 'Orientation error vs marker size (median over the detected)'\n"
                   "set xlabel 'shortest side of the black square in the image (px)'\n"
                   "set ylabel 'orientation error (deg)'\nset logscale xy\nset xrange [7:130]\n"
                   "set xtics (8,10,12,15,20,30,40,60,80,120)\n"
                   "plot 'compare_size.csv' skip 1 " +
                       lines_orient);
  plots_ok &= Plot(dir, "compare_angle",
                   "set title 'Detection rate vs viewing angle (50 px head-on)'\n"
                   "set xlabel 'angle between marker normal and line of sight (deg)'\n"
                   "set ylabel 'detected (%)'\nset yrange [0:105]\n"
                   "plot 'compare_angle.csv' skip 1 " +
                       lines_rate);
  plots_ok &= Plot(dir, "compare_occlusion",
                   "set title 'Detection rate vs occluded fraction of the data cells (60 px)'\n"
                   "set xlabel 'occluded data cells'\nset ylabel 'detected (%)'\n"
                   "set yrange [0:105]\nset xrange [-0.5:4.5]\n"
                   "set xtics ('0' 0, '0-10%%' 1, '10-20%%' 2, '20-35%%' 3, '>35%%' 4)\n"
                   "plot 'compare_occlusion.csv' skip 1 " +
                       lines_rate);
  {
    OutputFile paper(dir / "fig9_paper.csv");
    paper << "distance_m,range_err_mm,orientation_err_deg\n0.8,1,0.16\n16,42,1.7\n";
  }
  plots_ok &= Plot(dir, "fig9",
                   "set multiplot layout 1,2 title 'Dual SVMS marker 0.432 m, 1024x1024 camera "
                   "(cf. paper Fig. 9)'\nset key inside left top\nset logscale x\n"
                   "set xtics (0.8,2,4,8,16)\nset xrange [0.7:18]\nset logscale y\n"
                   "set xlabel 'distance (m)'\n"
                   "set ylabel 'range error (mm)'\n"
                   "plot 'fig9.csv' skip 1 using 2:4 with points pt 6 lc rgb '#999999' title "
                   "'each view', 'fig9_summary.csv' skip 1 using 1:4 with linespoints lw 2 pt 7 "
                   "lc rgb '#d62728' title 'RMS', 'fig9_paper.csv' skip 1 using 1:2 with points "
                   "pt 5 ps 2 lc rgb 'black' title 'paper'\n"
                   "set ylabel 'orientation error (deg)'\n"
                   "plot 'fig9.csv' skip 1 using 2:5 with points pt 6 lc rgb '#999999' title "
                   "'each view', 'fig9_summary.csv' skip 1 using 1:5 with linespoints lw 2 pt 7 "
                   "lc rgb '#d62728' title 'RMS', 'fig9_paper.csv' skip 1 using 1:3 with points "
                   "pt 5 ps 2 lc rgb 'black' title 'paper'\nunset multiplot",
                   "1100,480");
  return plots_ok;
}

}  // namespace svms

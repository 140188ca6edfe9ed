#include "svms/bundle/survey_report.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "svms/base/file_io.h"
#include "svms/base/format.h"

namespace svms {
namespace {

namespace fs = std::filesystem;

// markers.csv: each surveyed marker's pose (object frame), sigmas, post and residuals.
std::string MarkersCsv(const SurveyResult& r, const std::vector<MarkerSigmas>& sig) {
  const SurveySummary& S = r.summary;
  std::ostringstream markers_csv;
  markers_csv << "id,x_m,y_m,z_m,rx,ry,rz,position_sigma_mm,orientation_sigma_deg,post_height_m,"
                 "post_height_sigma_mm,points,outliers,rms_px,max_px\n";
  for (size_t i = 0; i < r.layout.markers.size(); ++i) {
    const LayoutEntry& e = r.layout.markers[i];
    const Pose& p = e.object_from_marker;
    markers_csv.precision(9);
    markers_csv << e.marker.id << "," << p.tvec.x() << "," << p.tvec.y() << "," << p.tvec.z() << ","
                << p.rvec.x() << "," << p.rvec.y() << "," << p.rvec.z() << "," << sig[i].position_mm
                << "," << sig[i].orientation_deg << ","
                << (e.marker.post ? e.marker.post->height : 0) << "," << sig[i].post_height_mm;
    const ResidualStats* st = nullptr;
    for (const ResidualStats& s : S.per_marker)
      if (s.name == "marker " + std::to_string(e.marker.id)) st = &s;
    if (st)
      markers_csv << "," << st->points << "," << st->outliers << "," << st->rms_px << ","
                  << st->max_px;
    else
      markers_csv << ",0,0,0,0";
    markers_csv << "\n";
  }
  return markers_csv.str();
}

// The layout picture's data (gnuplot's): marker squares, 3-sigma position ellipsoids
// magnified, camera centres, labels; and its plot box and magnification.
struct LayoutPicture {
  std::string squares, ellipses, cams, labels;
  Eigen::Vector3d lo, hi;  // the plot box, object frame, metres
  double magnify = 1;      // of the ellipsoids
};

// The plot box is the markers' bounding box with a margin (cameras outside are clipped); the
// ellipsoids are magnified by a power of ten that makes the median one about 5 % of the box.
LayoutPicture MakeLayoutPicture(const SurveyResult& r) {
  LayoutPicture pic;
  std::ostringstream squares, ellipses, cams, labels;
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  std::vector<double> radii3;
  for (const LayoutEntry& e : r.layout.markers) {
    for (const Eigen::Vector3d& c : e.marker.Corners()) {
      lo = lo.cwiseMin(e.object_from_marker * c);
      hi = hi.cwiseMax(e.object_from_marker * c);
    }
    if (e.covariance && !e.covariance->isZero())
      radii3.push_back(
          3 * std::sqrt(std::max(
                  0.0, e.covariance->bottomRightCorner<3, 3>().eigenvalues().real().maxCoeff())));
  }
  if (r.layout.markers.empty()) lo = hi = Eigen::Vector3d::Zero();
  const double extent = std::max(0.2, (hi - lo).maxCoeff());
  lo -= Eigen::Vector3d::Constant(0.3 * extent);
  hi += Eigen::Vector3d::Constant(0.3 * extent);
  std::sort(radii3.begin(), radii3.end());
  const double median = radii3.empty() ? 0 : radii3[radii3.size() / 2];
  const double magnify =
      median > 0 ? std::max(1.0, std::pow(10, std::floor(std::log10(0.05 * extent / median)))) : 1;
  for (const LayoutEntry& e : r.layout.markers) {
    const auto corners = e.marker.Corners();
    for (int k = 0; k <= 4; ++k) {
      const Eigen::Vector3d p = e.object_from_marker * corners[k % 4];
      squares << p.x() << " " << p.y() << " " << p.z() << "\n";
    }
    squares << "\n\n";
    const Eigen::Vector3d c = e.object_from_marker.tvec;
    labels << c.x() << " " << c.y() << " " << c.z() << " " << e.marker.id << "\n";
    if (!e.covariance) continue;
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(e.covariance->bottomRightCorner<3, 3>());
    const Eigen::Vector3d radii = 3 * magnify * es.eigenvalues().cwiseMax(0).cwiseSqrt();
    for (int plane = 0; plane < 3; ++plane) {
      const int a = plane, b = (plane + 1) % 3;
      for (int k = 0; k <= 48; ++k) {
        const double t = 2 * M_PI * k / 48;
        const Eigen::Vector3d p = c + es.eigenvectors().col(a) * radii(a) * std::cos(t) +
                                  es.eigenvectors().col(b) * radii(b) * std::sin(t);
        ellipses << p.x() << " " << p.y() << " " << p.z() << "\n";
      }
      ellipses << "\n\n";
    }
  }
  for (size_t i = 0; i < r.cam_from_object.size(); ++i)
    if (r.image_used[i]) {
      const Eigen::Vector3d c = r.cam_from_object[i].Inverse().tvec;
      cams << c.x() << " " << c.y() << " " << c.z() << "\n";
    }
  pic.squares = squares.str();
  pic.ellipses = ellipses.str();
  pic.cams = cams.str();
  pic.labels = labels.str();
  pic.lo = lo;
  pic.hi = hi;
  pic.magnify = magnify;
  return pic;
}

// The gnuplot script of the layout picture (its data files written beside it).
std::string LayoutPlotScript(const LayoutPicture& pic) {
  const Eigen::Vector3d &lo = pic.lo, &hi = pic.hi;
  const std::string mag =
      pic.magnify >= 1 ? std::to_string(static_cast<long>(pic.magnify)) : Fixed(pic.magnify, 3);
  return "set title 'Surveyed layout (object frame, m): markers, 3-sigma position ellipsoids x" +
         mag +
         ", cameras'\n"
         "set xlabel 'x'\nset ylabel 'y'\nset zlabel 'z'\nset view equal xyz\nset view 60, 30\n"
         "set key bottom right\nset xrange [" +
         Fixed(lo.x(), 3) + ":" + Fixed(hi.x(), 3) + "]\nset yrange [" + Fixed(lo.y(), 3) + ":" +
         Fixed(hi.y(), 3) + "]\nset zrange [" + Fixed(lo.z(), 3) + ":" + Fixed(hi.z(), 3) +
         "]\n"
         "splot 'layout_squares.dat' with lines lw 2 lc rgb '#202020' title 'markers', \\\n"
         "  'layout_ellipses.dat' with lines lc rgb '#d02020' title '3 sigma x" +
         mag +
         "', \\\n"
         "  'layout_cameras.dat' with points pt 7 ps 0.4 lc rgb '#2060d0' title 'cameras (in the "
         "box)', \\\n"
         "  'layout_labels.dat' using 1:2:3:4 with labels offset 1,1 notitle\n";
}

// report.md: the summary, the markers' table, the pictures drawn (layout_ok, res_ok) and the
// solver's reports.
std::string ReportMarkdown(const SurveyResult& r, const std::vector<MarkerSigmas>& sig,
                           bool layout_ok, bool res_ok) {
  const SurveySummary& S = r.summary;
  std::ostringstream md;
  md << "## Survey report\n\n";
  if (!S.success) md << "**The survey failed:** " << S.message << "\n\n";
  md << "Images used: " << S.images_used << " of " << S.images_total << " (" << S.detections_used
     << " detections); markers surveyed: " << S.markers_surveyed << ".\n";
  for (const auto& [id, why] : S.left_out) md << "- marker " << id << " left out: " << why << "\n";
  md << "\nResiduals m = " << S.residuals << ", parameters n = " << S.parameters
     << ", RMS reprojection residual " << Fixed(S.rms_px, 3) << " px, a-posteriori variance factor "
     << Fixed(S.variance_factor, 3) << "; covariances "
     << (S.covariance_ok ? (S.covariance_scaled ? "scaled by it" : "not scaled") : "not computed")
     << (S.covariance_ok
             ? (S.calibration_in_covariance ? ", the camera calibration's uncertainty included"
                                            : ", without the camera calibration's uncertainty")
             : "")
     << (S.covariance_ok && S.corner_repeat_in_covariance
             ? ", and the repeated corner error of the markers seen with grey levels "
               "(SurveyOptions::corner_repeat_px_grey over each detection's contrast)"
             : "")
     << ". Points rejected as outliers: " << S.rejected.size() << ".\n\n";
  if (S.intrinsics_refined && S.success) {
    md << "The camera's intrinsics were refined with the layout: **the layout belongs to the "
          "camera "
       << (S.refined_camera.empty()
               ? "the survey refined**, which was not written (`--out-camera` writes it); with the "
                 "input camera it is not consistent"
               : "`" + S.refined_camera +
                     "`** (written with its covariance sidecar), not to the input camera")
       << ". Its " << r.camera.lensmodel() << " intrinsics (sigma):";
    const std::vector<double>& in = r.camera.intrinsics();
    const Eigen::MatrixXd& L = r.camera.intrinsics_covariance_factor();
    for (size_t k = 0; k < in.size(); ++k) {
      md << (k ? ", " : " ") << Significant(in[k], 17);
      if (L.rows() == static_cast<Eigen::Index>(in.size()))
        md << " (" << Significant(L.row(static_cast<Eigen::Index>(k)).norm(), 3) << ")";
    }
    md << ".\n\n";
  }
  md << "| marker | x (m) | y (m) | z (m) | position sigma (mm) | orientation sigma (deg) | post "
        "height (mm) | its sigma (mm) | RMS (px) |\n|---|---|---|---|---|---|---|---|---|\n";
  for (size_t i = 0; i < r.layout.markers.size(); ++i) {
    const LayoutEntry& e = r.layout.markers[i];
    double rms = 0;
    for (const ResidualStats& s : S.per_marker)
      if (s.name == "marker " + std::to_string(e.marker.id)) rms = s.rms_px;
    md << "| " << e.marker.id << " | " << Fixed(e.object_from_marker.tvec.x(), 5) << " | "
       << Fixed(e.object_from_marker.tvec.y(), 5) << " | "
       << Fixed(e.object_from_marker.tvec.z(), 5) << " | " << Fixed(sig[i].position_mm, 4) << " | "
       << Fixed(sig[i].orientation_deg, 5) << " | "
       << (e.marker.post ? Fixed(1000 * e.marker.post->height, 3) : "-") << " | "
       << (sig[i].post_height_mm >= 0 ? Fixed(sig[i].post_height_mm, 4) : "-") << " | "
       << Fixed(rms, 3) << " |\n";
  }
  md << "\nSigmas are sqrt(trace) of the 3x3 blocks of each marker's covariance (object axes); "
        "the reference marker defines the frame (zero covariance).\n\n";
  if (layout_ok)
    md << "![](layout.png)\n\n";
  else
    md << "(layout picture not drawn: gnuplot missing or failed)\n\n";
  if (res_ok) md << "![](residuals.png)\n\n";
  md << "Per image: images.csv; per marker: markers.csv; rejected points: rejected.csv.\n\n";
  md << "Solver (first, robust): " << S.ceres_report_first
     << "\n\nSolver (second): " << S.ceres_report_second << "\n";
  return md.str();
}

}  // namespace

std::vector<MarkerSigmas> ComputeMarkerSigmas(const Layout& layout) {
  std::vector<MarkerSigmas> out;
  for (const LayoutEntry& e : layout.markers) {
    MarkerSigmas m;
    m.id = e.marker.id;
    if (e.covariance) {
      m.orientation_deg =
          std::sqrt(std::max(0.0, e.covariance->topLeftCorner<3, 3>().trace())) * 180 / M_PI;
      m.position_mm =
          1000 * std::sqrt(std::max(0.0, e.covariance->bottomRightCorner<3, 3>().trace()));
    }
    if (e.post_height_sigma) m.post_height_mm = 1000 * *e.post_height_sigma;
    out.push_back(m);
  }
  return out;
}

Status WriteSurveyReport(const SurveyResult& r, const std::string& dir, const PlotFunction& plot) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (!fs::is_directory(dir)) return Status::Error(dir + ": cannot create the directory");
  const SurveySummary& S = r.summary;
  AtomicFileSet files;
  auto Write = [&](const std::string& path, const std::string& text) {
    return files.Add(path, text);
  };
  const std::vector<MarkerSigmas> sig = ComputeMarkerSigmas(r.layout);

  // Tables.
  std::ostringstream images_csv, rejected_csv;
  images_csv << "image,points,outliers,rms_px,max_px\n";
  for (const ResidualStats& s : S.per_image)
    images_csv << s.name << "," << s.points << "," << s.outliers << "," << s.rms_px << ","
               << s.max_px << "\n";
  rejected_csv << "image,marker,point,residual_px\n";
  for (const RejectedPoint& p : S.rejected)
    rejected_csv << p.image << "," << p.marker_id << "," << p.point << "," << p.residual_px << "\n";
  for (const auto& [name, text] :
       {std::pair<std::string, std::string>{"markers.csv", MarkersCsv(r, sig)},
        {"images.csv", images_csv.str()},
        {"rejected.csv", rejected_csv.str()}})
    if (Status s = Write((fs::path(dir) / name).string(), text); !s) return s;

  // The layout picture: marker squares, 3-sigma position ellipsoids magnified, cameras.
  const LayoutPicture pic = MakeLayoutPicture(r);
  for (const auto& [name, text] :
       {std::pair<std::string, std::string>{"layout_squares.dat", pic.squares},
        {"layout_ellipses.dat", pic.ellipses},
        {"layout_cameras.dat", pic.cams},
        {"layout_labels.dat", pic.labels}})
    if (Status s = Write((fs::path(dir) / name).string(), text); !s) return s;
  auto draw = [&](const std::string& name, const std::string& body, const std::string& size) {
    return plot && plot(dir, name, body, size, &files).ok();
  };
  const bool layout_ok = draw("layout", LayoutPlotScript(pic), "1100,850");
  const bool res_ok = draw("residuals",
                           "set datafile separator ','\nset title 'RMS reprojection residual "
                           "per image'\nset xlabel 'image'\nset ylabel 'px'\nset yrange [0:*]\n"
                           "plot 'images.csv' using 0:4 every ::1 with impulses lw 2 title 'RMS', "
                           "'' using 0:5 every ::1 with points pt 1 title 'max'\n",
                           "1000,400");

  Write((fs::path(dir) / "report.md").string(), ReportMarkdown(r, sig, layout_ok, res_ok));
  return files.Commit();
}

}  // namespace svms

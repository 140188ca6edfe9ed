#include "svms/corner_refine.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <array>
#include <cmath>
#include <vector>

namespace svms {

double SampleImage(const cv::Mat& img, double u, double v) {
  u = std::clamp(u, 0.0, img.cols - 1.0);
  v = std::clamp(v, 0.0, img.rows - 1.0);
  const int x0 = std::min(static_cast<int>(u), img.cols - 2 < 0 ? 0 : img.cols - 2);
  const int y0 = std::min(static_cast<int>(v), img.rows - 2 < 0 ? 0 : img.rows - 2);
  const int x1 = std::min(x0 + 1, img.cols - 1), y1 = std::min(y0 + 1, img.rows - 1);
  const double fx = u - x0, fy = v - y0;
  auto at = [&](int y, int x) -> double {
    return img.depth() == CV_16U ? img.at<uint16_t>(y, x) : img.at<uint8_t>(y, x);
  };
  return (1 - fy) * ((1 - fx) * at(y0, x0) + fx * at(y0, x1)) +
         fy * ((1 - fx) * at(y1, x0) + fx * at(y1, x1));
}

namespace {

// Maps pixels to the plane where lines are fitted, and back.
struct Plane {
  const CameraModel* camera;
  bool ToPlane(const Eigen::Vector2d& px, Eigen::Vector2d* q) const {
    if (!camera) {
      *q = px;
      return true;
    }
    Eigen::Vector3d d;
    if (!camera->Unproject(px, &d) || d.z() <= 0) return false;
    *q = d.head<2>() / d.z();
    return true;
  }
  bool ToPixel(const Eigen::Vector2d& q, Eigen::Vector2d* px) const {
    if (!camera) {
      *px = q;
      return true;
    }
    return camera->Project(Eigen::Vector3d(q.x(), q.y(), 1), px);
  }
};

}  // namespace

RefinedCorners RefineCorners(const cv::Mat& img, const std::array<Eigen::Vector2d, 4>& in,
                             const CameraModel* camera, const CornerRefineOptions& o) {
  RefinedCorners out;
  out.corners = in;
  const Plane plane{camera};
  for (int it = 0; it < o.iterations; ++it) {
    std::array<Eigen::Vector3d, 4> lines;  // in the fitting plane
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector2d a = out.corners[k], b = out.corners[(k + 1) % 4];
      const double len = (b - a).norm();
      const Eigen::Vector2d u = (b - a) / len, outward(u.y(), -u.x());  // dark is screen-right
      const int m = std::clamp(static_cast<int>(len / 1.5), 4, o.max_points);
      std::vector<Eigen::Vector2d> pts;
      std::vector<double> weights;
      for (int i = 0; i < m; ++i) {
        const double t = o.end_margin + (1 - 2 * o.end_margin) * (i + 0.5) / m;
        const Eigen::Vector2d p = a + t * (b - a);
        // Derivative of intensity along the outward normal, at 0.5 px steps.
        const int steps = static_cast<int>(std::ceil(o.search_px / 0.5));
        double best = 0;
        int best_s = 0;
        std::vector<double> deriv(2 * steps + 1);
        for (int s = -steps; s <= steps; ++s) {
          const Eigen::Vector2d q = p + 0.5 * s * outward;
          const Eigen::Vector2d f = q + 0.5 * outward, r = q - 0.5 * outward;
          deriv[s + steps] = SampleImage(img, f.x(), f.y()) - SampleImage(img, r.x(), r.y());
        }
        for (int s = -steps + 1; s < steps; ++s) {
          if (deriv[s + steps] > best) {
            best = deriv[s + steps];
            best_s = s;
          }
        }
        if (best <= 0 || best_s == -steps + 1 || best_s == steps - 1) continue;
        // The edge position from the area under the normalised profile, in a window centred on
        // the derivative's peak: for a step seen through box-filtered pixels (and any
        // symmetric blur) the bright length is the integral, whatever the pixel phase -- the
        // peak of the derivative alone locks toward pixel centres on sharp edges.
        const Eigen::Vector2d centre = p + 0.5 * best_s * outward;
        const double W = 2.0, h = 0.25;
        const int ns = static_cast<int>(2 * W / h);
        double dark = 0, bright = 0, area = 0;
        std::array<double, 17> prof{};
        for (int i = 0; i <= ns; ++i) {
          const Eigen::Vector2d q = centre + (-W + i * h) * outward;
          prof[i] = SampleImage(img, q.x(), q.y());
        }
        for (int i = 0; i < 3; ++i) {
          dark += prof[i] / 3;
          bright += prof[ns - i] / 3;
        }
        if (bright - dark < 0.3 * best) continue;
        for (int i = 0; i < ns; ++i)
          area += 0.5 * (prof[i] + prof[i + 1] - 2 * dark) / (bright - dark) * h;
        const double offset = W - area;  // from the window's start: -W + (2W - area)
        const Eigen::Vector2d edge = centre + std::clamp(offset, -W, W) * outward;
        Eigen::Vector2d q;
        if (!plane.ToPlane(edge, &q)) continue;
        pts.push_back(q);
        weights.push_back(best);
      }
      if (pts.size() < 3) return out;  // not refined: keep what we had, ok = false
      // Weighted total least squares line.
      double wsum = 0;
      Eigen::Vector2d mean = Eigen::Vector2d::Zero();
      for (size_t i = 0; i < pts.size(); ++i) {
        mean += weights[i] * pts[i];
        wsum += weights[i];
      }
      mean /= wsum;
      Eigen::Matrix2d cov = Eigen::Matrix2d::Zero();
      for (size_t i = 0; i < pts.size(); ++i)
        cov += weights[i] * (pts[i] - mean) * (pts[i] - mean).transpose();
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(cov);
      const Eigen::Vector2d nrm = es.eigenvectors().col(0);
      lines[k] = Eigen::Vector3d(nrm.x(), nrm.y(), -nrm.dot(mean));
      out.side_points[k] = static_cast<int>(pts.size());
      // Residual RMS in pixels (approximately: scale plane distances by the local pixel size).
      double ss = 0;
      for (const auto& q : pts) ss += std::pow(nrm.dot(q - mean), 2);
      double scale = 1;
      if (camera) {
        Eigen::Vector2d p0, p1;
        if (plane.ToPixel(mean, &p0) && plane.ToPixel(mean + 1e-3 * nrm, &p1))
          scale = (p1 - p0).norm() / 1e-3;
      }
      out.side_rms[k] = scale * std::sqrt(ss / pts.size());
    }
    // A line fitted to n points spread evenly over a fraction f of a side, residual RMS s: its
    // offset at the middle has variance s^2 / n and its slope s^2 / (n (f L)^2 / 12); at the
    // side's end (L / 2 away) the perpendicular variance is s^2 / n (1 + 3 / f^2).
    const double f = 1 - 2 * o.end_margin;
    std::array<double, 4> perp{};
    for (int k = 0; k < 4; ++k)
      perp[k] = out.side_rms[k] * std::sqrt((1 + 3 / (f * f)) / std::max(1, out.side_points[k]));
    for (int k = 0; k < 4; ++k) {
      const int j = (k + 3) % 4;
      const double sin_angle =
          std::max(0.2, std::abs(lines[j].x() * lines[k].y() - lines[j].y() * lines[k].x()));
      out.corner_sigma[k] = std::sqrt(0.5 * (perp[j] * perp[j] + perp[k] * perp[k])) / sin_angle;
    }
    for (int k = 0; k < 4; ++k) {
      const Eigen::Vector3d h = lines[(k + 3) % 4].cross(lines[k]);
      if (std::abs(h.z()) < 1e-15) return out;
      Eigen::Vector2d px;
      if (!plane.ToPixel(h.head<2>() / h.z(), &px)) return out;
      out.corners[k] = px;
    }
  }
  out.ok = true;
  return out;
}

}  // namespace svms

// The second pass of sensor.edge_rays_per_pixel: the pixels on an edge of the first pass's
// radiance (a step, a ramp or a kink along a row, a column or a diagonal) are rendered again
// with the finer grid of samples, through the general per-sample path (pixel.cc). Why a second
// pass and not more rays everywhere: on a 1024 x 1024 view of a 120 px marker, 256 rays per
// pixel take ten times as long as 16 (108 s against 10 s for 40 views), and all but about
// 1.5 % of the pixels (the print's and the silhouettes' edges) gain nothing.
#include <algorithm>
#include <cmath>

#include "svms/sim/render_impl.h"

namespace svms {
using namespace render;  // NOLINT: the renderer's pieces (render_impl.h)

cv::Mat EdgePixels(const cv::Mat& radiance) {
  const int H = radiance.rows, W = radiance.cols;
  cv::Mat edge(H, W, CV_8U, cv::Scalar(0));
  auto at = [&](int x, int y) { return static_cast<double>(radiance.ptr<float>(y)[x]); };
  auto inside = [&](int x, int y) { return x >= 0 && y >= 0 && x < W && y < H; };
  // Half the eight neighbours: each direction through the pixel once.
  constexpr int kDirs[4][2] = {{1, 0}, {0, 1}, {1, 1}, {1, -1}};
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) {
      const double c = at(x, y);
      bool on = false;
      for (const auto& d : kDirs) {
        const bool a = inside(x - d[0], y - d[1]), b = inside(x + d[0], y + d[1]);
        const double va = a ? at(x - d[0], y - d[1]) : c, vb = b ? at(x + d[0], y + d[1]) : c;
        if ((a && std::abs(va - c) > kEdgeRadianceJump) ||
            (b && std::abs(vb - c) > kEdgeRadianceJump) ||
            (a && b && std::abs(va - 2 * c + vb) > kEdgeRadianceStep)) {
          on = true;
          break;
        }
      }
      edge.ptr<uint8_t>(y)[x] = on;
    }
  return edge;
}

// Renders the edge pixels (EdgePixels) of *out, the first pass's radiance of frame f, again with
// sensor.edge_rays_per_pixel samples each.
void Renderer::Impl::RefineEdges(const Frame& f, cv::Mat* out) const {
  // The edge pixels from the first pass alone, so that the result does not depend on the
  // order in which they are refined.
  const cv::Mat edge = EdgePixels(*out);
  RenderAgain(f, static_cast<int>(std::lround(std::sqrt(scene.sensor.edge_rays_per_pixel))), edge,
              out);
}

// Tile by tile, so that each tile's candidates are culled once.
void Renderer::Impl::RenderAgain(const Frame& f, int n, const cv::Mat& mask, cv::Mat* out) const {
  Frame g = f;
  g.n = n;
  const int nn = n * n;
  Scratch sc;
  sc.idx.resize(nn);
  sc.ray.resize(3 * (static_cast<size_t>(nn) + 2));
  sc.samples.resize(nn);
  std::vector<Candidate> candidates, pixel_cands;
  auto corner = [&](int x, int y) -> Vec3 {
    return Normalized(Mul(f.Rwc, corner_dirs[static_cast<size_t>(y) * (W + 1) + x].cast<double>()));
  };
  for (int ty = 0; ty < H; ty += kTile) {
    for (int tx = 0; tx < W; tx += kTile) {
      const int x1 = std::min(W, tx + kTile), y1 = std::min(H, ty + kTile);
      bool any = false;
      for (int y = ty; y < y1 && !any; ++y)
        for (int x = tx; x < x1 && !any; ++x) any = mask.at<uint8_t>(y, x);
      if (!any) continue;
      TileCandidates(f, tx, ty, x1, y1, &candidates);
      for (int y = ty; y < y1; ++y)
        for (int x = tx; x < x1; ++x) {
          if (!mask.at<uint8_t>(y, x)) continue;
          auto finite = [&](int i, int j) {
            return corner_dirs[static_cast<size_t>(j) * (W + 1) + i].allFinite();
          };
          if (!finite(x, y) || !finite(x + 1, y) || !finite(x, y + 1) || !finite(x + 1, y + 1))
            continue;  // as in the first pass: a pixel the lens cannot see stays 0
          PixelJob J;
          J.x = x;
          J.y = y;
          J.valid = true;
          J.samples = sc.samples.data();
          pixel_cands.clear();
          if (f.moving) {
            J.cands = &pixel_cands;  // TracePixel gathers each sample's own
          } else {
            const Vec3 c[4] = {corner(x, y), corner(x + 1, y), corner(x, y + 1),
                               corner(x + 1, y + 1)};
            PixelPlan plan;
            ConeCandidates(g, c, 4, candidates, &pixel_cands, &plan);
            J.cands = &pixel_cands;
          }
          J.plan = PixelPlan{};  // not planned: every sample traced on its own
          out->ptr<float>(y)[x] = static_cast<float>(RenderPixel(g, J, nullptr, &sc));
        }
    }
  }
}

}  // namespace svms

// The edge map of detector step 1 computed in bands of rows on several threads.
//
// FindSegments (segments.h) finds edges on a grey-level table's image (16 sqrt(grey)) with
// OpenCV's 3x3 Sobel derivatives (cv::spatialGradient) and Canny (canny.h). Here each band of
// rows runs the same steps on its own (the table and the derivatives of the row above and
// below the band are computed again by the band that needs them), then the hysteresis, which
// connects edges across the whole image, is finished from the rows where bands meet. All of it
// is integer arithmetic, and the derivatives and the edge map are the same, value for value,
// as the single-threaded steps give, whatever the number of threads or bands: the map is the
// unique set of candidates connected to a strong edge, in whichever order it is grown.
#pragma once

#include <chrono>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

namespace svms {

class WorkerPool;

// Buffers of EdgeMapInBands, reused between calls (they grow to the largest image seen).
struct EdgeBandsScratch {
  struct Band {
    int y0 = 0, y1 = 0;                         // rows [y0, y1)
    std::vector<uint8_t> table_rows;            // 3 rows of the table's image
    std::vector<int16_t> border_dx, border_dy;  // derivatives of rows y0 - 1 and y1
    std::vector<int32_t> magnitude;             // 3 rows of cols + 2, zero pads
    std::vector<int32_t> stack;                 // the band's hysteresis stack
    bool interrupted = false;
  };
  std::vector<Band> bands;
  std::vector<uint8_t> map;    // (rows + 2) x (cols + 2), canny.h's values
  std::vector<int32_t> stack;  // the hysteresis across bands
};

// The rows [0, rows) split into the bands EdgeMapInBands uses for `threads` threads: about
// four bands per thread of at least 64 rows each.
int EdgeBandCount(int rows, int threads);

// Edges of `gray8` (CV_8UC1, at least 3 x 3) into *edges (CV_8UC1, 255 on edges), with its
// Sobel derivatives into *gx, *gy (CV_16SC1), all three (re)created at gray8's size:
// cv::spatialGradient(T(gray8), gx, gy, 3) and CannyFromDerivatives(gx, gy, low, high,
// l2_gradient) where T applies `table` (256 entries; nullptr: the identity). The work runs on
// `pool`'s threads. `deadline` is read at the start of each band, every 32 rows of it and
// every 4,096 pixels of each hysteresis; once it has passed the result is false and the
// outputs are incomplete. No heap allocation once the scratch has served an image of this size.
bool EdgeMapInBands(
    const cv::Mat& gray8, const uint8_t* table, double low, double high, bool l2_gradient,
    WorkerPool* pool, EdgeBandsScratch* scratch, cv::Mat* gx, cv::Mat* gy, cv::Mat* edges,
    std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max());

}  // namespace svms

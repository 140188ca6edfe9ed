// Canny hysteresis edges from precomputed Sobel derivatives, without a heap allocation per frame.
//
// Why this exists: cv::Canny allocates on every call (parallel_for_, cv::AutoBuffer magnitude
// rows, the edge map, and std::deque stacks that grow by 64 pointers: on a 1024 x 1024 frame
// some 30 heap allocations when it is nearly blank, about 110 on a typical detector frame,
// thousands when edges are dense), while the C API promises that detection allocates nothing
// per frame once warmed up. CannyFromDerivatives keeps every buffer in a caller-owned CannyScratch
// that grows to the largest image seen and is then reused.
//
// It reproduces OpenCV 4.6's cv::Canny(dx, dy, edges, threshold1, threshold2, L2gradient)
// (modules/imgproc/src/canny.cpp, the overload on CV_16SC1 derivatives) and returns the very
// same edge map, pixel for pixel:
//  - thresholds: swapped when low > high; with L2 each is clamped to at most 32767, squared
//    when positive and compared with dx^2 + dy^2 (an int, wrapping like OpenCV's); with L1
//    the magnitude is |dx| + |dy|; both thresholds are rounded down with cvFloor;
//  - non-maximum suppression with OpenCV's integer direction test: tan(22.5 deg) as
//    13573 / 2^15; horizontal when |dy| 2^15 < 13573 |dx|, vertical when |dy| 2^15 exceeds
//    13573 |dx| + 2^16 |dx| (computed in 32 bits, wrapping as OpenCV's does for |dx| above
//    about 25,000), diagonal otherwise; a pixel survives when its magnitude exceeds `low`, is
//    greater than the neighbour "before" it and at least the one "after" it (greater than
//    both on a diagonal);
//  - borders: magnitudes outside the image count as 0, and nothing outside the image is an
//    edge;
//  - hysteresis: every surviving pixel above `high` is an edge, and so is every surviving
//    pixel 8-connected to an edge through surviving pixels. The order in which the stack is
//    worked off differs from OpenCV's (which splits the image into slices per thread) but the
//    resulting map is the same, being the connected closure.
// One known difference, only for values no 8-bit image's Sobel derivative reaches: with L1,
// OpenCV's SIMD body takes |-32768| as -32768 (16-bit abs) while its scalar tail takes 32768,
// so its result for dx or dy == -32768 depends on the column; here it is always 32768.
//
// Single-threaded; edge_bands.h computes the same map in bands of rows on several threads
// with the row kernels below.
#pragma once

#include <chrono>
#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

namespace svms {

// Buffers reused between calls. They grow to the largest image seen and never shrink, so
// calls on images no larger than an earlier one allocate nothing. Not shared between threads.
struct CannyScratch {
  std::vector<int32_t> magnitude;  // 3 rows (ring buffer) of cols + 2 with zero pads
  std::vector<uint8_t> map;        // (rows + 2) x (cols + 2): 0 candidate, 1 not edge, 2 edge
  std::vector<int32_t> stack;      // hysteresis stack of map offsets, rows x cols at most
};

// Edges (CV_8UC1, 255 on edge pixels, 0 elsewhere; same as cv::Canny) from CV_16SC1 Sobel
// derivatives `dx`, `dy` of equal size (continuous or not, e.g. ROIs). `low`, `high` and
// `l2_gradient` mean what cv::Canny's threshold1, threshold2 and L2gradient do (see above).
// `scratch` and `edges` must not be null. `edges` is (re)created with dx's size: its buffer is
// reused when it already has that size and type CV_8UC1. Throws cv::Exception, as cv::Canny does,
// on other types, sizes that differ, or a matrix that is not 2-D (an empty cv::Mat); a 0 x N input
// gives an empty map. Allocates nothing when `scratch` has already served an image with at least as
// many rows and at least as many columns, and `edges` already has dx's size and type CV_8UC1. The
// scratch then holds about 5 bytes per pixel (map and stack) plus 3 rows of magnitudes.
// `deadline`: read every 64 rows and every 4,096 pixels of the hysteresis; once it has passed
// the result is false and `edges` incomplete. True when the map is whole.
bool CannyFromDerivatives(
    const cv::Mat& dx, const cv::Mat& dy, double low, double high, bool l2_gradient,
    CannyScratch* scratch, cv::Mat* edges,
    std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max());

// The pieces of CannyFromDerivatives, row by row, for a caller that computes the map in bands
// of rows (edge_bands.h): the very code the whole-image function runs, so the map is the same.
// The map has a pad of one pixel all round: (rows + 2) x (cols + 2), row y of the image at map
// row y + 1, column x at x + 1.
namespace canny_rows {
constexpr uint8_t kCandidate = 0, kNotEdge = 1, kEdge = 2;
// The integer thresholds cv::Canny compares with (see above).
void Thresholds(double low, double high, bool l2_gradient, int32_t* ilow, int32_t* ihigh);
// out[j] = the gradient magnitude of (dx[j], dy[j]), j in [0, n).
void Magnitude(const int16_t* dx, const int16_t* dy, bool l2_gradient, int32_t* out, int n);
// Non-maximum suppression and double threshold of one row into out[0, n): `above`, `here`,
// `below` the magnitudes of the rows before, at and after it, readable at [-1, n] (zero
// outside the image).
void SuppressRow(const int32_t* above, const int32_t* here, const int32_t* below, const int16_t* dx,
                 const int16_t* dy, int32_t low, int32_t high, uint8_t* out, int n);
// Appends the offsets from `base` of row[0, n)'s kEdge pixels to stack[*top...].
void PushEdges(const uint8_t* row, int n, const uint8_t* base, int32_t* stack, size_t* top);
// Hysteresis from the kEdge pixels at stack[0, top) (map offsets): kCandidate pixels
// 8-connected to them become kEdge, looking only at offsets in [begin, end) (a band's rows;
// the whole map for [0, map size)). `stack` needs room for every kCandidate pixel in range.
// False when `deadline` (read every 4,096 pixels) passed first.
bool Hysteresis(
    uint8_t* map, int cols, int32_t* stack, size_t top, int32_t begin, int32_t end,
    std::chrono::steady_clock::time_point deadline = std::chrono::steady_clock::time_point::max());
// edges[j] = 255 where map[j] is kEdge, else 0.
void FinalRow(const uint8_t* map, uint8_t* edges, int n);
}  // namespace canny_rows

}  // namespace svms

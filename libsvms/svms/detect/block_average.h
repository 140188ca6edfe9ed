// The image of detector steps 1-4 at DetectorOptions::decimate > 1: each f x f block of pixels
// averaged into one.
#pragma once

#include <opencv2/core.hpp>

namespace svms {

// The mean of each f x f block of an 8-bit single-channel image (f in [2, 4]), the last
// cols % f columns and rows % f rows left out, so that coarse pixel q is exactly full pixels
// f q .. f q + f - 1 and its centre full pixel f q + (f - 1) / 2; *out is (rows / f) x
// (cols / f), CV_8UC1. The means are rounded exactly as OpenCV 4.6's area resize rounds the same
// blocks (cv::resize with INTER_AREA on the part f divides): halves up at f = 2, to even at
// f = 4 (none at f = 3); block_average_test.cc checks every block sum against it.
//
// Why not cv::resize itself: it allocates its tables on every call, and the C API promises frames
// without heap allocation (capi_alloc_test); it may also hand the rows to OpenCV's thread pool,
// beside the detector's own threads. *out is reused when it has the size already.
// False (and *out untouched) for another image type or f.
bool BlockAverage(const cv::Mat& in, int f, cv::Mat* out);

}  // namespace svms

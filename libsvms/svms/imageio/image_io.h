// Reading camera images from files, with the checks a batch over files from many hands needs:
// the size is read from the file's header and refused beyond a pixel limit before anything is
// decoded (so a 20000 x 20000 or a forged header cannot make us allocate gigabytes), truncated
// PNG and JPEG files are recognised before the decoder sees them (libjpeg would otherwise fill
// the missing part with grey and say nothing), and only 8- and 16-bit grey results come out.
// See docs/reliability.md.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

#include "svms/base/file_io.h"
#include "svms/base/status.h"

namespace svms {

// The default limit on width x height (pixels) of an image we decode or render: 100 megapixels,
// i.e. 100 MB as 8-bit grey, 200 MB as 16-bit. `svms detect --max-megapixels` changes it.
constexpr int64_t kDefaultMaxImagePixels = 100'000'000;

// What a file's first bytes say about it.
struct ImageHeader {
  std::string format;  // "PNG", "JPEG", "PNM", "BMP" or "TIFF"
  int64_t width = 0;   // pixels, as the header states them
  int64_t height = 0;
  // The response the file declares (photometric.h), read when the whole file is given: a PNG's
  // sRGB chunk ("srgb") or gAMA chunk ("linear" for gAMA 1.0, else "gamma:G" with G = 1 /
  // gAMA), a JPEG ("srgb": JFIF is sRGB); "" when the file says nothing.
  std::string declared_response;
};

// Reads the format and the size from the bytes of an image file (the whole file, or at least its
// header). Returns "" on success, or why the bytes are not a readable image of a supported
// format (PNG, JPEG, PNM P1-P6, BMP, classic TIFF), without a file name. When `data` is the
// whole file (`complete`), also checks that it is not truncated: PNG up to its IEND chunk, JPEG
// up to its end-of-image marker after the scan, binary PNM and uncompressed BMP up to the last
// pixel.
std::string ReadImageHeader(const unsigned char* data, size_t size, bool complete,
                            ImageHeader* out);

// Loads an image file as one grey channel, 8- or 16-bit (CV_8UC1 or CV_16UC1; colour is turned
// to grey with OpenCV's weights, 16-bit stays 16-bit). Refuses, with a one-line message that
// starts with the path and says what was expected: a missing file, a directory, an empty file,
// an unsupported or corrupt format, a truncated file, an image of zero size or of more than
// `max_pixels` pixels (checked from the header, before decoding), and other pixel depths
// (float or 32-bit). Reads the whole file into memory first (at most 8 * max_pixels + 16 MB).
Status LoadImage(const std::string& path, int64_t max_pixels, cv::Mat* out);

// Loads an image file as it is stored: 1 channel (grey or a Bayer mosaic) or 3 (BGR; an alpha
// channel is dropped, a palette expanded), 8- or 16-bit, with the same checks as LoadImage.
// *header (optional) gets the format, size and declared response.
Status LoadStoredImage(const std::string& path, int64_t max_pixels, cv::Mat* out,
                       ImageHeader* header = nullptr);

// How WriteImage encodes: the JPEG quality (1-100), and for PNG the response to declare in a
// gAMA chunk (PNG 1.2, section 11.3.3.2; "" writes none): "linear" (gAMA 1.0, what svms render
// writes on its linear images), "srgb" (an sRGB chunk), "gamma:G".
struct ImageEncoding {
  int jpeg_quality = 95;
  std::string png_response;
};

// Writes `image` in the format its extension names (OpenCV's encoders: .png, .jpg, .pgm, .tif,
// .exr, ...) atomically (file_io.h): encoded in memory first, then written to a temporary and
// renamed into place, so a failure leaves an earlier file as it was. Errors name the path.
Status WriteImage(const std::string& path, const cv::Mat& image,
                  const ImageEncoding& encoding = {});
// The same into a group of files that the caller commits (AtomicFileSet).
Status AddImage(const std::string& path, const cv::Mat& image, AtomicFileSet* files,
                const ImageEncoding& encoding = {});
// The bytes WriteImage would write.
Status EncodeImage(const std::string& path, const cv::Mat& image, const ImageEncoding& encoding,
                   std::string* bytes);

}  // namespace svms

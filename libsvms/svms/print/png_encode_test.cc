#include "svms/print/png_encode.h"

#include <gtest/gtest.h>
#include <zlib.h>

#include <cstring>
#include <opencv2/imgcodecs.hpp>
#include <vector>

namespace svms {
namespace {

// The chunks of a PNG byte stream: type and data, each CRC checked (zlib's crc32 over the type
// and the data, as the PNG specification defines it).
struct Chunk {
  std::string type, data;
};

uint32_t BigEndian(const std::string& s, size_t at) {
  const auto* b = reinterpret_cast<const unsigned char*>(s.data() + at);
  return (uint32_t{b[0]} << 24) | (uint32_t{b[1]} << 16) | (uint32_t{b[2]} << 8) | b[3];
}

std::vector<Chunk> Chunks(const std::string& png) {
  std::vector<Chunk> chunks;
  EXPECT_EQ(png.compare(0, 8, "\x89PNG\r\n\x1a\n"), 0) << "PNG signature";
  for (size_t at = 8; at + 12 <= png.size();) {
    const uint32_t length = BigEndian(png, at);
    Chunk c{png.substr(at + 4, 4), png.substr(at + 8, length)};
    const uint32_t crc = crc32(crc32(0, nullptr, 0),
                               reinterpret_cast<const Bytef*>(png.data() + at + 4), length + 4);
    EXPECT_EQ(crc, BigEndian(png, at + 8 + length)) << "CRC of " << c.type;
    chunks.push_back(c);
    at += 12 + length;
  }
  return chunks;
}

// Known answer: the chunk pHYs holds the pixels per metre for x and y and unit 1 (metre),
// before the image data; the pixels decode (OpenCV) to what was given.
TEST(PngEncode, WritesPhysAndThePixels) {
  const int w = 7, h = 5, stride = 32;
  std::vector<unsigned char> xrgb(stride * h, 0);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const uint32_t p = (uint32_t(10 * x) << 16) | (uint32_t(20 * y) << 8) | uint32_t(x + y);
      std::memcpy(&xrgb[y * stride + 4 * x], &p, 4);
    }
  }
  std::string png;
  ASSERT_TRUE(EncodePngWithResolution("t.png", xrgb.data(), w, h, stride, 11811, &png).ok());
  const std::vector<Chunk> chunks = Chunks(png);
  int phys = -1, idat = -1;
  for (size_t i = 0; i < chunks.size(); ++i) {
    if (chunks[i].type == "pHYs") phys = static_cast<int>(i);
    if (chunks[i].type == "IDAT" && idat < 0) idat = static_cast<int>(i);
  }
  ASSERT_GE(phys, 0) << "no pHYs chunk";
  ASSERT_LT(phys, idat) << "pHYs must come before IDAT";
  const std::string& d = chunks[phys].data;
  ASSERT_EQ(d.size(), 9u);
  EXPECT_EQ(BigEndian(d, 0), 11811u);
  EXPECT_EQ(BigEndian(d, 4), 11811u);
  EXPECT_EQ(d[8], 1) << "unit: metre";

  const cv::Mat img = cv::imdecode(std::vector<unsigned char>(png.begin(), png.end()),
                                   cv::IMREAD_UNCHANGED);
  ASSERT_EQ(img.type(), CV_8UC3);
  ASSERT_EQ(img.cols, w);
  ASSERT_EQ(img.rows, h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const cv::Vec3b bgr = img.at<cv::Vec3b>(y, x);
      EXPECT_EQ(bgr[2], 10 * x);
      EXPECT_EQ(bgr[1], 20 * y);
      EXPECT_EQ(bgr[0], x + y);
    }
  }
}

TEST(PngEncode, RefusesEmptyImage) {
  std::string png;
  const Status s = EncodePngWithResolution("e.png", nullptr, 0, 3, 0, 100, &png);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.message().rfind("e.png: ", 0), 0u) << s.message();
}

}  // namespace
}  // namespace svms

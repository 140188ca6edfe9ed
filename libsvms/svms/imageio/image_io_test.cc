#include "svms/imageio/image_io.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <random>

#include "svms_testing/scratch_dir.h"

namespace svms {
namespace {

namespace fs = std::filesystem;

// A scratch directory removed when the test program ends.
const fs::path& Dir() {
  static const svms_testing::ScratchDir dir("svms_image_io_test");
  return dir.path();
}

std::string Write(const std::string& name, const std::vector<unsigned char>& bytes) {
  const std::string path = (Dir() / name).string();
  std::ofstream(path, std::ios::binary)
      .write(reinterpret_cast<const char*>(bytes.data()),
             static_cast<std::streamsize>(bytes.size()));
  return path;
}

std::vector<unsigned char> Encode(const std::string& ext, const cv::Mat& img) {
  std::vector<unsigned char> out;
  EXPECT_TRUE(cv::imencode(ext, img, out)) << ext;
  return out;
}

cv::Mat Pattern(int w, int h, int type) {
  cv::Mat m(h, w, type);
  cv::randu(m, 0, type == CV_16UC1 ? 65535 : 255);
  return m;
}

void ExpectError(const Status& s, const std::string& path,
                 std::initializer_list<std::string> parts) {
  ASSERT_FALSE(s.ok()) << path;
  EXPECT_EQ(s.message().rfind(path + ": ", 0), 0u) << s.message();
  EXPECT_EQ(s.message().find('\n'), std::string::npos) << s.message();
  for (const std::string& p : parts)
    EXPECT_NE(s.message().find(p), std::string::npos) << s.message();
}

TEST(ImageIo, ReadsGreySixteenBitAndColour) {
  const cv::Mat grey = Pattern(40, 30, CV_8UC1), deep = Pattern(40, 30, CV_16UC1);
  cv::Mat colour(30, 40, CV_8UC3, cv::Scalar(10, 200, 30));
  struct Case {
    std::string name;
    cv::Mat img;
    int type;
  };
  for (const Case& c :
       {Case{"g.png", grey, CV_8UC1}, Case{"d.png", deep, CV_16UC1}, Case{"c.png", colour, CV_8UC1},
        Case{"g.pgm", grey, CV_8UC1}, Case{"d.pgm", deep, CV_16UC1}, Case{"c.ppm", colour, CV_8UC1},
        Case{"g.bmp", grey, CV_8UC1}, Case{"c.bmp", colour, CV_8UC1}, Case{"d.tif", deep, CV_16UC1},
        Case{"g.jpg", grey, CV_8UC1}}) {
    SCOPED_TRACE(c.name);
    const std::string path = Write(c.name, Encode(fs::path(c.name).extension().string(), c.img));
    cv::Mat got;
    const Status s = LoadImage(path, kDefaultMaxImagePixels, &got);
    ASSERT_TRUE(s.ok()) << s.message();
    EXPECT_EQ(got.type(), c.type);
    EXPECT_EQ(got.cols, 40);
    EXPECT_EQ(got.rows, 30);
    if (c.img.type() == c.type && c.name.find(".jpg") == std::string::npos) {
      EXPECT_EQ(cv::norm(got, c.img, cv::NORM_INF), 0);
    }
  }
  // A 1x1 image is an image (callers decide what is too small to hold a marker).
  cv::Mat one;
  ASSERT_TRUE(LoadImage(Write("one.png", Encode(".png", Pattern(1, 1, CV_8UC1))), 100, &one).ok());
  EXPECT_EQ(one.total(), 1u);
}

TEST(ImageIo, RefusesWhatIsNotAnImage) {
  cv::Mat m;
  const std::string missing = (Dir() / "missing.png").string();
  ExpectError(LoadImage(missing, 1000, &m), missing, {"no such file"});
  ExpectError(LoadImage(Dir().string(), 1000, &m), Dir().string(), {"is a directory"});
  const std::string empty = Write("empty.png", {});
  ExpectError(LoadImage(empty, 1000, &m), empty, {"empty file (0 bytes)"});
  const std::string text = Write("text.png", {'h', 'e', 'l', 'l', 'o'});
  ExpectError(LoadImage(text, 1000, &m), text, {"not an image of a supported format", "PNG"});
  const std::string pfm = Write("x.pfm", {'P', 'f', '\n', '1', ' ', '1', '\n'});
  ExpectError(LoadImage(pfm, 1000, &m), pfm, {"not an image of a supported format"});
  EXPECT_TRUE(m.empty());
}

TEST(ImageIo, RefusesTruncatedFilesBeforeDecoding) {
  const cv::Mat img = Pattern(64, 48, CV_8UC1);
  for (const std::string ext : {".png", ".jpg", ".pgm", ".bmp"}) {
    SCOPED_TRACE(ext);
    std::vector<unsigned char> bytes = Encode(ext, img);
    for (const size_t keep : {bytes.size() / 2, bytes.size() - 3, size_t{40}, size_t{9}}) {
      const std::string path =
          Write("cut" + std::to_string(keep) + ext, {bytes.begin(), bytes.begin() + keep});
      cv::Mat m;
      ExpectError(LoadImage(path, 1000000, &m), path, {});
      EXPECT_TRUE(m.empty());
    }
  }
  std::vector<unsigned char> png = Encode(".png", img);
  png.resize(png.size() - 12);  // without its IEND chunk
  const std::string path = Write("no_iend.png", png);
  cv::Mat m;
  ExpectError(LoadImage(path, 1000000, &m), path, {"truncated PNG"});
  std::vector<unsigned char> jpg = Encode(".jpg", img);
  jpg.resize(jpg.size() - 2);  // without its end-of-image marker
  const std::string jpath = Write("no_eoi.jpg", jpg);
  ExpectError(LoadImage(jpath, 1000000, &m), jpath, {"truncated JPEG"});
}

TEST(ImageIo, RefusesHugeImagesFromTheHeader) {
  // A small PNG whose header claims 20000 x 20000 pixels (a decoder would allocate 400 MB).
  std::vector<unsigned char> png = Encode(".png", Pattern(8, 8, CV_8UC1));
  for (int i : {16, 20}) {
    png[i] = 0, png[i + 1] = 0, png[i + 2] = 20000 >> 8, png[i + 3] = 20000 & 255;
  }
  const std::string path = Write("huge.png", png);
  cv::Mat m;
  ExpectError(LoadImage(path, kDefaultMaxImagePixels, &m), path,
              {"20000x20000 pixels (400 megapixels) is over the limit of 100 megapixels"});
  // The same for a binary PGM header, and a zero size.
  const std::string pgm_text = "P5\n20000 20000\n255\n";
  const std::string pgm = Write("huge.pgm", {pgm_text.begin(), pgm_text.end()});
  ExpectError(LoadImage(pgm, kDefaultMaxImagePixels, &m), pgm, {"20000x20000 pixels"});
  const std::string zero_text = "P5\n0 7\n255\n";
  const std::string zero = Write("zero.pgm", {zero_text.begin(), zero_text.end()});
  ExpectError(LoadImage(zero, kDefaultMaxImagePixels, &m), zero,
              {"the PNM header says 0x7 pixels; expected a positive width and height"});
  // A real image just over a small limit.
  const std::string real = Write("real.png", Encode(".png", Pattern(40, 30, CV_8UC1)));
  ExpectError(LoadImage(real, 1199, &m), real, {"40x30 pixels", "over the limit"});
  EXPECT_TRUE(LoadImage(real, 1200, &m).ok());
}

TEST(ImageIo, RefusesFloatPixels) {
  cv::Mat f(20, 20, CV_32FC1, cv::Scalar(0.5));
  const std::string path = Write("float.tif", Encode(".tif", f));
  cv::Mat m;
  ExpectError(LoadImage(path, 1000, &m), path, {"expected 8- or 16-bit unsigned"});
}

TEST(ImageIo, HeaderReaderSurvivesEveryPrefixAndRandomBytes) {
  // Every prefix of every format: an answer, never a crash (the fuzzer goes further).
  const cv::Mat img = Pattern(33, 17, CV_8UC1);
  for (const std::string ext : {".png", ".jpg", ".pgm", ".bmp", ".tif"}) {
    const std::vector<unsigned char> bytes = Encode(ext, img);
    for (size_t n = 0; n <= bytes.size(); ++n) {
      ImageHeader h;
      const std::string e = ReadImageHeader(bytes.data(), n, true, &h);
      if (n == bytes.size()) {
        EXPECT_EQ(e, "") << ext;
        EXPECT_EQ(h.width, 33) << ext;
        EXPECT_EQ(h.height, 17) << ext;
      }
    }
  }
  std::mt19937 rng(5);
  std::vector<unsigned char> junk(256);
  for (int k = 0; k < 2000; ++k) {
    for (auto& b : junk) b = static_cast<unsigned char>(rng());
    const char* magic[] = {"\x89PNG\r\n\x1a\n", "\xFF\xD8\xFF", "P5", "BM", "II*", "MM"};
    const std::string m = magic[k % 6];
    std::copy(m.begin(), m.end(), junk.begin());
    ImageHeader h;
    ReadImageHeader(junk.data(), junk.size(), k % 2 == 0, &h);
  }
}

}  // namespace
}  // namespace svms

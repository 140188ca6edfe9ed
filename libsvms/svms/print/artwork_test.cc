#include "svms/print/artwork.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <regex>

#include "svms/codec/svms44.h"
#include "svms/detect/bit_sampler.h"
#include "svms/marker/model_io.h"
#include "svms_testing/scratch_dir.h"

namespace svms {
namespace {

namespace fs = std::filesystem;

// `name` in a scratch directory removed when the test program ends.
std::string TempBase(const std::string& name) {
  static const svms_testing::ScratchDir dir("svms_artwork_test");
  return dir.File(name);
}

// The artwork of `m` at `dpi`, written as `name`.png and read back in grey (empty on failure).
cv::Mat WrittenArtwork(const MarkerModel& m, const std::string& name, double dpi) {
  WrittenFiles files;
  ArtworkOptions o;
  o.dpi = dpi;
  if (!WriteMarkerArtwork(m, TempBase(name), o, &files).ok()) return cv::Mat();
  return cv::imread(TempBase(name) + ".png", cv::IMREAD_GRAYSCALE);
}

std::string Slurp(const std::string& path) {
  std::string s;
  EXPECT_TRUE(ReadTextFile(path, &s).ok()) << path;
  return s;
}

// Reads the PNG back through the codec, sampling where the model says the cells are.
void ExpectReadsBack(const std::string& png, const MarkerModel& m, double dpi) {
  const cv::Mat img = cv::imread(png, cv::IMREAD_GRAYSCALE);
  ASSERT_FALSE(img.empty()) << png;
  const Eigen::Matrix3d H = ArtworkPixelFromPlane(img.cols, img.rows, dpi);
  std::vector<MarkerModel> models{m};
  if (auto inner = m.InnerModel()) models.push_back(*inner);
  for (const MarkerModel& mm : models) {
    const BitReading r = SampleBits(img, H, mm);
    EXPECT_EQ(r.samples_outside, 0);
    EXPECT_EQ(r.word, Svms44::Codeword(mm.id)) << png << " ID " << mm.id;
    const CodeMatch match = Svms44::Decode(r.word, 0);
    EXPECT_TRUE(match.accepted());
    EXPECT_EQ(match.id, mm.id);
    EXPECT_GT(r.weakest(), 0.3) << "every cell clearly black or white";
    EXPECT_EQ(r.separated_refs, 44);
    EXPECT_LT(r.black, 40);
    EXPECT_GT(r.white, 215);
  }
}

TEST(Artwork, SingleMarkerIsExactScaleAndReadsBack) {
  const MarkerModel m = MarkerModel::Standard(17, 0.2, 0.05);
  const std::string base = TempBase("m17");
  WrittenFiles files;
  ASSERT_TRUE(WriteMarkerArtwork(m, base + ".svg", ArtworkOptions{}, &files).ok());
  ASSERT_EQ(files.size(), 4u);
  for (const auto& f : files) EXPECT_TRUE(fs::exists(f)) << f;

  // SVG: user units are millimetres; the black square is a 200.000 x 200.000 rectangle.
  const std::string svg = Slurp(base + ".svg");
  ASSERT_NE(svg.find("mm\" height="), std::string::npos);
  const std::regex rect(
      R"(d="M ([-0-9.]+) ([-0-9.]+) L ([-0-9.]+) ([-0-9.]+) L ([-0-9.]+) ([-0-9.]+) L ([-0-9.]+) ([-0-9.]+) Z)");
  int squares = 0;
  for (auto it = std::sregex_iterator(svg.begin(), svg.end(), rect); it != std::sregex_iterator();
       ++it) {
    double v[8];
    for (int i = 0; i < 8; ++i) v[i] = std::stod((*it)[i + 1]);
    const double w = std::abs(v[2] - v[0]) + std::abs(v[4] - v[2]);
    const double h = std::abs(v[5] - v[3]) + std::abs(v[7] - v[5]);
    if (std::abs(w - 200.0) < 1e-3 && std::abs(h - 200.0) < 1e-3) ++squares;
  }
  EXPECT_EQ(squares, 1) << "exactly one 200.000 mm square (the black square)";

  // PDF: the page is the SVG's page, in points.
  const std::string pdf = Slurp(base + ".pdf");
  const std::regex viewbox(R"(viewBox="0 0 ([0-9.]+) ([0-9.]+)\")");
  std::smatch vb;
  ASSERT_TRUE(std::regex_search(svg, vb, viewbox));
  const std::regex mediabox(R"(/MediaBox \[ ?0 0 ([0-9.]+) ([0-9.]+) ?\])");
  std::smatch mb;
  ASSERT_TRUE(std::regex_search(pdf, mb, mediabox)) << "no MediaBox";
  EXPECT_NEAR(std::stod(mb[1]), std::stod(vb[1]) * 72 / 25.4, 0.01);
  EXPECT_NEAR(std::stod(mb[2]), std::stod(vb[2]) * 72 / 25.4, 0.01);

  ExpectReadsBack(base + ".png", m, 300);
  ModelFile f;
  ASSERT_TRUE(ReadModelFile(base + ".json", &f).ok());
  EXPECT_EQ(MarkerModelToJson(f.markers[0]), MarkerModelToJson(m));
}

TEST(Artwork, DualAndConcaveMarkersReadBackAtLowResolution) {
  MarkerModel dual = MarkerModel::Standard(3, 0.432, 0.027);
  dual.AddInner(4, 0.108);
  WrittenFiles files;
  ArtworkOptions o;
  o.dpi = 40;  // inner cells are 0.018 m = 28 px... at 40 dpi: 2.8 px
  ASSERT_TRUE(WriteMarkerArtwork(dual, TempBase("dual"), o, &files).ok());
  ExpectReadsBack(TempBase("dual") + ".png", dual, 40);
  const MarkerModel well = MarkerModel::Standard(32767, 0.05, -0.0125);
  o.dpi = 150;
  ASSERT_TRUE(WriteMarkerArtwork(well, TempBase("well"), o, &files).ok());
  ExpectReadsBack(TempBase("well") + ".png", well, 150);
}

TEST(Artwork, EveryRotationOfTheArtworkDecodesWithItsRotation) {
  const MarkerModel m = MarkerModel::Standard(1234, 0.05, 0.01);
  cv::Mat img = WrittenArtwork(m, "rot", 100);
  ASSERT_FALSE(img.empty());
  for (int r = 0; r < 4; ++r) {
    // Reading from marker corner r: rotate the image so that corner r is at the top-left.
    const BitReading reading = SampleBits(img, ArtworkPixelFromPlane(img.cols, img.rows, 100), m);
    const CodeMatch match = Svms44::Decode(reading.word, 0);
    ASSERT_TRUE(match.accepted());
    EXPECT_EQ(match.id, 1234);
    EXPECT_EQ(match.rotation, r);
    cv::rotate(img, img, cv::ROTATE_90_COUNTERCLOCKWISE);
  }
}

// Step 7b retries a small quad only if its cells' stripe and square references stand apart
// (BitReading::separated_refs): all 44 on the print, a coin toss each on noise.
TEST(Artwork, StripeAndSquareReferencesStandApartOnThePrintNotOnNoise) {
  const MarkerModel m = MarkerModel::Standard(4321, 0.05, 0.01);
  const cv::Mat img = WrittenArtwork(m, "sep", 100);
  ASSERT_FALSE(img.empty());
  const Eigen::Matrix3d H = ArtworkPixelFromPlane(img.cols, img.rows, 100);
  EXPECT_EQ(SampleBits(img, H, m).separated_refs, 44);
  cv::Mat noise(img.size(), CV_8U);
  cv::RNG rng(7);
  int most = 0;
  for (int trial = 0; trial < 20; ++trial) {
    rng.fill(noise, cv::RNG::UNIFORM, 0, 256);
    most = std::max(most, SampleBits(noise, H, m).separated_refs);
  }
  EXPECT_LT(most, 40) << "DetectorOptions::small_quad_min_separated_refs would let noise through";
}

TEST(Artwork, SheetPaginatesAndRefusesWhatDoesNotFit) {
  std::vector<MarkerModel> ms;
  for (int id = 0; id < 12; ++id) ms.push_back(MarkerModel::Standard(id, 0.04, 0.01));
  SheetOptions o;
  o.dpi = 50;
  WrittenFiles files;
  ASSERT_TRUE(WriteSheet(ms, TempBase("sheet"), o, &files).ok());
  // 0.04 m markers need ~117 mm boxes: 1 across on A4 width... count pages from the files.
  int pngs = 0;
  for (const auto& f : files) pngs += f.size() > 4 && f.substr(f.size() - 4) == ".png";
  EXPECT_GT(pngs, 1);
  const std::string pdf = Slurp(TempBase("sheet") + ".pdf");
  EXPECT_NE(pdf.find("/Count " + std::to_string(pngs)), std::string::npos);
  ModelFile f;
  ASSERT_TRUE(ReadModelFile(TempBase("sheet") + ".json", &f).ok());
  EXPECT_EQ(f.markers.size(), 12u);

  files.clear();
  const Status s = WriteSheet({MarkerModel::Standard(1, 0.5, 0.1)}, TempBase("big"), o, &files);
  ASSERT_FALSE(s.ok());
  EXPECT_NE(s.message().find("more than the printable"), std::string::npos) << s.message();
  EXPECT_TRUE(files.empty());
}

TEST(PageSpec, ParsesNamesAndSizes) {
  PageSpec p;
  ASSERT_TRUE(PageSpec::Parse("Letter", &p).ok());
  EXPECT_DOUBLE_EQ(p.width_mm, 215.9);
  ASSERT_TRUE(PageSpec::Parse("600x400", &p).ok());
  EXPECT_DOUBLE_EQ(p.height_mm, 400);
  EXPECT_FALSE(PageSpec::Parse("B5", &p).ok());
  EXPECT_FALSE(PageSpec::Parse("600x", &p).ok());
  EXPECT_FALSE(PageSpec::Parse("10x10", &p).ok());
}

// The PNG declares its resolution (pHYs, pixels per metre) and is drawn at it: printed at that
// resolution the page is its physical size (to the half pixel its edges are rounded to) and the
// marker reads back where ArtworkPixelFromPlane puts it at that same resolution.
TEST(Artwork, PngCarriesItsResolution) {
  for (const double dpi : {254.0, 300.0, 72.0}) {
    const MarkerModel m = MarkerModel::Standard(21, 0.05, 0.01);
    const std::string base = TempBase("phys" + std::to_string(static_cast<int>(dpi)));
    WrittenFiles files;
    ArtworkOptions o;
    o.dpi = dpi;
    ASSERT_TRUE(WriteMarkerArtwork(m, base, o, &files).ok());
    const std::string png = Slurp(base + ".png");
    // The pHYs chunk, found by its type: length 9, then x and y pixels per metre, unit 1.
    const size_t at = png.find("pHYs");
    ASSERT_NE(at, std::string::npos) << "no pHYs chunk at " << dpi << " dpi";
    ASSERT_LT(at, png.find("IDAT"));
    auto u32 = [&](size_t i) {
      const auto* b = reinterpret_cast<const unsigned char*>(png.data() + i);
      return (uint32_t{b[0]} << 24) | (uint32_t{b[1]} << 16) | (uint32_t{b[2]} << 8) | b[3];
    };
    EXPECT_EQ(u32(at - 4), 9u);
    const uint32_t ppm = u32(at + 4);
    EXPECT_EQ(ppm, u32(at + 8));
    EXPECT_EQ(png[at + 12], 1) << "unit: metre";
    EXPECT_EQ(ppm, ArtworkPixelsPerMetre(dpi));
    EXPECT_NEAR(ppm, dpi / 0.0254, 0.5);
    if (dpi == 254.0) {
      EXPECT_EQ(ppm, 10000u);
    }
    // The page's physical size, from the SVG (millimetres), times the resolution is the
    // image's size in pixels.
    const std::string svg = Slurp(base + ".svg");
    const std::regex size_mm(R"(width="([0-9.]+)mm\" height="([0-9.]+)mm\")");
    std::smatch mm;
    ASSERT_TRUE(std::regex_search(svg, mm, size_mm)) << "no page size in the SVG";
    const cv::Mat img = cv::imread(base + ".png", cv::IMREAD_GRAYSCALE);
    ASSERT_FALSE(img.empty());
    EXPECT_NEAR(ppm * std::stod(mm[1]) / 1000, img.cols, 0.5);
    EXPECT_NEAR(ppm * std::stod(mm[2]) / 1000, img.rows, 0.5);
    if (dpi >= 254) ExpectReadsBack(base + ".png", m, dpi);
  }
}

}  // namespace
}  // namespace svms

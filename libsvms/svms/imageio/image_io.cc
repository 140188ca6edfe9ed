#include "svms/imageio/image_io.h"

#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "svms/base/file_io.h"
#include "svms/camera/photometric.h"

namespace svms {
namespace {

namespace fs = std::filesystem;

constexpr const char* kSupported = "PNG, JPEG, TIFF, BMP or PGM/PPM";

uint32_t Be32(const unsigned char* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3];
}
uint32_t Be16(const unsigned char* p) { return (uint32_t{p[0]} << 8) | p[1]; }
uint32_t Le32(const unsigned char* p) {
  return (uint32_t{p[3]} << 24) | (uint32_t{p[2]} << 16) | (uint32_t{p[1]} << 8) | p[0];
}
uint32_t Le16(const unsigned char* p) { return (uint32_t{p[1]} << 8) | p[0]; }

std::string Png(const unsigned char* d, size_t n, bool complete, ImageHeader* out) {
  // Signature (8), then the IHDR chunk: length (4), "IHDR", width (4), height (4), ...
  if (n < 8 + 8 + 13 + 4) return "truncated PNG header";
  if (std::memcmp(d + 12, "IHDR", 4) != 0) return "corrupt PNG: the first chunk is not IHDR";
  out->width = Be32(d + 16);
  out->height = Be32(d + 20);
  if (!complete) return "";
  // Walk the chunks (length, type, data, CRC) to IEND; the sRGB and gAMA chunks say how the
  // values encode light (sRGB wins over gAMA, as PNG 1.2 asks of decoders).
  size_t at = 8;
  bool srgb = false;
  double gama = 0;
  while (true) {
    if (n - at < 12) return "truncated PNG: the file ends before its IEND chunk";
    const uint32_t len = Be32(d + at);
    if (len > 0x7fffffffu) return "corrupt PNG: a chunk length over 2^31";
    if (std::memcmp(d + at + 4, "IEND", 4) == 0) break;
    if (n - at - 12 < len) return "truncated PNG: the file ends inside a chunk";
    if (std::memcmp(d + at + 4, "sRGB", 4) == 0) srgb = true;
    if (std::memcmp(d + at + 4, "gAMA", 4) == 0 && len == 4) gama = Be32(d + at + 8) / 100000.0;
    at += 12 + size_t{len};
  }
  if (srgb) {
    out->declared_response = "srgb";
  } else if (gama > 0) {
    const double g = 1 / gama;
    char buf[32];
    std::snprintf(buf, sizeof buf, "gamma:%.4g", g);
    out->declared_response = std::abs(g - 1) < 1e-3 ? "linear" : buf;
  }
  return "";
}

std::string Jpeg(const unsigned char* d, size_t n, bool complete, ImageHeader* out) {
  size_t at = 2;
  bool have_size = false;
  while (true) {
    if (at >= n) return "truncated JPEG: the file ends before the image data";
    if (d[at] != 0xFF) return "corrupt JPEG: expected a marker";
    while (at < n && d[at] == 0xFF) ++at;  // fill bytes
    if (at >= n) return "truncated JPEG: the file ends before the image data";
    const unsigned char m = d[at++];
    if (m == 0xD8 || m == 0x01 || (m >= 0xD0 && m <= 0xD7)) continue;  // no length
    if (m == 0xD9) return "corrupt JPEG: it ends before any image data";
    if (n - at < 2) return "truncated JPEG header";
    const size_t len = Be16(d + at);
    if (len < 2) return "corrupt JPEG: a segment length below 2";
    if (n - at < len) return "truncated JPEG header";
    const bool sof = m >= 0xC0 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC;
    if (sof) {
      if (len < 7) return "corrupt JPEG: a frame header too short";
      out->height = Be16(d + at + 3);
      out->width = Be16(d + at + 5);
      have_size = true;
    }
    if (m == 0xDA) {  // start of scan: the entropy-coded data follows
      if (!have_size) return "corrupt JPEG: image data before the frame header";
      if (!complete) return "";
      // Inside entropy-coded data 0xFF is always followed by 0x00 or a restart marker, so an
      // end-of-image marker (FF D9) after the first scan is the real end of the image.
      static const unsigned char kEoi[2] = {0xFF, 0xD9};
      const unsigned char* end = d + n;
      if (std::search(d + at + len, end, kEoi, kEoi + 2) == end)
        return "truncated JPEG: no end-of-image marker after the image data";
      return "";
    }
    at += len;
  }
}

// Skips blanks and '#' comments, then reads a decimal number of at most 9 digits.
bool PnmNumber(const unsigned char* d, size_t n, size_t* at, int64_t* v) {
  while (*at < n) {
    if (d[*at] == '#') {
      while (*at < n && d[*at] != '\n' && d[*at] != '\r') ++*at;
    } else if (std::strchr(" \t\r\n\v\f", d[*at]) != nullptr && d[*at] != 0) {
      ++*at;
    } else {
      break;
    }
  }
  int digits = 0;
  *v = 0;
  while (*at < n && d[*at] >= '0' && d[*at] <= '9') {
    if (++digits > 9) return false;
    *v = *v * 10 + (d[*at] - '0');
    ++*at;
  }
  return digits > 0;
}

std::string Pnm(const unsigned char* d, size_t n, bool complete, ImageHeader* out) {
  const char kind = static_cast<char>(d[1]);
  size_t at = 2;
  int64_t maxval = 1;
  if (!PnmNumber(d, n, &at, &out->width) || !PnmNumber(d, n, &at, &out->height))
    return "corrupt or truncated PNM header: expected a width and a height";
  if (kind != '1' && kind != '4') {
    if (!PnmNumber(d, n, &at, &maxval) || maxval < 1 || maxval > 65535)
      return "corrupt PNM header: expected a maximum value from 1 to 65535";
  }
  if (!complete || kind == '1' || kind == '2' || kind == '3') return "";  // ASCII: not checked
  // Sizes beyond 2^24 are refused by LoadImage's pixel limit; not checked here (overflow).
  if (out->width > (1 << 24) || out->height > (1 << 24)) return "";
  if (at >= n) return "truncated PNM: no pixel data";
  ++at;  // the single blank after the header
  const int64_t bytes = maxval > 255 ? 2 : 1;
  int64_t need = 0;
  if (kind == '4') need = (out->width + 7) / 8 * out->height;
  if (kind == '5') need = out->width * out->height * bytes;
  if (kind == '6') need = out->width * out->height * bytes * 3;
  if (static_cast<int64_t>(n - at) < need) return "truncated PNM: the pixel data is short";
  return "";
}

std::string Bmp(const unsigned char* d, size_t n, bool complete, ImageHeader* out) {
  if (n < 26) return "truncated BMP header";
  const uint32_t offset = Le32(d + 10), dib = Le32(d + 14);
  int64_t bpp = 0, compression = 0;
  if (dib == 12) {  // OS/2 core header
    out->width = Le16(d + 18);
    out->height = Le16(d + 20);
    bpp = Le16(d + 24);
  } else if (dib >= 40) {
    if (n < 34) return "truncated BMP header";
    out->width = static_cast<int32_t>(Le32(d + 18));
    out->height = static_cast<int32_t>(Le32(d + 22));
    if (out->height < 0) out->height = -out->height;  // top-down rows
    bpp = Le16(d + 28);
    compression = Le32(d + 30);
  } else {
    return "corrupt BMP header: unknown header size " + std::to_string(dib);
  }
  if (!complete || compression != 0 || out->width <= 0 || out->width > (1 << 24) ||
      out->height > (1 << 24))
    return "";
  const int64_t stride = (out->width * bpp + 31) / 32 * 4;
  if (offset > n || static_cast<int64_t>(n - offset) < stride * out->height)
    return "truncated BMP: the pixel data is short";
  return "";
}

std::string Tiff(const unsigned char* d, size_t n, ImageHeader* out) {
  const bool le = d[0] == 'I';
  auto u16 = [&](size_t at) { return le ? Le16(d + at) : Be16(d + at); };
  auto u32 = [&](size_t at) { return le ? Le32(d + at) : Be32(d + at); };
  if (u16(2) == 43) return "BigTIFF is not supported; expected " + std::string(kSupported);
  if (u16(2) != 42) return "corrupt TIFF header";
  const size_t ifd = u32(4);
  if (ifd > n || n - ifd < 2) return "truncated TIFF: the first directory is past the end";
  const size_t count = u16(ifd);
  if ((n - ifd - 2) / 12 < count) return "truncated TIFF: the first directory is cut short";
  for (size_t i = 0; i < count; ++i) {
    const size_t e = ifd + 2 + 12 * i;
    const uint32_t tag = u16(e), type = u16(e + 2);
    if (tag != 256 && tag != 257) continue;
    const int64_t v = type == 3 ? u16(e + 8) : type == 4 ? u32(e + 8) : -1;
    if (v < 0) return "corrupt TIFF: the image size is neither SHORT nor LONG";
    (tag == 256 ? out->width : out->height) = v;
  }
  if (out->width == 0 && out->height == 0) return "corrupt TIFF: no image size in its directory";
  return "";
}

std::string Megapixels(int64_t pixels) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.4g", pixels / 1e6);
  return buf;
}

}  // namespace

std::string ReadImageHeader(const unsigned char* d, size_t n, bool complete, ImageHeader* out) {
  *out = ImageHeader();
  static const unsigned char kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  if (n >= 8 && std::memcmp(d, kPng, 8) == 0) {
    out->format = "PNG";
    return Png(d, n, complete, out);
  }
  if (n >= 3 && d[0] == 0xFF && d[1] == 0xD8 && d[2] == 0xFF) {
    out->format = "JPEG";
    if (complete) out->declared_response = "srgb";
    return Jpeg(d, n, complete, out);
  }
  if (n >= 2 && d[0] == 'P' && d[1] >= '1' && d[1] <= '6') {
    out->format = "PNM";
    return Pnm(d, n, complete, out);
  }
  if (n >= 2 && d[0] == 'B' && d[1] == 'M') {
    out->format = "BMP";
    return Bmp(d, n, complete, out);
  }
  if (n >= 8 && (std::memcmp(d, "II", 2) == 0 || std::memcmp(d, "MM", 2) == 0)) {
    out->format = "TIFF";
    return Tiff(d, n, out);
  }
  return std::string("not an image of a supported format; expected ") + kSupported;
}

namespace {

Status Load(const std::string& path, int64_t max_pixels, int flags, cv::Mat* out,
            ImageHeader* header_out) {
  std::error_code ec;
  const fs::file_status st = fs::status(path, ec);
  if (!fs::exists(st)) return Status::Error(path + ": no such file; expected an image");
  if (fs::is_directory(st)) return Status::Error(path + ": is a directory; expected an image");
  const uintmax_t size = fs::file_size(path, ec);
  if (ec) return Status::Error(path + ": cannot read the file size; expected an image file");
  if (size == 0) return Status::Error(path + ": empty file (0 bytes); expected an image");
  const uintmax_t max_bytes =
      8 * static_cast<uintmax_t>(std::max<int64_t>(max_pixels, 0)) + (uintmax_t{16} << 20);
  if (size > max_bytes) {
    return Status::Error(path + ": " + std::to_string(size) +
                         " bytes, more than any image within " + "the limit of " +
                         Megapixels(max_pixels) + " megapixels");
  }
  std::vector<unsigned char> bytes(static_cast<size_t>(size));
  std::ifstream in(path, std::ios::binary);
  if (!in || !in.read(reinterpret_cast<char*>(bytes.data()), static_cast<std::streamsize>(size)))
    return Status::Error(path + ": cannot read the file");
  // The size first (a forged header is refused as too large before it is found truncated).
  ImageHeader h;
  if (std::string e = ReadImageHeader(bytes.data(), bytes.size(), false, &h); !e.empty())
    return Status::Error(path + ": " + e);
  const std::string dims = std::to_string(h.width) + "x" + std::to_string(h.height);
  if (h.width <= 0 || h.height <= 0)
    return Status::Error(path + ": the " + h.format + " header says " + dims +
                         " pixels; expected a positive width and height");
  if (h.width > max_pixels || h.height > max_pixels || h.width * h.height > max_pixels) {
    return Status::Error(path + ": " + dims + " pixels (" + Megapixels(h.width * h.height) +
                         " megapixels) is over the limit of " + Megapixels(max_pixels) +
                         " megapixels; expected a smaller image");
  }
  if (std::string e = ReadImageHeader(bytes.data(), bytes.size(), true, &h); !e.empty())
    return Status::Error(path + ": " + e);
  cv::Mat img;
  try {
    img = cv::imdecode(bytes, flags | cv::IMREAD_IGNORE_ORIENTATION);
  } catch (const cv::Exception& e) {
    // Out of memory is not a corrupt file: it goes to the caller (ItemFailure).
    if (e.code == cv::Error::StsNoMem) throw;
    img.release();
  }
  if (img.empty())
    return Status::Error(path + ": cannot decode the " + h.format + " data (corrupt file)");
  if (img.cols != h.width || img.rows != h.height)
    return Status::Error(path + ": decoded as " + std::to_string(img.cols) + "x" +
                         std::to_string(img.rows) + " but the header says " + dims);
  if (img.depth() != CV_8U && img.depth() != CV_16U)
    return Status::Error(path + ": " + std::string(cv::depthToString(img.depth())) +
                         " pixels; expected 8- or 16-bit unsigned");
  if (img.channels() == 4) cv::cvtColor(img, img, cv::COLOR_BGRA2BGR);
  if (img.channels() != 1 && img.channels() != 3)
    return Status::Error(path + ": " + std::to_string(img.channels()) +
                         " channels; expected grey or colour");
  *out = img;
  if (header_out) *header_out = h;
  return Status::Ok();
}

}  // namespace

Status LoadImage(const std::string& path, int64_t max_pixels, cv::Mat* out) {
  return Load(path, max_pixels, cv::IMREAD_ANYDEPTH | cv::IMREAD_GRAYSCALE, out, nullptr);
}

Status LoadStoredImage(const std::string& path, int64_t max_pixels, cv::Mat* out,
                       ImageHeader* header) {
  return Load(path, max_pixels, cv::IMREAD_ANYDEPTH | cv::IMREAD_ANYCOLOR, out, header);
}

namespace {

// A PNG chunk (length, type, data, CRC-32 of type and data; PNG 1.2 section 5.3).
std::string PngChunk(const char* type, const std::string& data) {
  std::string c;
  auto be32 = [&](uint32_t v) {
    for (int k = 3; k >= 0; --k) c.push_back(static_cast<char>((v >> (8 * k)) & 0xff));
  };
  be32(static_cast<uint32_t>(data.size()));
  const std::string body = std::string(type, 4) + data;
  c += body;
  be32(static_cast<uint32_t>(
      crc32(0, reinterpret_cast<const Bytef*>(body.data()), static_cast<uInt>(body.size()))));
  return c;
}

// `png` with a chunk declaring `response` after its IHDR (where PNG wants sRGB and gAMA: before
// PLTE and IDAT).
Status DeclareResponse(const std::string& path, const std::string& response, std::string* png) {
  std::string chunk;
  if (response == "srgb") {
    chunk = PngChunk("sRGB", std::string(1, '\0'));  // rendering intent: perceptual
  } else {
    double gamma = 1;
    if (response != "linear") {
      Response r;
      if (Status s = Response::Parse(response, &r); !s || r.kind() != Response::Kind::kGamma)
        return Status::Error(path + ": cannot declare the response \"" + response +
                             "\" in a PNG; expected linear, srgb or gamma:G");
      gamma = r.gamma();
    }
    const auto g = static_cast<uint32_t>(std::lround(100000 / gamma));
    std::string data;
    for (int k = 3; k >= 0; --k) data.push_back(static_cast<char>((g >> (8 * k)) & 0xff));
    chunk = PngChunk("gAMA", data);
  }
  const size_t after_ihdr = 8 + 8 + 13 + 4;
  if (png->size() < after_ihdr) return Status::Error(path + ": the PNG encoder wrote no IHDR");
  png->insert(after_ihdr, chunk);
  return Status::Ok();
}

}  // namespace

Status EncodeImage(const std::string& path, const cv::Mat& image, const ImageEncoding& encoding,
                   std::string* bytes) {
  std::string ext = fs::path(path).extension().string();
  for (char& c : ext) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (ext.empty())
    return Status::Error(path +
                         ": cannot write an image without an extension; expected .png, "
                         ".jpg, .pgm, .tif or .exr");
  try {
    if (ext == ".exr") {
      // OpenCV 4.6's OpenEXR encoder writes only to files: a temporary with the same extension,
      // read back (the atomic write stays the one way files are replaced).
      const fs::path tmp = fs::path(path).parent_path() /
                           ("." + fs::path(path).filename().string() + ".svms-exr" + ext);
      const bool ok = cv::imwrite(tmp.string(), image);
      const Status read =
          ok ? ReadFileBytes(tmp.string(), size_t{1} << 40, bytes) : Status::Error("");
      std::error_code ec;
      fs::remove(tmp, ec);
      if (!ok || !read) return Status::Error(path + ": cannot write (OpenEXR encoder failed)");
      return Status::Ok();
    }
    std::vector<int> params;
    if (ext == ".jpg" || ext == ".jpeg") {
      if (encoding.jpeg_quality < 1 || encoding.jpeg_quality > 100)
        return Status::Error(path + ": JPEG quality " + std::to_string(encoding.jpeg_quality) +
                             "; expected 1 to 100");
      params = {cv::IMWRITE_JPEG_QUALITY, encoding.jpeg_quality};
    }
    std::vector<unsigned char> buf;
    if (!cv::imencode(ext, image, buf, params))
      return Status::Error(path + ": cannot encode the image as " + ext);
    bytes->assign(reinterpret_cast<const char*>(buf.data()), buf.size());
  } catch (const cv::Exception& e) {
    return Status::Error(path + ": cannot encode the image as " + ext + ": " + e.err);
  }
  if (ext == ".png" && !encoding.png_response.empty())
    return DeclareResponse(path, encoding.png_response, bytes);
  return Status::Ok();
}

Status WriteImage(const std::string& path, const cv::Mat& image, const ImageEncoding& encoding) {
  std::string bytes;
  if (Status s = EncodeImage(path, image, encoding, &bytes); !s) return s;
  return WriteFileAtomically(path, bytes);
}

Status AddImage(const std::string& path, const cv::Mat& image, AtomicFileSet* files,
                const ImageEncoding& encoding) {
  std::string bytes;
  if (Status s = EncodeImage(path, image, encoding, &bytes); !s) return s;
  return files->Add(path, bytes);
}

}  // namespace svms

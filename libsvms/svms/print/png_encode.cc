#include "svms/print/png_encode.h"

#include <png.h>

#include <cstring>
#include <new>
#include <vector>

namespace svms {
namespace {

// libpng reports errors through a callback that must not return; it jumps back to the
// setjmp in EncodePngWithResolution (libpng's documented error handling). The message is
// copied for the Status first.
struct ErrorSink {
  char message[200] = "";
};

void OnError(png_structp png, png_const_charp message) {
  auto* sink = static_cast<ErrorSink*>(png_get_error_ptr(png));
  std::strncpy(sink->message, message, sizeof(sink->message) - 1);
  png_longjmp(png, 1);
}

void OnWarning(png_structp, png_const_charp) {}

struct Output {
  std::string* bytes;
};

void OnWrite(png_structp png, png_bytep data, png_size_t length) {
  auto* out = static_cast<Output*>(png_get_io_ptr(png));
  bool failed = false;
  try {
    out->bytes->append(reinterpret_cast<const char*>(data), length);
  } catch (const std::bad_alloc&) {
    failed = true;
  }
  if (failed) png_error(png, "out of memory");
}

void OnFlush(png_structp) {}

}  // namespace

Status EncodePngWithResolution(const std::string& name, const unsigned char* xrgb, int width,
                               int height, int stride, std::uint32_t pixels_per_metre,
                               std::string* png_bytes) {
  if (width < 1 || height < 1 || pixels_per_metre == 0) {
    return Status::Error(name + ": cannot encode a PNG of " + std::to_string(width) + "x" +
                         std::to_string(height) + " pixels at " +
                         std::to_string(pixels_per_metre) + " pixels per metre");
  }
  // Everything with a destructor exists before setjmp, so that the jump skips none.
  std::vector<png_byte> row(static_cast<size_t>(width) * 3);
  std::string bytes;
  ErrorSink sink;
  Output out{&bytes};
  png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, &sink, OnError, OnWarning);
  if (png == nullptr) return Status::Error(name + ": cannot encode a PNG (libpng: no memory)");
  png_infop info = png_create_info_struct(png);
  if (info == nullptr) {
    png_destroy_write_struct(&png, nullptr);
    return Status::Error(name + ": cannot encode a PNG (libpng: no memory)");
  }
  if (setjmp(png_jmpbuf(png))) {
    png_destroy_write_struct(&png, &info);
    return Status::Error(name + ": cannot encode a PNG (libpng: " + sink.message + ")");
  }
  png_set_write_fn(png, &out, OnWrite, OnFlush);
  png_set_IHDR(png, info, static_cast<png_uint_32>(width), static_cast<png_uint_32>(height), 8,
               PNG_COLOR_TYPE_RGB, PNG_INTERLACE_NONE, PNG_COMPRESSION_TYPE_DEFAULT,
               PNG_FILTER_TYPE_DEFAULT);
  png_set_pHYs(png, info, pixels_per_metre, pixels_per_metre, PNG_RESOLUTION_METER);
  png_write_info(png, info);
  for (int y = 0; y < height; ++y) {
    const unsigned char* src = xrgb + static_cast<size_t>(y) * stride;
    for (int x = 0; x < width; ++x) {
      std::uint32_t p;
      std::memcpy(&p, src + 4 * static_cast<size_t>(x), 4);
      row[3 * x] = static_cast<png_byte>(p >> 16);
      row[3 * x + 1] = static_cast<png_byte>(p >> 8);
      row[3 * x + 2] = static_cast<png_byte>(p);
    }
    png_write_row(png, row.data());
  }
  png_write_end(png, info);
  png_destroy_write_struct(&png, &info);
  *png_bytes = std::move(bytes);
  return Status::Ok();
}

}  // namespace svms

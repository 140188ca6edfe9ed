// PNG files of artwork that carry their resolution: a pHYs chunk (pixels per metre), so that a
// viewer or printer that honours it prints the image at the artwork's physical size. cairo's
// own PNG writer writes no pHYs chunk, so the image is encoded with libpng (Debian's
// libpng-dev, the reference PNG library, which writes pHYs through png_set_pHYs).
#pragma once

#include <cstdint>
#include <string>

#include "svms/base/status.h"

namespace svms {

// Encodes an 8-bit RGB image as PNG into *png. `xrgb` holds `height` rows of `width` pixels,
// `stride` bytes apart, each pixel a native-endian uint32 0x00RRGGBB (cairo's
// CAIRO_FORMAT_RGB24). pixels_per_metre (> 0) goes into pHYs for both axes, unit metre.
// Errors (libpng's message) are one line starting with `name`.
Status EncodePngWithResolution(const std::string& name, const unsigned char* xrgb, int width,
                               int height, int stride, std::uint32_t pixels_per_metre,
                               std::string* png);

}  // namespace svms

// libFuzzer target: the image header reader that guards every decode (svms/imageio/image_io.h),
// both on a whole file and on a prefix.
#include <cstdint>

#include "svms/imageio/image_io.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  svms::ImageHeader h;
  svms::ReadImageHeader(data, size, true, &h);
  svms::ReadImageHeader(data, size, false, &h);
  return 0;
}

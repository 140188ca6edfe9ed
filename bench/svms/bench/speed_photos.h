// The real photographs of the speed benchmark (`svms bench speed`) and the crops cut from them.
//
// Sources, in order, each a Debian package that installs photographs
// (scripts/install_bench_photos installs the first two; opencv-doc comes with the peers):
//   plasma-workspace-wallpapers  /usr/share/wallpapers/NAME/contents/images/: the largest JPEG
//                                of each wallpaper (the PNG-only ones are drawn, not
//                                photographed, and are left out)
//   ukui-wallpapers              /usr/share/backgrounds/*.jpg
//   opencv-doc                   /usr/share/doc/opencv-doc/examples/data/*.jpg, without its
//                                logos and marker pictures
// Only JPEG files are taken: their response is known (sRGB), so they are turned into linear
// light the way every image the detector measures is (photometry.h).
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "svms/base/status.h"

namespace svms {

// One source of photographs: where it was looked for and what was found there.
struct PhotoSource {
  std::string package;             // the Debian package that installs it
  std::string dir;                 // the directory looked in
  bool present = false;            // the directory exists
  std::vector<std::string> files;  // its photographs, sorted
};

// The three sources under `root` ("" for the real file system; a test passes a temporary
// directory laid out the same way), each with its photographs.
std::vector<PhotoSource> FindPhotoSources(const std::string& root = "");

// One crop: a grey, linear-light, 8-bit image cut from a photograph.
struct PhotoCrop {
  std::string name;   // "SOURCE-PHOTO_WxH_K" ("plasma-Autumn_640x480_0"), safe as a file name
  std::string photo;  // the photograph's path
  std::string package;
  int x = 0, y = 0;  // the crop's top-left corner in the photograph
  cv::Mat image;     // CV_8UC1, linear light (0 = black, 255 = the photograph's white)
};

// `per_size` crops of each size in `sizes` from the photograph at `path` (deterministic: the
// positions come from `seed` and the file name), skipping the sizes the photograph is too small
// for, and giving one crop where the photograph is just the crop's size. The photograph is read as
// a camera stores it (sRGB JPEG), turned into linear light (16 bits, LinearizeImage) and then
// rounded to 8 bits. An error names the file.
Status CutCrops(const std::string& path, const std::string& package,
                const std::vector<cv::Size>& sizes, int per_size, uint64_t seed,
                std::vector<PhotoCrop>* out);

}  // namespace svms

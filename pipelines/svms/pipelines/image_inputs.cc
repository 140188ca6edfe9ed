#include "svms/pipelines/image_inputs.h"

#include <glob.h>

#include <algorithm>
#include <cctype>
#include <filesystem>

namespace svms {

namespace fs = std::filesystem;

namespace {

std::string LowerExtension(const std::string& path) {
  std::string e = fs::path(path).extension().string();
  for (auto& c : e) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return e;
}

}  // namespace

bool IsImageFile(const std::string& path) {
  const std::string e = LowerExtension(path);
  return e == ".png" || e == ".jpg" || e == ".jpeg" || e == ".tif" || e == ".tiff" || e == ".bmp" ||
         e == ".pgm" || e == ".ppm";
}

bool IsVideoFile(const std::string& path) {
  const std::string e = LowerExtension(path);
  return e == ".mp4" || e == ".m4v" || e == ".mov" || e == ".avi" || e == ".mkv" || e == ".webm" ||
         e == ".mpg" || e == ".mpeg";
}

std::vector<std::string> ExpandImageInputs(const std::vector<std::string>& inputs) {
  std::vector<std::string> out;
  for (const std::string& in : inputs) {
    std::error_code ec;
    if (fs::is_directory(in, ec)) {
      std::vector<std::string> files;
      for (const auto& e : fs::directory_iterator(in, ec))
        if (e.is_regular_file() && IsImageFile(e.path().string()))
          files.push_back(e.path().string());
      std::sort(files.begin(), files.end());
      out.insert(out.end(), files.begin(), files.end());
    } else if (in.find_first_of("*?[") != std::string::npos) {
      glob_t g;
      if (glob(in.c_str(), 0, nullptr, &g) == 0)
        for (size_t i = 0; i < g.gl_pathc; ++i) out.push_back(g.gl_pathv[i]);
      else
        out.push_back(in);
      globfree(&g);
    } else {
      out.push_back(in);
    }
  }
  return out;
}

}  // namespace svms

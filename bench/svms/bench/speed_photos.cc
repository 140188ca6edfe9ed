#include "svms/bench/speed_photos.h"

#include <algorithm>
#include <filesystem>
#include <random>

#include "svms/pipelines/photometry.h"

namespace svms {
namespace {

namespace fs = std::filesystem;

bool IsJpeg(const fs::path& p) {
  std::string ext = p.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return std::tolower(c); });
  return ext == ".jpg" || ext == ".jpeg";
}

// "2560x1600.jpg" -> 2560 * 1600; 0 when the name is not WxH.
long long NamedPixels(const fs::path& p) {
  int w = 0, h = 0;
  char tail = 0;
  if (std::sscanf(p.stem().string().c_str(), "%dx%d%c", &w, &h, &tail) != 2) return 0;
  return static_cast<long long>(w) * h;
}

// The JPEG files directly in `dir`, sorted.
std::vector<std::string> JpegsIn(const fs::path& dir) {
  std::vector<std::string> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.is_regular_file(ec) && IsJpeg(e.path())) out.push_back(e.path().string());
  std::sort(out.begin(), out.end());
  return out;
}

// Pictures of opencv-doc that are not photographs of ordinary scenes: logos, and pictures of
// markers (a peer would be right to find them).
bool NotAPhoto(const std::string& path) {
  std::string n = fs::path(path).filename().string();
  std::transform(n.begin(), n.end(), n.begin(), [](unsigned char c) { return std::tolower(c); });
  for (const char* word : {"logo", "aruco", "charuco", "apriltag", "marker", "tag"})
    if (n.find(word) != std::string::npos) return true;
  return false;
}

std::string SafeName(std::string s) {
  for (char& c : s)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '-') c = '-';
  return s;
}

}  // namespace

std::vector<PhotoSource> FindPhotoSources(const std::string& root) {
  std::vector<PhotoSource> out;
  std::error_code ec;
  {
    PhotoSource s{"plasma-workspace-wallpapers", root + "/usr/share/wallpapers", false, {}};
    s.present = fs::is_directory(s.dir, ec);
    if (s.present) {
      std::vector<fs::path> walls;
      for (const auto& e : fs::directory_iterator(s.dir, ec))
        if (e.is_directory(ec)) walls.push_back(e.path());
      std::sort(walls.begin(), walls.end());
      for (const fs::path& w : walls) {
        std::string best;
        long long best_px = -1;
        for (const std::string& f : JpegsIn(w / "contents" / "images"))
          if (NamedPixels(f) > best_px) best = f, best_px = NamedPixels(f);
        if (!best.empty()) s.files.push_back(best);
      }
    }
    out.push_back(s);
  }
  {
    PhotoSource s{"ukui-wallpapers", root + "/usr/share/backgrounds", false, {}};
    s.present = fs::is_directory(s.dir, ec);
    if (s.present) s.files = JpegsIn(s.dir);
    out.push_back(s);
  }
  {
    PhotoSource s{"opencv-doc", root + "/usr/share/doc/opencv-doc/examples/data", false, {}};
    s.present = fs::is_directory(s.dir, ec);
    if (s.present)
      for (const std::string& f : JpegsIn(s.dir))
        if (!NotAPhoto(f)) s.files.push_back(f);
    out.push_back(s);
  }
  return out;
}

Status CutCrops(const std::string& path, const std::string& package,
                const std::vector<cv::Size>& sizes, int per_size, uint64_t seed,
                std::vector<PhotoCrop>* out) {
  Photometry photometry;
  if (Status s = Photometry::Create(PhotometryOptions{}, "", &photometry); !s) return s;
  cv::Mat linear;
  nlohmann::json how;
  if (Status s = photometry.Load(path, int64_t{1} << 28, &linear, &how); !s)
    return Status::Error(path + ": " + s.message());
  cv::Mat grey8;
  linear.convertTo(grey8, CV_8U, linear.depth() == CV_16U ? 255.0 / 65535.0 : 1.0);
  // The positions depend on the seed and the file's name only (FNV-1a: the same everywhere).
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : fs::path(path).filename().string()) h = (h ^ c) * 1099511628211ull;
  std::mt19937_64 rng(seed * 7919 + h);
  // A wallpaper's name is its directory's (its files are named by their size).
  const fs::path p(path);
  const std::string photo_name =
      NamedPixels(p) > 0 ? p.parent_path().parent_path().parent_path().filename().string()
                         : p.stem().string();
  const std::string stem = SafeName(package.substr(0, package.find('-')) + "_" + photo_name);
  for (const cv::Size& sz : sizes) {
    if (grey8.cols < sz.width || grey8.rows < sz.height) continue;
    // A photograph of just the crop's size gives one crop, not copies of it.
    const int n = grey8.cols == sz.width && grey8.rows == sz.height ? 1 : per_size;
    for (int k = 0; k < n; ++k) {
      PhotoCrop c;
      c.photo = path;
      c.package = package;
      c.x = static_cast<int>(rng() % static_cast<uint64_t>(grey8.cols - sz.width + 1));
      c.y = static_cast<int>(rng() % static_cast<uint64_t>(grey8.rows - sz.height + 1));
      c.name = stem + "_" + std::to_string(sz.width) + "x" + std::to_string(sz.height) + "_" +
               std::to_string(k);
      c.image = grey8(cv::Rect(c.x, c.y, sz.width, sz.height)).clone();
      out->push_back(std::move(c));
    }
  }
  return Status::Ok();
}

}  // namespace svms

// libFuzzer target: mrcal .cameramodel files through CameraModel::Read (the bytes go to a temp
// file, as a user's file would). A model that reads must project and unproject without crashing
// and write back to a file that reads back the same.
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>

#include "svms/camera/camera.h"

namespace {
std::string TempPath(const char* what) {
  return "/tmp/svms_fuzz_camera_" + std::to_string(::getpid()) + what;
}

// Removes the two files when an input is done, whichever way it returns (an abort leaves them).
struct RemoveOnReturn {
  const std::string& a;
  const std::string& b;
  ~RemoveOnReturn() {
    std::remove(a.c_str());
    std::remove(b.c_str());
  }
};
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const std::string in_path = TempPath(".in.cameramodel");
  static const std::string out_path = TempPath(".out.cameramodel");
  const RemoveOnReturn cleanup{in_path, out_path};
  {
    std::ofstream f(in_path, std::ios::binary | std::ios::trunc);
    f.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  svms::CameraModel cam;
  if (!svms::CameraModel::Read(in_path, &cam).ok()) return 0;
  (void)cam.Summary();
  Eigen::Vector2d px;
  Eigen::Matrix<double, 2, 3> dpx_dp;
  Eigen::Matrix<double, 2, Eigen::Dynamic> dpx_di;
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(0.3, -0.2, 1),
                                   Eigen::Vector3d(-1, 1, 0.1), Eigen::Vector3d(0, 0, -1)}) {
    cam.Project(p, &px);
    cam.Project(p, &px, &dpx_dp, &dpx_di);
  }
  Eigen::Vector3d dir;
  cam.Unproject(Eigen::Vector2d(0.5 * (cam.width() - 1), 0.5 * (cam.height() - 1)), &dir);
  cam.Unproject(Eigen::Vector2d(0, 0), &dir);
  svms::CameraModel back;
  if (!cam.Write(out_path).ok() || !svms::CameraModel::Read(out_path, &back).ok() ||
      back.intrinsics() != cam.intrinsics() || back.lensmodel() != cam.lensmodel() ||
      back.width() != cam.width() || back.height() != cam.height()) {
    std::fprintf(stderr, "a model that read does not write and read back the same: %s\n",
                 cam.Summary().c_str());
    std::abort();
  }
  return 0;
}

// Heap use per frame of the C API, counted by interposing glibc's malloc family in this
// executable (operator new goes through malloc in libstdc++, OpenCV's fastMalloc through
// posix_memalign or malloc). Usage: svms_capi_alloc_test FIXTURE_DIR.
//
// What it checks (the C API's promise: no allocation at all after the first frames): after warm-up
// on a fixture frame, 8-bit and 16-bit, every svms_process_frame (and svms_last_bias_factor after
// it) makes no heap allocation at all; nor does svms_process_frame_multi with two layouts on the
// two-object frame, nor svms_process_rig_frame and svms_process_rig_frame_u16 (and
// svms_last_rig_bias_factor) on a rig of two cameras, with both frames, 8- and 16-bit, and with
// one; nor does svms_process_frame with the 2 x 2 search (svms_set_detection). The rig's two
// cameras are the fixture's camera at the same place (a rig file written here),
// so that both see the fixture's frame. And, with every allocation failing, an entry point that has
// to word an error returns a status instead of letting std::bad_alloc cross into C (which would end
// this program).
#include <unistd.h>

#include <atomic>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "svms/svms.h"

extern "C" {
void* __libc_malloc(size_t);
void* __libc_calloc(size_t, size_t);
void* __libc_realloc(void*, size_t);
void* __libc_memalign(size_t, size_t);
void __libc_free(void*);
}

namespace {
std::atomic<bool> counting{false};
std::atomic<bool> failing{false};  // every allocation returns NULL (operator new throws)
std::atomic<long> allocations{0}, frees{0};
void Count() {
  if (counting.load(std::memory_order_relaxed)) allocations.fetch_add(1, std::memory_order_relaxed);
}
}  // namespace

extern "C" {
void* malloc(size_t n) {
  Count();
  if (failing) return nullptr;
  return __libc_malloc(n);
}
void* calloc(size_t a, size_t b) {
  Count();
  if (failing) return nullptr;
  return __libc_calloc(a, b);
}
void* realloc(void* p, size_t n) {
  Count();
  if (failing) return nullptr;
  return __libc_realloc(p, n);
}
void free(void* p) {
  if (p && counting.load(std::memory_order_relaxed)) frees.fetch_add(1, std::memory_order_relaxed);
  __libc_free(p);
}
int posix_memalign(void** out, size_t align, size_t n) {
  Count();
  if (failing) return 12;  // ENOMEM
  void* p = __libc_memalign(align, n);
  if (!p) return 12;  // ENOMEM
  *out = p;
  return 0;
}
void* aligned_alloc(size_t align, size_t n) {
  Count();
  if (failing) return nullptr;
  return __libc_memalign(align, n);
}
void* memalign(size_t align, size_t n) {
  Count();
  if (failing) return nullptr;
  return __libc_memalign(align, n);
}
}

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: svms_capi_alloc_test FIXTURE_DIR\n");
    return 2;
  }
  const std::string dir = argv[1];
  std::vector<unsigned char> frame(1024 * 1024);
  std::ifstream(dir + "/frame_11.raw", std::ios::binary)
      .read(reinterpret_cast<char*>(frame.data()), frame.size());
  svms_estimator* e = nullptr;
  // The camera with a covariance sidecar: the calibration's term is in the frames counted too.
  if (svms_create((dir + "/cal.cameramodel").c_str(), (dir + "/true_layout.json").c_str(), nullptr,
                  &e) != SVMS_OK) {
    std::fprintf(stderr, "svms_create: %s\n", svms_last_error());
    return 1;
  }
  // The same frame as 16-bit (scaled to 12 bits, as a machine-vision camera's).
  std::vector<uint16_t> frame16(frame.size());
  for (size_t i = 0; i < frame.size(); ++i) frame16[i] = static_cast<uint16_t>(frame[i] * 16);
  svms_pose pose;
  auto process = [&](int i) {
    return i % 2 == 0 ? svms_process_frame(e, frame.data(), 1024, 1024, 1024, i, &pose)
                      : svms_process_frame_u16(e, frame16.data(), 1024, 1024, 2048, i, &pose);
  };
  for (int i = 0; i < 6; ++i) process(i);
  std::vector<long> per_frame, unfreed;
  std::vector<std::string> counted;  // per_frame[i]'s configuration and frame
  // One counted frame: `call(i)` processes frame i into `pose`, `factor(buffer, &columns)`
  // copies its bias factor out (up to 64 columns); both must succeed, the pose valid with the
  // flags `flags`, and the factor not empty. The allocations of both calls go to per_frame, those
  // not freed to unfreed. False, after saying why, when a call failed.
  auto count_frame = [&](const char* what, int i, uint32_t flags, auto&& call, auto&& factor) {
    allocations = 0;
    frees = 0;
    counting = true;
    const svms_status s = call(i);
    double buffer[6 * 64];
    int columns = 0;
    const svms_status sf = factor(buffer, &columns);
    counting = false;
    if (s != SVMS_OK || !pose.valid || (pose.flags & flags) != flags) {
      std::fprintf(stderr, "%s, frame %d: %s %s\n", what, i, svms_status_string(s),
                   svms_last_error());
      return false;
    }
    if (sf != SVMS_OK || columns <= 0) {
      std::fprintf(stderr, "%s, frame %d: the bias factor: %s, %d columns: %s\n", what, i,
                   svms_status_string(sf), columns, svms_last_error());
      return false;
    }
    per_frame.push_back(allocations.load());
    unfreed.push_back(allocations.load() - frees.load());
    counted.push_back(std::string(what) + ", frame " + std::to_string(i));
    return true;
  };
  for (int i = 0; i < 20; ++i) {
    // The frame's common error's factor too (the calibration's 12 columns fit in 64).
    if (!count_frame("one layout", i, SVMS_FLAG_CALIBRATION_IN_COVARIANCE, process,
                     [&](double* buffer, int* columns) {
                       return svms_last_bias_factor(e, 0, buffer, 64, columns);
                     }))
      return 1;
  }
  // Out of memory while wording errors: a frame of the wrong size, a NULL rig estimator, files
  // that do not exist. Each message is longer than a short string's inline buffer.
  svms_rig_frame rig_frame{};
  svms_estimator* none = nullptr;
  (void)svms_last_error();  // its thread-local string exists (glibc allocates to register it)
  failing = true;
  const svms_status wrong_size = svms_process_frame(e, frame.data(), 640, 480, 640, 0, &pose);
  const svms_status null_rig = svms_process_rig_frame(nullptr, &rig_frame, 1, 0, &pose);
  const svms_status no_files =
      svms_create("/nonexistent/camera.cameramodel", "/nonexistent/layout.json", nullptr, &none);
  failing = false;
  if (wrong_size == SVMS_OK || null_rig == SVMS_OK || no_files == SVMS_OK || none) {
    std::fprintf(stderr, "FAIL: out of memory: %s, %s, %s\n", svms_status_string(wrong_size),
                 svms_status_string(null_rig), svms_status_string(no_files));
    return 1;
  }
  // The handle still works.
  if (process(0) != SVMS_OK) {
    std::fprintf(stderr, "FAIL: after the out-of-memory calls: %s\n", svms_last_error());
    return 1;
  }
  svms_destroy(e);

  // The 2 x 2 search (svms_set_detection) on one thread. Not with more threads per frame: each
  // worker grows its buffers in the first frames where it gets a share of the work, and a worker
  // that the machine's load keeps off its CPU may get none for many frames
  // (docs/flight-interface.md, "Memory").
  if (svms_create((dir + "/cal.cameramodel").c_str(), (dir + "/true_layout.json").c_str(), nullptr,
                  &e) != SVMS_OK ||
      svms_set_detection(e, 2, 1) != SVMS_OK) {
    std::fprintf(stderr, "svms_create, svms_set_detection: %s\n", svms_last_error());
    return 1;
  }
  for (int i = 0; i < 6; ++i) process(i);
  for (int i = 0; i < 20; ++i) {
    if (!count_frame("decimate 2", i, SVMS_FLAG_CALIBRATION_IN_COVARIANCE, process,
                     [&](double* buffer, int* columns) {
                       return svms_last_bias_factor(e, 0, buffer, 64, columns);
                     }))
      return 1;
  }
  svms_destroy(e);

  // Two objects, one detection: svms_process_frame_multi.
  std::ifstream(dir + "/pair.raw", std::ios::binary)
      .read(reinterpret_cast<char*>(frame.data()), frame.size());
  for (size_t i = 0; i < frame.size(); ++i) frame16[i] = static_cast<uint16_t>(frame[i] * 16);
  const std::string module = dir + "/true_layout.json", fixture = dir + "/fixture_layout.json";
  const char* layouts[2] = {module.c_str(), fixture.c_str()};
  if (svms_create_multi((dir + "/cal.cameramodel").c_str(), layouts, 2, nullptr, 0, &e) !=
      SVMS_OK) {
    std::fprintf(stderr, "svms_create_multi: %s\n", svms_last_error());
    return 1;
  }
  svms_pose poses[2];
  svms_frame_info info;
  auto process_multi = [&](int i) {
    return i % 2 == 0
               ? svms_process_frame_multi(e, frame.data(), 1024, 1024, 1024, i, poses, 2, &info)
               : svms_process_frame_multi_u16(e, frame16.data(), 1024, 1024, 2048, i, poses, 2,
                                              &info);
  };
  for (int i = 0; i < 6; ++i) process_multi(i);
  for (int i = 0; i < 20; ++i) {
    allocations = 0;
    frees = 0;
    counting = true;
    const svms_status s = process_multi(i);
    counting = false;
    if (s != SVMS_OK || !poses[0].valid || !poses[1].valid) {
      std::fprintf(stderr, "two objects, frame %d: %s %s\n", i, svms_status_string(s),
                   svms_last_error());
      return 1;
    }
    per_frame.push_back(allocations.load());
    unfreed.push_back(allocations.load() - frees.load());
  }
  svms_destroy(e);

  // A rig of two cameras, both the fixture's camera (with its calibration's covariance) at the
  // rig's origin, the first with an extrinsics covariance too: the frames it sees carry
  // SVMS_FLAG_EXTRINSICS_IN_COVARIANCE.
  std::ifstream(dir + "/frame_11.raw", std::ios::binary)
      .read(reinterpret_cast<char*>(frame.data()), frame.size());
  char rig_dir[] = "/tmp/svms_capi_alloc_test.XXXXXX";
  if (!mkdtemp(rig_dir)) {
    std::perror("mkdtemp");
    return 1;
  }
  const std::string rig_path = std::string(rig_dir) + "/two.rig";
  {
    char* cwd = getcwd(nullptr, 0);
    if (!cwd) {
      std::perror("getcwd");
      return 1;
    }
    const std::string model = !dir.empty() && dir.front() == '/'
                                  ? dir + "/cal.cameramodel"
                                  : std::string(cwd) + "/" + dir + "/cal.cameramodel";
    std::free(cwd);
    std::ofstream(rig_path)
        << R"({"type": "svms.rig", "name": "alloc", "cameras": [{"name": "a", "cameramodel": ")"
        << model << R"(", "rig_from_cam": {"rvec": [0,0,0], "tvec": [0,0,0]}, "covariance": )"
        << R"([[1e-8,0,0,0,0,0],[0,1e-8,0,0,0,0],[0,0,1e-8,0,0,0],[0,0,0,1e-8,0,0],)"
        << R"([0,0,0,0,1e-8,0],[0,0,0,0,0,1e-8]]}, {"name": "b", "cameramodel": ")" << model
        << R"(", "rig_from_cam": {"rvec": [0,0,0], "tvec": [0,0,0]}}]})";
  }
  svms_rig_estimator* rig = nullptr;
  const svms_status created = svms_create_rig(rig_path.c_str(), module.c_str(), nullptr, &rig);
  std::remove(rig_path.c_str());
  rmdir(rig_dir);
  if (created != SVMS_OK) {
    std::fprintf(stderr, "svms_create_rig: %s\n", svms_last_error());
    return 1;
  }
  for (size_t i = 0; i < frame.size(); ++i) frame16[i] = static_cast<uint16_t>(frame[i] * 16);
  const svms_rig_frame both[2] = {{frame.data(), 1024, 1024, 1024},
                                  {frame.data(), 1024, 1024, 1024}};
  const svms_rig_frame second_only[2] = {{nullptr, 0, 0, 0}, both[1]};
  const svms_rig_frame_u16 both16[2] = {{frame16.data(), 1024, 1024, 2048},
                                        {frame16.data(), 1024, 1024, 2048}};
  const svms_rig_frame_u16 second_only16[2] = {{nullptr, 0, 0, 0}, both16[1]};
  // 8-bit frames, 16-bit ones, then the second camera's alone (8- and 16-bit in turn).
  auto process_rig = [&](int i) {
    if (i % 3 == 0) return svms_process_rig_frame(rig, both, 2, i, &pose);
    if (i % 3 == 1) return svms_process_rig_frame_u16(rig, both16, 2, i, &pose);
    return i % 2 == 0 ? svms_process_rig_frame(rig, second_only, 2, i, &pose)
                      : svms_process_rig_frame_u16(rig, second_only16, 2, i, &pose);
  };
  for (int i = 0; i < 6; ++i) process_rig(i);
  for (int i = 0; i < 21; ++i) {
    // The second camera, alone on every third frame, has no extrinsics covariance.
    if (!count_frame("rig", i, i % 3 == 2 ? 0u : SVMS_FLAG_EXTRINSICS_IN_COVARIANCE, process_rig,
                     [&](double* buffer, int* columns) {
                       return svms_last_rig_bias_factor(rig, 0, buffer, 64, columns);
                     }))
      return 1;
  }
  svms_destroy_rig(rig);

  long lo = per_frame[0], hi = per_frame[0], leaked = 0;
  for (size_t i = 0; i < per_frame.size(); ++i) {
    lo = std::min(lo, per_frame[i]);
    hi = std::max(hi, per_frame[i]);
    leaked += unfreed[i];
  }
  std::printf(
      "svms_capi_alloc_test: %ld-%ld heap allocations per frame after warm-up (8- and 16-bit, the "
      "2 x 2 search, one layout and two, a rig of two cameras), %ld not freed over %zu frames\n",
      lo, hi, leaked, per_frame.size());
  for (size_t i = 0; i < per_frame.size(); ++i)
    if (per_frame[i] != 0 || unfreed[i] != 0)
      std::fprintf(stderr, "%s: %ld heap allocations, %ld not freed\n", counted[i].c_str(),
                   per_frame[i], unfreed[i]);
  int failed = 0;
  if (leaked != 0) std::fprintf(stderr, "FAIL: %ld allocations not freed\n", leaked), failed = 1;
  if (hi > 0) std::fprintf(stderr, "FAIL: up to %ld heap allocations per frame\n", hi), failed = 1;
  return failed;
}

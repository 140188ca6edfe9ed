/* The C API from plain C99: a pose from a rendered frame against its truth, every error path,
 * strides, 16-bit pixels, the time budget, calls after destroy, one handle per thread, one
 * handle shared by two threads (SVMS_ERR_BUSY, destroy refused during a call, per-thread
 * svms_last_error), and two objects from one frame (svms_create_multi).
 * Usage: svms_capi_c_test FIXTURE_DIR (written by svms_capi_fixture). */
#include <math.h>
#include <pthread.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "svms/svms.h"

static int failures = 0;
#define CHECK(cond)                                                            \
  do {                                                                         \
    if (!(cond)) {                                                             \
      fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond); \
      ++failures;                                                              \
    }                                                                          \
  } while (0)
#define CHECK_STATUS(call, expected)                                                      \
  do {                                                                                    \
    svms_status s_ = (call);                                                              \
    if (s_ != (expected)) {                                                               \
      fprintf(stderr, "%s:%d: %s gave %s, expected %s (%s)\n", __FILE__, __LINE__, #call, \
              svms_status_string(s_), svms_status_string(expected), svms_last_error());   \
      ++failures;                                                                         \
    }                                                                                     \
  } while (0)

enum { W = 1024, H = 1024 };
static char camera_path[4096], layout_path[4096];
static const char* fixture_dir;
static unsigned char* frame;

static unsigned char* ReadRaw(const char* path, size_t n) {
  FILE* f = fopen(path, "rb");
  unsigned char* p = (unsigned char*)malloc(n);
  if (!f || !p || fread(p, 1, n, f) != n) {
    fprintf(stderr, "cannot read %s\n", path);
    exit(2);
  }
  fclose(f);
  return p;
}

typedef struct {
  svms_pose pose;
  svms_status status;
} ThreadResult;

static void* Worker(void* arg) {
  ThreadResult* r = (ThreadResult*)arg;
  svms_estimator* e = NULL;
  r->status = svms_create(camera_path, layout_path, NULL, &e);
  for (int i = 0; i < 3 && r->status == SVMS_OK; ++i)
    r->status = svms_process_frame(e, frame, W, H, W, 1.5, &r->pose);
  svms_destroy(e);
  return NULL;
}

/* One handle shared by two threads (against the header's rule, as a careless program would):
 * the owner processes frames while the intruder calls svms_process_frame, svms_set_detection and
 * svms_destroy on the same handle. Every intruding call is SVMS_OK or SVMS_ERR_BUSY, never a crash,
 * and the BUSY ones say why in the intruder's own svms_last_error. */
typedef struct {
  svms_estimator* e;
  int done; /* set by the owner when its frames are processed */
  int owner_erred, intruder_erred;
  int owner_ok, owner_frames;
  int busy_process, busy_destroy, busy_set, other_status, message_ok;
  char owner_error_after[256];    /* the owner's svms_last_error after both threads erred */
  char intruder_error_after[256]; /* the intruder's */
} SharedHandle;

static void* Owner(void* arg) {
  SharedHandle* sh = (SharedHandle*)arg;
  svms_pose p;
  for (int i = 0; i < sh->owner_frames; ++i) {
    svms_status s;
    /* The intruder may hold the handle for a moment: retry, as a real program would. */
    while ((s = svms_process_frame(sh->e, frame, W, H, W, i, &p)) == SVMS_ERR_BUSY) {
    }
    sh->owner_ok += s == SVMS_OK && p.valid;
  }
  __atomic_store_n(&sh->done, 1, __ATOMIC_SEQ_CST);
  /* Per-thread last errors: this thread's own error, then the intruder's own, then each reads
   * back its own. */
  while (svms_process_frame(sh->e, frame, W - 1, H, W, 0, &p) == SVMS_ERR_BUSY) {
    /* the intruder's last call may still hold the handle */
  }
  __atomic_store_n(&sh->owner_erred, 1, __ATOMIC_SEQ_CST);
  while (!__atomic_load_n(&sh->intruder_erred, __ATOMIC_SEQ_CST)) {
  }
  snprintf(sh->owner_error_after, sizeof sh->owner_error_after, "%s", svms_last_error());
  return NULL;
}

static void* Intruder(void* arg) {
  SharedHandle* sh = (SharedHandle*)arg;
  svms_pose p;
  while (!__atomic_load_n(&sh->done, __ATOMIC_SEQ_CST)) {
    const svms_status a = svms_process_frame(sh->e, frame, W, H, W, 0, &p);
    if (a == SVMS_OK) continue; /* the owner was between frames */
    if (a != SVMS_ERR_BUSY) {
      ++sh->other_status;
      break;
    }
    ++sh->busy_process;
    sh->message_ok += strstr(svms_last_error(), "in use by another thread") != NULL;
    /* Changing the search during the owner's frame is refused too; between frames it is taken
     * (the defaults again, so the owner's frames are unchanged either way). */
    if (sh->busy_set < 3) {
      const svms_status t = svms_set_detection(sh->e, 1, 1);
      if (t == SVMS_ERR_BUSY) {
        ++sh->busy_set;
        sh->message_ok += strstr(svms_last_error(), "svms_set_detection") != NULL &&
                          strstr(svms_last_error(), "in use by another thread") != NULL;
      } else if (t == SVMS_OK) {
        continue; /* the owner is between frames: no destroy now (see below) */
      } else {
        ++sh->other_status;
        break;
      }
    }
    /* The owner is inside a call (it takes milliseconds; this follows within microseconds):
     * destroying now is refused. Three tries: in the microsecond window in which the owner
     * could finish in between, destroy would succeed and the owner's next frame see a
     * destroyed handle (counted as other_status, a failure of the test). */
    if (sh->busy_destroy >= 3) continue;
    const svms_status d = svms_destroy(sh->e);
    if (d != SVMS_ERR_BUSY) {
      ++sh->other_status; /* destroyed under the owner */
      break;
    }
    ++sh->busy_destroy;
    sh->message_ok += strstr(svms_last_error(), "svms_destroy") != NULL;
  }
  while (!__atomic_load_n(&sh->owner_erred, __ATOMIC_SEQ_CST)) {
  }
  svms_process_frame(sh->e, NULL, W, H, W, 0, &p);
  __atomic_store_n(&sh->intruder_erred, 1, __ATOMIC_SEQ_CST);
  snprintf(sh->intruder_error_after, sizeof sh->intruder_error_after, "%s", svms_last_error());
  return NULL;
}

static void CheckSharedHandle(void) {
  SharedHandle sh;
  memset(&sh, 0, sizeof sh);
  sh.owner_frames = 12;
  CHECK_STATUS(svms_create(camera_path, layout_path, NULL, &sh.e), SVMS_OK);
  pthread_t owner, intruder;
  CHECK(pthread_create(&owner, NULL, Owner, &sh) == 0);
  CHECK(pthread_create(&intruder, NULL, Intruder, &sh) == 0);
  pthread_join(owner, NULL);
  pthread_join(intruder, NULL);
  CHECK(sh.owner_ok == sh.owner_frames);
  CHECK(sh.other_status == 0);
  /* The owner holds the handle for about 12 frames x 10-20 ms: the intruder's destroy, tried
   * in a loop meanwhile, is refused at least once, and each refusal is worded. */
  CHECK(sh.busy_destroy > 0);
  CHECK(sh.busy_set > 0);
  CHECK(sh.message_ok == sh.busy_process + sh.busy_destroy + sh.busy_set);
  /* Each thread's last error is its own: the owner's bad width, the intruder's NULL pixels,
   * though the intruder erred after the owner. */
  CHECK(strstr(sh.owner_error_after, "1023x1024") != NULL);
  CHECK(strstr(sh.intruder_error_after, "pixels") != NULL);
  CHECK(strstr(sh.intruder_error_after, "1023x1024") == NULL);
  /* The handle survived every refused destroy. */
  svms_pose p;
  CHECK_STATUS(svms_process_frame(sh.e, frame, W, H, W, 0, &p), SVMS_OK);
  CHECK(p.valid);
  CHECK_STATUS(svms_destroy(sh.e), SVMS_OK);
  CHECK_STATUS(svms_destroy(sh.e), SVMS_ERR_BAD_HANDLE);
}

/* The angle between a rotation vector and a unit quaternion [w, x, y, z], radians. */
static double AngleToQuaternion(const double* rvec, const double* q) {
  const double a = sqrt(rvec[0] * rvec[0] + rvec[1] * rvec[1] + rvec[2] * rvec[2]);
  const double s = a > 0 ? sin(a / 2) / a : 0.5;
  const double qt[4] = {cos(a / 2), s * rvec[0], s * rvec[1], s * rvec[2]};
  double dot = 0;
  for (int i = 0; i < 4; ++i) dot += qt[i] * q[i];
  return 2 * acos(fmin(1, fabs(dot)));
}

static void CheckLoneAmbiguousMarker(void) {
  char cam[4096], layout[4096], path[4096];
  snprintf(cam, sizeof cam, "%s/lone.cameramodel", fixture_dir);
  snprintf(layout, sizeof layout, "%s/lone_layout.json", fixture_dir);
  snprintf(path, sizeof path, "%s/lone.txt", fixture_dir);
  int w = 0, h = 0;
  double truth[6];
  FILE* tf = fopen(path, "r");
  CHECK(tf && fscanf(tf, "%d %d %lf %lf %lf %lf %lf %lf", &w, &h, &truth[0], &truth[1], &truth[2],
                     &truth[3], &truth[4], &truth[5]) == 8);
  if (tf) fclose(tf);
  if (w <= 0 || h <= 0) return;
  snprintf(path, sizeof path, "%s/lone.raw", fixture_dir);
  unsigned char* pixels = ReadRaw(path, (size_t)w * h);
  svms_estimator* e = NULL;
  CHECK_STATUS(svms_create(cam, layout, NULL, &e), SVMS_OK);
  svms_pose p;
  CHECK_STATUS(svms_process_frame(e, pixels, w, h, w, 4, &p), SVMS_OK);
  const double deg = 3.14159265358979 / 180;
  CHECK(p.valid && p.markers_used == 1);
  CHECK((p.flags & SVMS_FLAG_AMBIGUOUS) != 0);
  CHECK(p.has_alternative == 1);
  CHECK(p.alternative_weight > 0.01 && p.alternative_weight <= 0.5);
  CHECK(AngleToQuaternion(truth, p.quaternion) > 10 * deg);
  CHECK(AngleToQuaternion(truth, p.alternative_quaternion) < 2 * deg);
  CHECK(AngleToQuaternion(p.alternative_rvec, p.alternative_quaternion) < 1e-6);
  double dt = 0;
  for (int i = 0; i < 3; ++i)
    dt += (p.alternative_tvec[i] - truth[3 + i]) * (p.alternative_tvec[i] - truth[3 + i]);
  CHECK(sqrt(dt) < 0.01 * truth[5]);
  svms_destroy(e);
  free(pixels);
}

/* Two objects in one frame (pair.raw: the module and the fixture, pair.txt their true poses):
 * svms_process_frame_multi gives each within 1 mm of its truth, each bit for bit the pose of a
 * single-layout estimator of that object, from one detection; and its errors. */
static void CheckTwoObjects(void) {
  char cam[4096], module[4096], fixture[4096], clash[4096], path[4096];
  snprintf(cam, sizeof cam, "%s/true.cameramodel", fixture_dir);
  snprintf(module, sizeof module, "%s/true_layout.json", fixture_dir);
  snprintf(fixture, sizeof fixture, "%s/fixture_layout.json", fixture_dir);
  snprintf(clash, sizeof clash, "%s/clash_layout.json", fixture_dir);
  double truth[2][6];
  snprintf(path, sizeof path, "%s/pair.txt", fixture_dir);
  FILE* tf = fopen(path, "r");
  int read = 0;
  for (int i = 0; tf && i < 12; ++i) read += fscanf(tf, "%lf", &truth[i / 6][i % 6]);
  CHECK(read == 12);
  if (tf) fclose(tf);
  if (read != 12) return;
  snprintf(path, sizeof path, "%s/pair.raw", fixture_dir);
  unsigned char* pixels = ReadRaw(path, (size_t)W * H);

  const char* both[2] = {module, fixture};
  svms_estimator *e = NULL, *alone[2] = {NULL, NULL};
  CHECK_STATUS(svms_create_multi(cam, both, 2, NULL, 0, &e), SVMS_OK);
  int n = 0;
  CHECK_STATUS(svms_layout_count(e, &n), SVMS_OK);
  CHECK(n == 2);
  svms_pose poses[2], single;
  svms_frame_info info;
  CHECK_STATUS(svms_process_frame_multi(e, pixels, W, H, W, 5, poses, 2, &info), SVMS_OK);
  CHECK(info.timestamp == 5 && info.n_unassigned == 0 && info.flags == 0);
  CHECK(info.detect_ms > 0 && info.latency_ms >= info.detect_ms + info.fuse_ms - 1e-6);
  for (int i = 0; i < 2; ++i) {
    CHECK(poses[i].valid && poses[i].markers_used >= 2 && poses[i].timestamp == 5);
    double d = 0;
    for (int k = 0; k < 3; ++k) d += pow(poses[i].tvec[k] - truth[i][3 + k], 2);
    CHECK(sqrt(d) < 1e-3);
    CHECK(AngleToQuaternion(truth[i], poses[i].quaternion) < 0.02 * 3.14159265358979 / 180);
    /* The same as an estimator of this object alone, to the bit. */
    CHECK_STATUS(svms_create(cam, both[i], NULL, &alone[i]), SVMS_OK);
    CHECK_STATUS(svms_process_frame(alone[i], pixels, W, H, W, 5, &single), SVMS_OK);
    CHECK(memcmp(poses[i].rvec, single.rvec, sizeof single.rvec) == 0);
    CHECK(memcmp(poses[i].tvec, single.tvec, sizeof single.tvec) == 0);
    CHECK(memcmp(poses[i].covariance, single.covariance, sizeof single.covariance) == 0);
    CHECK(memcmp(poses[i].marker_ids, single.marker_ids, sizeof single.marker_ids) == 0);
  }
  CHECK(poses[1].marker_ids[0] >= 30 && poses[1].marker_ids[0] <= 32);
  /* svms_process_frame on it: the first layout's object. */
  CHECK_STATUS(svms_process_frame(e, pixels, W, H, W, 5, &single), SVMS_OK);
  CHECK(memcmp(poses[0].tvec, single.tvec, sizeof single.tvec) == 0);
  /* 16-bit, and info may be NULL. */
  uint16_t* wide = (uint16_t*)malloc(sizeof(uint16_t) * W * H);
  for (size_t i = 0; i < (size_t)W * H; ++i) wide[i] = (uint16_t)(pixels[i] * 16);
  CHECK_STATUS(svms_process_frame_multi_u16(e, wide, W, H, 2 * W, 6, poses, 2, NULL), SVMS_OK);
  CHECK(poses[0].valid && poses[1].valid);
  free(wide);
  /* n_poses must be the number of layouts. */
  CHECK_STATUS(svms_process_frame_multi(e, pixels, W, H, W, 5, poses, 1, &info),
               SVMS_ERR_INVALID_ARGUMENT);
  CHECK(strstr(svms_last_error(), "n_poses is 1, expected the estimator's number of layouts, 2") !=
        NULL);
  CHECK(poses[0].valid == 0);
  /* A negative count is named as given. */
  CHECK_STATUS(svms_process_frame_multi(e, pixels, W, H, W, 5, poses, -3, &info),
               SVMS_ERR_INVALID_ARGUMENT);
  CHECK(strstr(svms_last_error(), "n_poses is -3, expected") != NULL);
  CHECK_STATUS(svms_process_frame_multi(e, pixels, W, H, W, 5, NULL, 2, &info),
               SVMS_ERR_NULL_ARGUMENT);
  CHECK_STATUS(svms_process_frame_multi(alone[0], pixels, W, H, W, 5, poses, 1, NULL), SVMS_OK);
  CHECK(poses[0].valid);

  /* The module's estimator told to detect every ID lists the fixture's markers as unassigned. */
  svms_estimator* every = NULL;
  CHECK_STATUS(svms_create_multi(cam, both, 1, NULL, SVMS_CREATE_UNKNOWN_IDS, &every), SVMS_OK);
  CHECK_STATUS(svms_process_frame_multi(every, pixels, W, H, W, 5, poses, 1, &info), SVMS_OK);
  CHECK(info.n_unassigned == 3);
  int sum = 0;
  for (int i = 0; i < info.n_unassigned && i < SVMS_MAX_REPORTED_MARKERS; ++i)
    sum += info.unassigned_ids[i];
  CHECK(sum == 30 + 31 + 32);
  CHECK_STATUS(svms_destroy(every), SVMS_OK);

  /* Creation errors: an ID in two layouts names both files and the ID; a missing file. */
  svms_estimator* bad = (svms_estimator*)0x1;
  const char* clashing[2] = {module, clash};
  CHECK_STATUS(svms_create_multi(cam, clashing, 2, NULL, 0, &bad), SVMS_ERR_FILE);
  CHECK(bad == NULL);
  CHECK(strstr(svms_last_error(), "clash_layout.json: marker ID 13 is also in ") != NULL);
  CHECK(strstr(svms_last_error(), module) != NULL);
  const char* missing[2] = {module, "/nonexistent/layout.json"};
  CHECK_STATUS(svms_create_multi(cam, missing, 2, NULL, 0, &bad), SVMS_ERR_FILE);
  CHECK(strstr(svms_last_error(), "/nonexistent/layout.json") != NULL);
  CHECK_STATUS(svms_create_multi(cam, both, 0, NULL, 0, &bad), SVMS_ERR_INVALID_ARGUMENT);
  CHECK_STATUS(svms_create_multi(cam, both, 2, NULL, 8u, &bad), SVMS_ERR_INVALID_ARGUMENT);
  CHECK_STATUS(svms_create_multi(cam, NULL, 2, NULL, 0, &bad), SVMS_ERR_NULL_ARGUMENT);
  const char* with_null[2] = {module, NULL};
  CHECK_STATUS(svms_create_multi(cam, with_null, 2, NULL, 0, &bad), SVMS_ERR_NULL_ARGUMENT);
  CHECK(strstr(svms_last_error(), "layout_paths[1]") != NULL);
  CHECK_STATUS(svms_layout_count(NULL, &n), SVMS_ERR_NULL_ARGUMENT);

  CHECK_STATUS(svms_destroy(e), SVMS_OK);
  CHECK_STATUS(svms_layout_count(e, &n), SVMS_ERR_BAD_HANDLE);
  CHECK_STATUS(svms_process_frame_multi(e, pixels, W, H, W, 5, poses, 2, NULL),
               SVMS_ERR_BAD_HANDLE);
  for (int i = 0; i < 2; ++i) svms_destroy(alone[i]);
  free(pixels);
}

/* svms_set_detection: two threads per frame give the reference pose to the bit, a 2 x 2 search
 * a pose as close to the truth; values out of range are refused by name, and keep the settings. */
static void CheckSetDetection(const svms_pose* reference, const double* truth) {
  CHECK_STATUS(svms_set_detection(NULL, 1, 1), SVMS_ERR_NULL_ARGUMENT);
  svms_estimator* est = NULL;
  CHECK_STATUS(svms_create(camera_path, layout_path, NULL, &est), SVMS_OK);
  svms_pose p;
  CHECK_STATUS(svms_set_detection(est, 1, 2), SVMS_OK);
  CHECK_STATUS(svms_process_frame(est, frame, W, H, W, 1.1, &p), SVMS_OK);
  CHECK(p.valid && memcmp(p.tvec, reference->tvec, sizeof p.tvec) == 0);
  CHECK(memcmp(p.covariance, reference->covariance, sizeof p.covariance) == 0);
  CHECK_STATUS(svms_set_detection(est, 2, 1), SVMS_OK);
  CHECK_STATUS(svms_process_frame(est, frame, W, H, W, 1.1, &p), SVMS_OK);
  CHECK(p.valid && p.markers_used == reference->markers_used);
  /* The 2 x 2 search took effect: its quads' corners start the fits elsewhere. */
  CHECK(memcmp(p.tvec, reference->tvec, sizeof p.tvec) != 0);
  double dt = 0;
  for (int i = 0; i < 3; ++i) dt += (p.tvec[i] - truth[3 + i]) * (p.tvec[i] - truth[3 + i]);
  CHECK(sqrt(dt) < 0.16e-3); /* the full search's limit (main) */
  CHECK_STATUS(svms_set_detection(est, 5, 1), SVMS_ERR_INVALID_ARGUMENT);
  CHECK(strstr(svms_last_error(), "svms_set_detection: decimate: expected 1 to 4, got 5") != NULL);
  CHECK_STATUS(svms_set_detection(est, 1, 0), SVMS_ERR_INVALID_ARGUMENT);
  CHECK(strstr(svms_last_error(), "frame_threads") != NULL);
  svms_pose kept;
  CHECK_STATUS(svms_process_frame(est, frame, W, H, W, 1.1, &kept), SVMS_OK);
  CHECK(kept.valid && memcmp(kept.tvec, p.tvec, sizeof p.tvec) == 0); /* still 2 x 2 */
  CHECK_STATUS(svms_destroy(est), SVMS_OK);
  CHECK_STATUS(svms_set_detection(est, 1, 1), SVMS_ERR_BAD_HANDLE);
}

int main(int argc, char** argv) {
  if (argc != 2) {
    fprintf(stderr, "usage: svms_capi_c_test FIXTURE_DIR\n");
    return 2;
  }
  char path[4096];
  fixture_dir = argv[1];
  snprintf(camera_path, sizeof camera_path, "%s/true.cameramodel", argv[1]);
  snprintf(layout_path, sizeof layout_path, "%s/true_layout.json", argv[1]);
  snprintf(path, sizeof path, "%s/frame_11.raw", argv[1]);
  frame = ReadRaw(path, (size_t)W * H);
  double truth[6];
  snprintf(path, sizeof path, "%s/frame_11.txt", argv[1]);
  FILE* tf = fopen(path, "r");
  CHECK(tf && fscanf(tf, "%lf %lf %lf %lf %lf %lf", &truth[0], &truth[1], &truth[2], &truth[3],
                     &truth[4], &truth[5]) == 6);
  if (tf) fclose(tf);

  CHECK(strlen(svms_version()) >= 5);
  CHECK(strcmp(svms_status_string(SVMS_ERR_BAD_HANDLE), "SVMS_ERR_BAD_HANDLE") == 0);

  /* Creation errors. */
  svms_estimator* est = (svms_estimator*)0x1;
  CHECK_STATUS(svms_create(camera_path, layout_path, NULL, NULL), SVMS_ERR_NULL_ARGUMENT);
  CHECK_STATUS(svms_create(NULL, layout_path, NULL, &est), SVMS_ERR_NULL_ARGUMENT);
  CHECK(est == NULL);
  CHECK(strstr(svms_last_error(), "camera_path") != NULL);
  CHECK_STATUS(svms_create("/nonexistent/cam.cameramodel", layout_path, NULL, &est), SVMS_ERR_FILE);
  CHECK(strstr(svms_last_error(), "/nonexistent/cam.cameramodel") != NULL);
  CHECK_STATUS(svms_create(camera_path, camera_path, NULL, &est), SVMS_ERR_FILE);
  svms_options bad;
  svms_options_default(&bad);
  CHECK(bad.corner_sigma_px > 0 && bad.budget_ms == 0);
  bad.corner_sigma_px = -1;
  CHECK_STATUS(svms_create(camera_path, layout_path, &bad, &est), SVMS_ERR_INVALID_ARGUMENT);
  bad.corner_sigma_px = 0.1;
  bad.budget_ms = NAN;
  CHECK_STATUS(svms_create(camera_path, layout_path, &bad, &est), SVMS_ERR_INVALID_ARGUMENT);

  /* A pose against the truth. */
  CHECK_STATUS(svms_create(camera_path, layout_path, NULL, &est), SVMS_OK);
  svms_pose pose;
  CHECK_STATUS(svms_process_frame(est, frame, W, H, W, 1.1, &pose), SVMS_OK);
  CHECK(pose.valid == 1);
  CHECK(pose.timestamp == 1.1);
  CHECK(pose.markers_used >= 2 && pose.markers_used <= pose.markers_seen);
  CHECK(pose.points_used >= 4 * pose.markers_used);
  CHECK(pose.dof >= 2 * pose.points_used - 6 &&
        pose.dof <= 2 * pose.points_used - 6 + 6 * pose.markers_used);
  const double range = sqrt(truth[3] * truth[3] + truth[4] * truth[4] + truth[5] * truth[5]);
  double dt = 0;
  for (int i = 0; i < 3; ++i) dt += (pose.tvec[i] - truth[3 + i]) * (pose.tvec[i] - truth[3 + i]);
  /* Measured on this frame (approach view 11, 2.25 m): 0.107 mm and 0.0054 degrees; the limits
   * are 1.5 times those, so a 2x loss of accuracy fails. */
  CHECK(sqrt(dt) < 0.16e-3);
  const double a = sqrt(truth[0] * truth[0] + truth[1] * truth[1] + truth[2] * truth[2]);
  const double qt[4] = {cos(a / 2), sin(a / 2) * truth[0] / a, sin(a / 2) * truth[1] / a,
                        sin(a / 2) * truth[2] / a};
  double dot = 0, qn = 0;
  for (int i = 0; i < 4; ++i)
    dot += qt[i] * pose.quaternion[i], qn += pose.quaternion[i] * pose.quaternion[i];
  CHECK(fabs(qn - 1) < 1e-9);
  CHECK(2 * acos(fmin(1, fabs(dot))) < 0.008 * 3.14159265358979 / 180);
  for (int r = 0; r < 6; ++r) {
    CHECK(pose.covariance[r * 6 + r] > 0);
    for (int c = 0; c < 6; ++c) CHECK(pose.covariance[r * 6 + c] == pose.covariance[c * 6 + r]);
  }
  CHECK(pose.latency_ms > 0);
  CHECK((pose.flags & SVMS_FLAG_CALIBRATION_IN_COVARIANCE) == 0);
  for (int i = 0; i < 36; ++i) CHECK(pose.covariance_common[i] == 0);
  CHECK((pose.flags & SVMS_FLAG_AMBIGUOUS) == 0 && pose.has_alternative == 0);
  CHECK(pose.alternative_weight == 0);

  /* A lone flat marker whose two planar poses the detector cannot tell apart, and where it
   * keeps the wrong one: flagged, with the right one as the alternative. */
  CheckLoneAmbiguousMarker();

  /* A camera with its calibration's covariance (cal.cameramodel.covariance.json): the same
   * pose, flagged, with a wider covariance. */
  char cal_path[4096];
  snprintf(cal_path, sizeof cal_path, "%s/cal.cameramodel", fixture_dir);
  svms_estimator* calibrated = NULL;
  CHECK_STATUS(svms_create(cal_path, layout_path, NULL, &calibrated), SVMS_OK);
  svms_pose pc;
  CHECK_STATUS(svms_process_frame(calibrated, frame, W, H, W, 1.1, &pc), SVMS_OK);
  CHECK(pc.valid && (pc.flags & SVMS_FLAG_CALIBRATION_IN_COVARIANCE) != 0);
  CHECK(memcmp(pc.tvec, pose.tvec, sizeof pose.tvec) == 0);
  for (int r = 0; r < 6; ++r) CHECK(pc.covariance[r * 6 + r] > pose.covariance[r * 6 + r]);
  /* Its factor: B B^T is covariance_common; asked with too little room, the call says how much. */
  {
    int k = -1;
    CHECK_STATUS(svms_last_bias_factor(calibrated, 0, NULL, 0, &k), SVMS_OK); /* size query */
    CHECK(k > 0 && k <= 64);
    double B[6 * 64];
    int k1 = -1;
    B[0] = 12345;
    CHECK_STATUS(svms_last_bias_factor(calibrated, 0, B, k - 1, &k1), SVMS_ERR_INVALID_ARGUMENT);
    CHECK(k1 == k && B[0] == 12345); /* too little room: nothing written, k said */
    CHECK_STATUS(svms_last_bias_factor(calibrated, 0, B, -1, &k1), SVMS_ERR_INVALID_ARGUMENT);
    int k2 = -1;
    CHECK_STATUS(svms_last_bias_factor(calibrated, 0, B, 64, &k2), SVMS_OK);
    CHECK(k2 == k);
    for (int r = 0; r < 6; ++r)
      for (int c = 0; c < 6; ++c) {
        double bb = 0;
        for (int j = 0; j < k; ++j) bb += B[j * 6 + r] * B[j * 6 + c];
        CHECK(fabs(bb - pc.covariance_common[r * 6 + c]) <= 1e-12 * pc.covariance[r * 6 + r]);
      }
    CHECK_STATUS(svms_last_bias_factor(calibrated, 1, B, 64, &k2), SVMS_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(svms_last_bias_factor(calibrated, 0, B, 64, NULL), SVMS_ERR_NULL_ARGUMENT);
    int k0 = -1;
    CHECK_STATUS(svms_last_bias_factor(est, 0, B, 64, &k0), SVMS_OK); /* no calibration's */
    CHECK(k0 == 0);
    /* A call that failed leaves no last frame: k is 0 after it, not the frame before's. */
    CHECK_STATUS(svms_process_frame(calibrated, frame, W - 1, H, W, 1.2, &pc),
                 SVMS_ERR_INVALID_ARGUMENT);
    CHECK_STATUS(svms_last_bias_factor(calibrated, 0, B, 64, &k0), SVMS_OK);
    CHECK(k0 == 0);
    CHECK_STATUS(svms_process_frame(calibrated, frame, W, H, W, 1.1, &pc), SVMS_OK);
  }
  /* The widening is the calibration's share, common to every frame: what it adds. */
  for (int r = 0; r < 6; ++r) {
    CHECK(pc.covariance_common[r * 6 + r] > 0);
    for (int c = 0; c < 6; ++c)
      CHECK(fabs(pc.covariance[r * 6 + c] - pc.covariance_common[r * 6 + c] -
                 pose.covariance[r * 6 + c]) <= 1e-9 * pc.covariance[r * 6 + r]);
  }
  svms_destroy(calibrated);
  {
    int k = -1;
    CHECK_STATUS(svms_last_bias_factor(calibrated, 0, NULL, 0, &k), SVMS_ERR_BAD_HANDLE);
    CHECK(k == 0);
  }
  /* A sidecar whose covariance overflows, and a layout with a duplicate key: refused at load. */
  char over_path[4096], dup_path[4096];
  snprintf(over_path, sizeof over_path, "%s/overflow.cameramodel", fixture_dir);
  snprintf(dup_path, sizeof dup_path, "%s/dup_layout.json", fixture_dir);
  svms_estimator* refused = (svms_estimator*)0x1;
  CHECK_STATUS(svms_create(over_path, layout_path, NULL, &refused), SVMS_ERR_FILE);
  CHECK(refused == NULL);
  CHECK(strstr(svms_last_error(), "overflows") != NULL);
  CHECK_STATUS(svms_create(camera_path, dup_path, NULL, &refused), SVMS_ERR_FILE);
  CHECK(strstr(svms_last_error(), "markers[0].object_from_marker: the field appears twice") !=
        NULL);

  /* The same pixels with padded rows, and as 16 bits. */
  const ptrdiff_t stride = W + 77;
  unsigned char* padded = (unsigned char*)calloc((size_t)stride * H, 1);
  unsigned short* wide = (unsigned short*)malloc((size_t)W * H * 2);
  for (int y = 0; y < H; ++y) {
    memcpy(padded + y * stride, frame + y * W, W);
    for (int x = 0; x < W; ++x) wide[y * W + x] = (unsigned short)(frame[y * W + x] * 257);
  }
  svms_pose p2;
  CHECK_STATUS(svms_process_frame(est, padded, W, H, stride, 1.1, &p2), SVMS_OK);
  CHECK(p2.valid && memcmp(p2.tvec, pose.tvec, sizeof pose.tvec) == 0);
  CHECK_STATUS(svms_process_frame_u16(est, wide, W, H, 2 * W, 1.1, &p2), SVMS_OK);
  CHECK(p2.valid && fabs(p2.tvec[2] - pose.tvec[2]) < 0.01);

  /* Bad frames: defined errors, *out cleared. */
  CHECK_STATUS(svms_process_frame(est, frame, W - 1, H, W, 0, &p2), SVMS_ERR_INVALID_ARGUMENT);
  CHECK(p2.valid == 0);
  CHECK(strstr(svms_last_error(), "1023x1024") != NULL);
  CHECK_STATUS(svms_process_frame(est, frame, W, H, W - 1, 0, &p2), SVMS_ERR_INVALID_ARGUMENT);
  CHECK_STATUS(svms_process_frame(est, frame, -5, H, W, 0, &p2), SVMS_ERR_INVALID_ARGUMENT);
  CHECK_STATUS(svms_process_frame_u16(est, wide, W, H, 2 * W + 1, 0, &p2),
               SVMS_ERR_INVALID_ARGUMENT);
  CHECK_STATUS(svms_process_frame(est, frame, W, H, W, NAN, &p2), SVMS_ERR_INVALID_ARGUMENT);
  CHECK_STATUS(svms_process_frame(est, NULL, W, H, W, 0, &p2), SVMS_ERR_NULL_ARGUMENT);
  CHECK_STATUS(svms_process_frame(est, frame, W, H, W, 0, NULL), SVMS_ERR_NULL_ARGUMENT);
  CHECK_STATUS(svms_process_frame(NULL, frame, W, H, W, 0, &p2), SVMS_ERR_NULL_ARGUMENT);
  /* Nothing to see: OK, no pose. */
  unsigned char* black = (unsigned char*)calloc((size_t)W * H, 1);
  CHECK_STATUS(svms_process_frame(est, black, W, H, W, 2, &p2), SVMS_OK);
  CHECK(p2.valid == 0 && p2.markers_seen == 0 && p2.timestamp == 2);

  /* A budget that cannot be met: flagged, never a crash. */
  svms_options tight;
  svms_options_default(&tight);
  tight.budget_ms = 1e-6;
  svms_estimator* hurried = NULL;
  CHECK_STATUS(svms_create(camera_path, layout_path, &tight, &hurried), SVMS_OK);
  CHECK_STATUS(svms_process_frame(hurried, frame, W, H, W, 3, &p2), SVMS_OK);
  CHECK((p2.flags & SVMS_FLAG_BUDGET_EXCEEDED) != 0);
  CHECK_STATUS(svms_destroy(hurried), SVMS_OK);

  /* After destroy, and handles that never were. */
  CHECK_STATUS(svms_destroy(est), SVMS_OK);
  CHECK_STATUS(svms_process_frame(est, frame, W, H, W, 0, &p2), SVMS_ERR_BAD_HANDLE);
  CHECK_STATUS(svms_destroy(est), SVMS_ERR_BAD_HANDLE);
  CHECK_STATUS(svms_destroy(NULL), SVMS_OK);
  double not_an_estimator[16] = {0};
  CHECK_STATUS(svms_process_frame((svms_estimator*)not_an_estimator, frame, W, H, W, 0, &p2),
               SVMS_ERR_BAD_HANDLE);

  /* One handle per thread, two threads at once: the same answer as alone. */
  pthread_t threads[2];
  ThreadResult results[2];
  for (int i = 0; i < 2; ++i) CHECK(pthread_create(&threads[i], NULL, Worker, &results[i]) == 0);
  for (int i = 0; i < 2; ++i) pthread_join(threads[i], NULL);
  for (int i = 0; i < 2; ++i) {
    CHECK(results[i].status == SVMS_OK);
    CHECK(results[i].pose.valid && memcmp(results[i].pose.tvec, pose.tvec, sizeof pose.tvec) == 0);
  }

  /* One handle, two threads: BUSY, not a crash; each thread's own last error. */
  CheckSharedHandle();

  CheckTwoObjects();

  CheckSetDetection(&pose, truth);

  free(frame);
  free(padded);
  free(wide);
  free(black);
  if (failures) {
    fprintf(stderr, "svms_capi_c_test: %d checks failed\n", failures);
    return 1;
  }
  printf("svms_capi_c_test: all checks passed (pose within %.2f mm of the truth at %.2f m)\n",
         1000 * sqrt(dt), range);
  return 0;
}

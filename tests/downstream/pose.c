/* A C program that uses an installed SVMS through pkg-config (tests/downstream_test.sh):
 *   cc pose.c $(pkg-config --cflags --libs svms) -lm
 * It runs the fused pose on the demo frame the C API fixture rendered (capi/tests/
 * capi_fixture.cc: frame_0.raw, 1024 x 1024, 8-bit; frame_0.txt, the true cam_from_object) and
 * exits 0 only if each position axis lies within 5 of its sigmas of the truth and the covariance
 * is a symmetric matrix with a positive diagonal. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <svms/svms.h>

int main(int argc, char** argv) {
  if (argc != 2) {
    fprintf(stderr, "usage: %s FIXTURE_DIR\n", argv[0]);
    return 2;
  }
  char camera[4096], layout[4096], raw[4096], txt[4096];
  snprintf(camera, sizeof camera, "%s/true.cameramodel", argv[1]);
  snprintf(layout, sizeof layout, "%s/true_layout.json", argv[1]);
  snprintf(raw, sizeof raw, "%s/frame_0.raw", argv[1]);
  snprintf(txt, sizeof txt, "%s/frame_0.txt", argv[1]);
  enum { W = 1024, H = 1024 };
  unsigned char* frame = malloc((size_t)W * H);
  double truth[6];
  FILE* f = fopen(raw, "rb");
  FILE* t = fopen(txt, "r");
  if (!frame || !f || fread(frame, 1, (size_t)W * H, f) != (size_t)W * H || !t ||
      fscanf(t, "%lf %lf %lf %lf %lf %lf", &truth[0], &truth[1], &truth[2], &truth[3], &truth[4],
             &truth[5]) != 6) {
    fprintf(stderr, "cannot read the fixture in %s\n", argv[1]);
    return 2;
  }
  fclose(f);
  fclose(t);
  svms_estimator* e = NULL;
  svms_status s = svms_create(camera, layout, NULL, &e);
  if (s != SVMS_OK) {
    fprintf(stderr, "svms_create: %s: %s\n", svms_status_string(s), svms_last_error());
    return 1;
  }
  svms_pose p;
  s = svms_process_frame(e, frame, W, H, W, 0.0, &p);
  svms_destroy(e);
  free(frame);
  if (s != SVMS_OK || !p.valid) {
    fprintf(stderr, "svms_process_frame: %s: %s\n", svms_status_string(s), svms_last_error());
    return 1;
  }
  int ok = 1;
  for (int i = 0; i < 3; ++i) {
    const double d = p.tvec[i] - truth[3 + i];
    ok &= d * d < 25 * p.covariance[(3 + i) * 6 + 3 + i];
  }
  for (int r = 0; r < 6; ++r) {
    ok &= p.covariance[r * 6 + r] > 0;
    for (int c = 0; c < 6; ++c) ok &= p.covariance[r * 6 + c] == p.covariance[c * 6 + r];
  }
  printf(
      "svms %s: %d markers, tvec %.4f %.4f %.4f m (truth %.4f %.4f %.4f), sigma_z %.2f mm -> %s\n",
      svms_version(), p.markers_used, p.tvec[0], p.tvec[1], p.tvec[2], truth[3], truth[4], truth[5],
      1e3 * sqrt(p.covariance[35]), ok ? "ok" : "WRONG");
  return ok ? 0 : 1;
}

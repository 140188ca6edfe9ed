/* SVMS C API: the fused object pose of each camera frame, for flight-like software.
 *
 * C99, no exceptions cross this boundary, every call returns a status code and never aborts.
 * Frames, units and the covariance convention: docs/flight-interface.md.
 *
 *   svms_estimator* est = NULL;
 *   if (svms_create("cam.cameramodel", "layout.json", NULL, &est) != SVMS_OK)
 *     fprintf(stderr, "%s\n", svms_last_error());
 *   svms_pose pose;
 *   svms_status s = svms_process_frame(est, pixels, 1024, 1024, 1024, t, &pose);
 *   if (s == SVMS_OK && pose.valid) use(pose.tvec, pose.covariance);
 *   svms_destroy(est);
 *
 * Threads: one estimator per thread. Several estimators may run at once in different threads;
 * two calls on the same estimator at the same time get SVMS_ERR_BUSY for the second.
 * A destroyed estimator stays detectable: any call through it returns SVMS_ERR_BAD_HANDLE
 * (its 32-byte shell is kept for the life of the process for that purpose).
 *
 * Several objects in one camera (a docking target and a reference fixture): svms_create_multi
 * takes one layout per object, and svms_process_frame_multi detects the frame once and gives
 * one svms_pose per layout, each what a single-layout estimator of that object would give.
 *
 * Several cameras on one vehicle (a camera rig, docs/conventions.md "Camera rigs"):
 * svms_create_rig reads a rig file, and svms_process_rig_frame (svms_process_rig_frame_u16 for
 * 16-bit frames) takes one frame per camera taken at one time stamp and gives one svms_pose
 * whose pose is rig_from_object.
 */
#ifndef SVMS_SVMS_H_
#define SVMS_SVMS_H_

#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef enum svms_status {
  SVMS_OK = 0,
  SVMS_ERR_NULL_ARGUMENT = 1,    /* a required pointer is NULL */
  SVMS_ERR_INVALID_ARGUMENT = 2, /* a size, stride or option out of range */
  SVMS_ERR_FILE = 3,             /* the camera model or layout cannot be read or is invalid */
  SVMS_ERR_BAD_HANDLE = 4,       /* not an estimator from svms_create, or destroyed */
  SVMS_ERR_BUSY = 5,             /* the estimator is in use by another thread */
  SVMS_ERR_INTERNAL = 6          /* an unexpected failure inside (out of memory, a bug) */
} svms_status;

/* Flags of a pose (svms_pose.flags). */
#define SVMS_FLAG_AMBIGUOUS 1u /* one marker, and its two planar poses could not be told apart */
#define SVMS_FLAG_POORLY_CONDITIONED \
  2u                                 /* rotation sigma > 1 deg or position sigma > 2 % of range */
#define SVMS_FLAG_BUDGET_EXCEEDED 4u /* the time budget ran out: the markers found until then */
#define SVMS_FLAG_MARKER_REJECTED 8u /* a marker was inconsistent with the others and left out */
/* The covariance includes the camera calibration's uncertainty (CAMERA.covariance.json, written
 * by svms calibrate, was next to the camera model). */
#define SVMS_FLAG_CALIBRATION_IN_COVARIANCE 16u
/* A rig's pose: the covariance includes the cameras' rig_from_cam uncertainty (the rig file
 * gave a covariance for some camera). */
#define SVMS_FLAG_EXTRINSICS_IN_COVARIANCE 32u
/* The pose rests on one marker and is that marker's own pose, which also fitted its stripe's
 * and decal's outer edges (with the layout's uncertainty added to its covariance). */
#define SVMS_FLAG_MARKER_POSE_WITH_EDGES 64u

#define SVMS_MAX_REPORTED_MARKERS 32

typedef struct svms_options {
  double corner_sigma_px; /* pixel noise of a detected corner, each axis (default 0.1) */
  double budget_ms;       /* time budget per frame, milliseconds, the conversion to linear light
                           * included; 0: none (default 0) */
} svms_options;

typedef struct svms_pose {
  double timestamp; /* as given to svms_process_frame */
  int valid;        /* 1: the fields below hold a pose; 0: no pose this frame */
  /* cam_from_object: p_cam = R p_object + t (metres). rvec: axis * angle (radians);
   * quaternion: [w, x, y, z] of the same rotation. */
  double rvec[3];
  double tvec[3];
  double quaternion[4];
  /* 6x6 row-major, ordered [rotation(3), translation(3)]: the rotation a small angle about the
   * camera axes (rad^2), the translation of tvec (m^2). Includes image noise and the layout's
   * own uncertainty, and the camera calibration's with SVMS_FLAG_CALIBRATION_IN_COVARIANCE. */
  double covariance[36];
  int markers_seen;                          /* markers of the layout detected */
  int markers_used;                          /* after rejection */
  int points_used;                           /* corners and post tips in the fit */
  int marker_ids[SVMS_MAX_REPORTED_MARKERS]; /* IDs used (the first SVMS_MAX_REPORTED_MARKERS) */
  double rms_px;                             /* RMS pixel residual, per coordinate */
  double chi2;                               /* whitened residual sum of squares */
  /* 2 * points_used + the rows of the markers' stripe and decal edge quadratics (at most 6 a
   * marker) - 6 */
  int dof;
  uint32_t flags;    /* SVMS_FLAG_* */
  double latency_ms; /* the whole frame: conversion to linear light, detection, fusion */
  /* With SVMS_FLAG_AMBIGUOUS, where the one marker's other planar pose is known
   * (has_alternative = 1): cam_from_object under that pose, as rvec, tvec and quaternion above,
   * and its share of the likelihood, in (0.01, 0.5]. A filter can carry both hypotheses until a
   * second marker or a closer view settles them. Added in 0.2.0 (svms_pose grew: rebuild). */
  int has_alternative;
  double alternative_rvec[3];
  double alternative_tvec[3];
  double alternative_quaternion[4];
  double alternative_weight;
  /* The share of `covariance` that is one error common to every frame (the camera
   * calibration's with SVMS_FLAG_CALIBRATION_IN_COVARIANCE, a rig's extrinsics' with
   * SVMS_FLAG_EXTRINSICS_IN_COVARIANCE; zero without either), 6x6 row-major as `covariance`.
   * covariance - covariance_common is the frame's own noise and the layout's error (which is
   * also the same in every frame, but not given apart: docs/flight-interface.md). A filter that
   * fuses frames must treat the common part as a bias (one draw for the whole sequence), not
   * average it down; its factor, whose columns keep their meaning from frame to frame (so two
   * frames' common errors are correlated by B_f B_g^T), comes from svms_last_bias_factor
   * (svms_last_rig_bias_factor for a rig). Added in 0.4.0 (svms_pose grew: rebuild). */
  double covariance_common[36];
  double reserved[8]; /* zero; room for fields a later minor version adds without a new layout */
} svms_pose;

/* What one frame of svms_process_frame_multi gives besides the objects' poses. */
typedef struct svms_frame_info {
  double timestamp;  /* as given */
  double latency_ms; /* the whole frame: linear light, the detection, every layout's fusion */
  double detect_ms;  /* the frame's one detection pass (shared by every layout) */
  double fuse_ms;    /* every layout's fusion together */
  uint32_t flags;    /* SVMS_FLAG_BUDGET_EXCEEDED, for the frame */
  int n_unassigned;  /* detections of no layout (all of them, even beyond the array below);
                        only with SVMS_CREATE_UNKNOWN_IDS, else the detector reports the
                        layouts' IDs only and this is 0 */
  int unassigned_ids[SVMS_MAX_REPORTED_MARKERS]; /* their IDs, the first SVMS_MAX_REPORTED_MARKERS
                                                  */
  double reserved[8]; /* zero; room for fields a later minor version adds without a new layout */
} svms_frame_info;

/* Flags of svms_create_multi. */
/* Detect markers of every ID, not only the layouts' ones, so that svms_frame_info lists those
 * of no layout. Off, the detector ignores other IDs, which keeps a random quadrilateral from
 * decoding as a marker nobody asked for. */
#define SVMS_CREATE_UNKNOWN_IDS 1u

typedef struct svms_estimator svms_estimator;

/* Defaults for svms_options. */
void svms_options_default(svms_options* options);

/* Creates an estimator from an mrcal .cameramodel and a surveyed layout (svms survey --out).
 * `options` may be NULL (defaults). On failure *out is NULL and svms_last_error() says why. */
svms_status svms_create(const char* camera_path, const char* layout_path,
                        const svms_options* options, svms_estimator** out);

/* An estimator of several objects from one camera, one layout each: `layout_paths` holds
 * `n_layouts` (>= 1) paths. A marker ID (outer or inner) may be in one layout only: an ID in two
 * layouts is SVMS_ERR_FILE, and svms_last_error() names both files and the ID. `create_flags`:
 * 0 or SVMS_CREATE_UNKNOWN_IDS. With one layout and no flag it is svms_create. */
svms_status svms_create_multi(const char* camera_path, const char* const* layout_paths,
                              int n_layouts, const svms_options* options, uint32_t create_flags,
                              svms_estimator** out);

/* The number of layouts (objects) of an estimator: 1 for svms_create's. */
svms_status svms_layout_count(const svms_estimator* estimator, int* n_layouts);

/* One frame of 8-bit grey pixels, `width` x `height`, rows `stride` bytes apart (stride >=
 * width). The size must be the camera model's. No copy is made of the pixels. *out is always
 * written (valid = 0 when there is no pose). */
svms_status svms_process_frame(svms_estimator* estimator, const uint8_t* pixels, int width,
                               int height, ptrdiff_t stride, double timestamp, svms_pose* out);

/* The same for 16-bit grey pixels (stride in bytes, >= 2 * width). */
svms_status svms_process_frame_u16(svms_estimator* estimator, const uint16_t* pixels, int width,
                                   int height, ptrdiff_t stride, double timestamp, svms_pose* out);

/* svms_process_frame and svms_process_frame_u16 of an estimator of several layouts give the
 * first layout's object. These give every object from the frame's one detection: poses[i] is
 * the object of layout i (svms_create_multi's order); `n_poses` must be the number of layouts
 * (svms_layout_count), else SVMS_ERR_INVALID_ARGUMENT. Each pose's flags carry the frame's
 * SVMS_FLAG_BUDGET_EXCEEDED, its latency_ms the whole frame's. `info` may be NULL. The poses
 * (and info) are always written, as by svms_process_frame. */
svms_status svms_process_frame_multi(svms_estimator* estimator, const uint8_t* pixels, int width,
                                     int height, ptrdiff_t stride, double timestamp,
                                     svms_pose* poses, int n_poses, svms_frame_info* info);
svms_status svms_process_frame_multi_u16(svms_estimator* estimator, const uint16_t* pixels,
                                         int width, int height, ptrdiff_t stride, double timestamp,
                                         svms_pose* poses, int n_poses, svms_frame_info* info);

/* A camera rig's estimator (svms_create_rig). */
typedef struct svms_rig_estimator svms_rig_estimator;

/* One camera's frame of a rig: 8-bit grey pixels, `width` x `height`, rows `stride` bytes apart
 * (stride >= width), the size of that camera's model. pixels NULL: that camera has no frame
 * this time. */
typedef struct svms_rig_frame {
  const uint8_t* pixels;
  int width;
  int height;
  ptrdiff_t stride;
} svms_rig_frame;

/* Creates a rig's estimator from a rig file (*.rig: its cameras' models, their rig_from_cam
 * and its covariance) and a surveyed layout. `options` may be NULL. On failure *out is NULL and
 * svms_last_error() names the file and field. */
svms_status svms_create_rig(const char* rig_path, const char* layout_path,
                            const svms_options* options, svms_rig_estimator** out);

/* The number of cameras of a rig's estimator (the rig file's order). */
svms_status svms_rig_camera_count(const svms_rig_estimator* estimator, int* n_cameras);

/* The frames of every camera at one time stamp: frames[c] is camera c's, n_frames must be the
 * number of cameras (else SVMS_ERR_INVALID_ARGUMENT). *out is always written: its rvec, tvec
 * and quaternion are rig_from_object (p_rig = R p_object + t), its covariance [rotation,
 * translation] with the rotation about the RIG axes; marker_ids lists the markers used by any
 * camera (a marker seen by two cameras twice); latency_ms covers every camera. Flags as for
 * one camera, plus SVMS_FLAG_EXTRINSICS_IN_COVARIANCE. One estimator per thread, as above. */
svms_status svms_process_rig_frame(svms_rig_estimator* estimator, const svms_rig_frame* frames,
                                   int n_frames, double timestamp, svms_pose* out);

/* One camera's frame of a rig in 16-bit grey pixels (a raw frame as its camera stores it, for
 * instance 12 bits in 16; the camera model's photometry says how its values map to light, as
 * for svms_process_frame_u16): as svms_rig_frame, rows `stride` bytes apart (stride >= 2 *
 * width, even). pixels NULL: that camera has no frame this time. Added in 0.4.1. */
typedef struct svms_rig_frame_u16 {
  const uint16_t* pixels;
  int width;
  int height;
  ptrdiff_t stride;
} svms_rig_frame_u16;

/* svms_process_rig_frame for 16-bit frames: the same checks, pose and flags. Added in 0.4.1: a
 * program that calls it needs libsvms_c 0.4.1 or later, whose soname is 0.4's (check
 * svms_version(), or link with -z now so that an older library is refused at start). */
svms_status svms_process_rig_frame_u16(svms_rig_estimator* estimator,
                                       const svms_rig_frame_u16* frames, int n_frames,
                                       double timestamp, svms_pose* out);

/* How the estimator searches each frame for markers (docs/detector.md, docs/flight-interface.md):
 * `decimate` 1 to 4 finds the edges and quads of steps 1-4 on the frame averaged over decimate x
 * decimate blocks, as AprilTag's quad_decimate (1, the default: full resolution; 2 is several
 * times faster on textured frames and loses most markers under about 16 px; corners and poses
 * still come from the full frame); `frame_threads` 1 to 64 threads share each frame (1, the
 * default; every count gives the same poses unless a budget runs out, docs/benchmarks.md says
 * what two threads gain).
 * Between frames: a call while another thread processes a frame through the same estimator is
 * SVMS_ERR_BUSY. A value out of range is SVMS_ERR_INVALID_ARGUMENT, svms_last_error() names it,
 * and the estimator keeps its settings. Starts the threads, so it allocates: call it before the
 * loop, and give a warm-up frame after it. For a rig, every camera takes the values; where
 * starting a camera's threads fails (SVMS_ERR_INTERNAL) the cameras before it may have taken
 * them: destroy the estimator. Added in 0.4.2. */
svms_status svms_set_detection(svms_estimator* estimator, int decimate, int frame_threads);
svms_status svms_set_rig_detection(svms_rig_estimator* estimator, int decimate, int frame_threads);

/* The factor B of the last processed frame's covariance_common for layout `object` (0 for a
 * single-layout handle): covariance_common = B B^T, B 6 x k, written column-major into
 * out[0 .. 6 k), k into *columns. Column j is the same error (one component of the camera
 * calibration's or a rig camera's extrinsics' error, unit variance) in every frame of the
 * handle, so the errors of two frames f and g share B_f B_g^T: what a filter needs to carry
 * the common error as one bias instead of noise (docs/flight-interface.md). k is 0 without a
 * calibration's or extrinsics' uncertainty, before the first frame, and after a frame without a
 * pose or a processing call that failed. out = NULL with capacity_columns = 0 asks for k only
 * (SVMS_OK); with 0 <= capacity_columns < k nothing is written to out, *columns is k and the
 * status SVMS_ERR_INVALID_ARGUMENT. No allocation but in wording an error. Added in 0.4.0. */
svms_status svms_last_bias_factor(svms_estimator* estimator, int object, double* out,
                                  int capacity_columns, int* columns);
svms_status svms_last_rig_bias_factor(svms_rig_estimator* estimator, int object, double* out,
                                      int capacity_columns, int* columns);

/* Destroys a rig's estimator; NULL is accepted (SVMS_OK). Like svms_destroy, a destroyed one
 * stays detectable (SVMS_ERR_BAD_HANDLE). */
svms_status svms_destroy_rig(svms_rig_estimator* estimator);

/* Destroys an estimator; NULL is accepted (SVMS_OK). */
svms_status svms_destroy(svms_estimator* estimator);

/* The message of the last failed call in this thread (never NULL; "" if none). Valid until the
 * next failing call in this thread. */
const char* svms_last_error(void);

/* A short name for a status ("SVMS_OK", ...). */
const char* svms_status_string(svms_status status);

/* The library's version, "MAJOR.MINOR.PATCH". */
const char* svms_version(void);

#ifdef __cplusplus
}
#endif

#endif /* SVMS_SVMS_H_ */

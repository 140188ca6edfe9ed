#!/usr/bin/env bash
# Real cameras through the svms binary (docs/conventions.md "Photometry"): the same
# views rendered through the linear, JPEG (libjpeg, sRGB) and 12-bit Bayer profiles are read
# back with the photometric model each file or camera declares; video files through OpenCV's
# VideoCapture with the container's time stamps; bad photometry options and videos refused.
# Usage: tests/real_cameras_test.sh path/to/svms
set -uo pipefail
svms=${1:?usage: real_cameras_test.sh SVMS}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "$0")/expect.sh"
cd "$tmp"
py=/usr/bin/python3  # Debian's, with numpy and OpenCV (python3-opencv)

for p in linear jpeg_srgb raw12_bayer; do
  "$svms" dataset range --quick --profile $p --out $p --quiet --threads 2 >/dev/null || { echo "dataset $p failed"; exit 1; }
done
cam=linear/true.cameramodel; markers=linear/markers.json
ls jpeg_srgb/*.jpg >/dev/null 2>&1 && pass || fail "jpeg_srgb rendered no .jpg files"

# detect LABEL OUT ARGS...: JSON lines into OUT.
detect() { local out=$1; shift; "$svms" detect "$@" --camera "$cam" --markers "$markers" --quiet > "$out" || fail "detect $* exited $?"; }
detect lin.jsonl linear/*.png && pass || fail "detect on the linear profile"
detect jpg.jsonl jpeg_srgb/*.jpg && pass || fail "detect on the JPEG profile"
detect bay.jsonl raw12_bayer/*.png --bayer RGGB --black-level 256 --white-level 4095 && pass || fail "detect on the Bayer profile"

# Each file says how it was read; the JPEG and raw poses agree with the linear ones.
"$py" - lin.jsonl jpg.jsonl bay.jsonl <<'PY' && pass || fail "the profiles disagree (see above)"
import json, sys
def load(f):
    return [json.loads(l) for l in open(f)]
lin, jpg, bay = (load(f) for f in sys.argv[1:4])
assert all(l["photometry"]["response"] == "linear" and l["photometry"]["source"] == "image" for l in lin), lin[0]["photometry"]
assert all(l["photometry"]["response"] == "srgb" and l["photometry"]["source"] == "image" for l in jpg), jpg[0]["photometry"]
assert all(l["photometry"]["bayer"] == "RGGB" and l["photometry"]["source"] == "option" for l in bay), bay[0]["photometry"]
n = 0
for a, b, c in zip(lin, jpg, bay):
    da = {d["id"]: d for d in a["detections"] if "cam_from_marker" in d}
    for other in (b, c):
        do = {d["id"]: d for d in other["detections"] if "cam_from_marker" in d}
        for i in set(da) & set(do):
            ta, to = da[i]["cam_from_marker"]["tvec"], do[i]["cam_from_marker"]["tvec"]
            r = sum(x * x for x in ta) ** 0.5
            err = sum((x - y) ** 2 for x, y in zip(ta, to)) ** 0.5
            # Within 0.5 % of the range, or within 3 sigma of the two poses' own position
            # uncertainty where that is larger (a marker of a few pixels: a JPEG's 8 px marker
            # at 16 m has a range sigma of 0.5 m).
            var = sum(da[i]["covariance"][k] + do[i]["covariance"][k] for k in (21, 28, 35))
            assert err < max(0.005 * r, 3 * var ** 0.5), (a["image"], i, ta, to, var ** 0.5)
            n += 1
found = sum(len(set(d["id"] for d in a["detections"] if "cam_from_marker" in d)) for a in lin)
assert n >= 0.8 * 2 * found, (n, found)  # each profile finds at least 80 % of linear's
PY
# Read as linear, the JPEG's gamma-encoded edges move the corners: its photometry matters.
detect jpg_as_linear.jsonl jpeg_srgb/*.jpg --response linear 2>/dev/null
"$py" - jpg.jsonl jpg_as_linear.jsonl <<'PY' && pass || fail "--response linear does not move the corners of sRGB images inward"
import json, sys
a = [json.loads(l) for l in open(sys.argv[1])]
b = [json.loads(l) for l in open(sys.argv[2])]
assert b[0]["photometry"]["source"] == "option" and b[0]["photometry"]["response"] == "linear"
# Read as linear, a gamma-encoded edge moves toward its dark side: the square shrinks.
inward = []
for p, q in zip(a, b):
    dq = {d["id"]: d for d in q["detections"]}
    for d in p["detections"]:
        if d["id"] not in dq: continue
        c0 = [sum(c[k] for c in d["corners"]) / 4 for k in (0, 1)]
        for c, f in zip(d["corners"], dq[d["id"]]["corners"]):
            out = [c[k] - c0[k] for k in (0, 1)]
            n = sum(x * x for x in out) ** 0.5
            inward.append(sum((c[k] - f[k]) * out[k] / n for k in (0, 1)))
assert len(inward) >= 20, len(inward)
mean = sum(inward) / len(inward)
assert mean > 0.03, mean
PY

# A declared response the edges contradict is a warning, on stderr and in the JSON line. On
# lossless sRGB files: a JPEG's blocks pull the estimate toward 1 (docs/detector.md).
"$svms" dataset range --quick --profile srgb8 --out srgb8 --quiet --threads 2 >/dev/null || { echo "dataset srgb8 failed"; exit 1; }
out=$("$svms" detect srgb8/*.png --response linear --quiet 2>&1 >/dev/null)
grep -q "warning: the response linear contradicts the image" <<<"$out" && pass || fail "no warning for --response linear on sRGB files: $out"
# A linear PNG that declares nothing (no gAMA chunk) is taken as sRGB by default: the edges
# contradict that; given --response linear they do not.
mkdir -p bare && "$py" -c "import cv2, glob, os
for f in glob.glob('linear/*.png'): cv2.imwrite('bare/' + os.path.basename(f), cv2.imread(f, 0))"
out=$("$svms" detect bare/*.png --camera "$cam" --markers "$markers" --quiet 2>&1 >/dev/null)
grep -q "warning: the response srgb contradicts the image" <<<"$out" && pass || fail "no warning for linear images taken as sRGB: $out"
out=$("$svms" detect bare/*.png --camera "$cam" --markers "$markers" --response linear --quiet 2>&1 >/dev/null)
! grep -q "contradicts" <<<"$out" && pass || fail "a warning on linear images read as linear: $out"
# Printed artwork (black and white pixels) says nothing about the curve: no warning.
"$svms" generate marker --id 3 --size 0.05 --dpi 150 --out art >/dev/null
out=$("$svms" detect art.png --response linear 2>&1 >/dev/null)
! grep -q "contradicts" <<<"$out" && pass || fail "a warning on binary artwork: $out"

# svms calibrate --response estimate on boards seen through a gamma-2.2 camera: the estimate,
# a calibration as good as on linear images, and the response stored with the camera.
"$svms" dataset calibration --quick --out cal --no-render >/dev/null
for r in linear gamma:2.2; do
  mkdir -p "cal_$r" && "$py" - cal/board/scene.json "cal_$r/scene.json" "$r" <<'PY'
import json, sys
s = json.load(open(sys.argv[1])); s["sensor"]["response"] = sys.argv[3]; s["sensor"]["defocus_sigma_px"] = 0.7
json.dump(s, open(sys.argv[2], "w"))
PY
  "$svms" render "cal_$r/scene.json" --out "cal_$r" --quiet >/dev/null
done
"$svms" calibrate cal_linear --board cal/board_layout.json --lensmodel LENSMODEL_OPENCV4 --out lin.cameramodel --quiet >/dev/null
out=$("$svms" calibrate "cal_gamma:2.2" --board cal/board_layout.json --lensmodel LENSMODEL_OPENCV4 --response estimate --out g22.cameramodel --report g22 --quiet 2>&1)
"$py" - g22/summary.json g22.cameramodel g22.cameramodel.photometric.json lin.cameramodel <<'PY' && pass || fail "calibrate --response estimate: $out"
import json, sys, mrcal
s = json.load(open(sys.argv[1]))
g = s["response_estimate"]["gamma"]
assert abs(g - 2.2) < 0.15, g  # 4 views: measured 2.15 +- 0.04 (48 views: docs/detector.md)
assert s["residuals_px"]["rms"] < 0.15, s["residuals_px"]
p = json.load(open(sys.argv[3]))
assert p["response"].startswith("gamma:"), p
a, b = mrcal.cameramodel(sys.argv[2]).intrinsics()[1], mrcal.cameramodel(sys.argv[4]).intrinsics()[1]
assert abs(a[0] - b[0]) < 0.003 * b[0], (a, b)  # the focal lengths agree within 0.3 %
# The edge bias is fitted with the estimate (calib/calibrate.h) and reported with its sigma.
e = s["edge_bias_px"]
assert 0 < e["sigma"] < 0.01 and abs(e["value"]) < 0.05, e
# ... and refines the curve that is stored (calibration_run.cc: RefineGammaFromEdgeBias).
r = s["response_refined"]
assert abs(r["gamma"] - 2.2) < max(0.01, 4 * r["sigma"]), r
assert abs(r["gamma"] - 2.2) < abs(g - 2.2), (r, g)
assert p["response"] == "gamma:%g" % r["gamma"] or abs(float(p["response"][6:]) - r["gamma"]) < 1e-4, p
PY
grep -q "^edge bias: " <<<"$out" && pass || fail "svms calibrate prints no edge bias: $out"
expect 2 '--edge-bias "sometimes": expected auto, on or off' "$svms" calibrate cal_linear --board cal/board_layout.json --edge-bias sometimes --out x.cameramodel
out=$("$svms" calibrate "cal_gamma:2.2" --board cal/board_layout.json --lensmodel LENSMODEL_OPENCV4 --response linear --out asl.cameramodel --quiet 2>&1 | head -1)
"$py" -c "import sys; rms = float(sys.argv[1].split('RMS ')[1].split()[0]); assert rms > 0.2, rms" "$out" && pass || fail "read as linear, the gamma boards should fit worse: $out"

# The camera's photometric file is used when there is one.
cp "$cam" rawcam.cameramodel
printf '{"type": "svms.photometric", "response": "linear", "black_level": 256, "white_level": 4095, "bayer": "RGGB"}\n' > rawcam.cameramodel.photometric.json
expect 0 '"source":"camera"' "$svms" detect raw12_bayer/range_0000.png --camera rawcam.cameramodel --markers "$markers"
printf '{"type": "svms.photometric", "response": "warm", "black_level": 0, "white_level": 0}\n' > bad.cameramodel.photometric.json
cp "$cam" bad.cameramodel
expect 2 "bad.cameramodel.photometric.json: response:" "$svms" detect linear/range_0000.png --camera bad.cameramodel

# Bad photometry options: exit 2, named.
expect 2 '--bayer "RGBX": unknown Bayer pattern' "$svms" detect linear/range_0000.png --bayer RGBX
# A one-marker layout: the range set's dual marker at the object's origin.
"$py" - "$markers" layout.json <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))["markers"][0]
json.dump({"type": "svms.layout", "name": "dual", "markers": [
    {"marker": m, "object_from_marker": {"rvec": [0, 0, 0], "tvec": [0, 0, 0]}}]}, open(sys.argv[2], "w"))
PY
expect 2 '--response "log": unknown response' "$svms" pose linear/range_0000.png --camera "$cam" --layout layout.json --response log
expect 2 "--black-level/--white-level" "$svms" detect linear/range_0000.png --black-level 300 --white-level 200
"$py" -c "import cv2; cv2.imwrite('colour.png', cv2.cvtColor(cv2.imread('linear/range_0000.png', 0), cv2.COLOR_GRAY2BGR))"
expect 1 "expected a one-channel mosaic" "$svms" detect colour.png --bayer RGGB

# Video: the linear frames as a lossless FFV1 video at 5 frames per second.
"$py" - linear/range_000*.png <<'PY' || fail "cannot write the test video"
import cv2, sys
frames = [cv2.imread(f) for f in sorted(sys.argv[1:])]
h, w = frames[0].shape[:2]
out = cv2.VideoWriter("v.mkv", cv2.CAP_FFMPEG, cv2.VideoWriter_fourcc(*"FFV1"), 5, (w, h))
assert out.isOpened()
for f in frames: out.write(f)
out.release()
PY
nframes=$(ls linear/range_000*.png | wc -l)
"$svms" detect v.mkv --camera "$cam" --markers "$markers" --response linear > v.jsonl 2>/dev/null; rc=$?
[ $rc -eq 0 ] && pass || fail "detect on a video: exit $rc"
"$py" - v.jsonl lin.jsonl $nframes <<'PY' && pass || fail "the video's lines are not its frames"
import json, sys
v = [json.loads(l) for l in open(sys.argv[1])]
lin = [json.loads(l) for l in open(sys.argv[2])]
n = int(sys.argv[3])
assert len(v) == n, (len(v), n)
assert [l["frame"] for l in v] == list(range(n))
assert all(abs(l["timestamp"] - 0.2 * l["frame"]) < 1e-6 for l in v), [l["timestamp"] for l in v]
for a, b in zip(v, lin):
    assert sorted(d["id"] for d in a["detections"]) == sorted(d["id"] for d in b["detections"]), (a, b["image"])
PY
out=$("$svms" pose v.mkv --camera "$cam" --layout layout.json --response linear --quiet 2>/dev/null)
[ "$(grep -c '"frame":' <<<"$out")" -eq "$nframes" ] && grep -q '"valid":true' <<<"$out" && grep -q '"timestamp":0.2,' <<<"$out" \
  && pass || fail "pose on a video: $out"
# A video of one frame is one line and no error.
"$py" - linear/range_0000.png <<'PY' || fail "cannot write the one-frame video"
import cv2, sys
f = cv2.imread(sys.argv[1])
out = cv2.VideoWriter("one.mkv", cv2.CAP_FFMPEG, cv2.VideoWriter_fourcc(*"FFV1"), 5, (f.shape[1], f.shape[0]))
out.write(f)
out.release()
PY
expect 0 '"frame":0' "$svms" detect one.mkv --response linear
echo "not a video" > bad.mp4
expect 2 'bad.mp4: cannot open the video with OpenCV'"'"'s FFmpeg backend: FFmpeg says' "$svms" detect bad.mp4

echo "real_cameras: $passes passed, $fails failed"
[ "$fails" -eq 0 ]

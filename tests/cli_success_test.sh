#!/usr/bin/env bash
# The CLI's success paths of `svms survey` and `svms calibrate`, on the images the quick
# benchmarks rendered (ctest fixtures), checked against the truth:
#  - survey of the quick mockup (8 views, 8 markers): every marker's position within 5 sigma
#    (plus 0.05 mm) of the truth in the reference marker's frame, and its report's pictures;
#  - calibration from the quick calibration benchmark's 12 board views: mrcal's own Python
#    reads the model, whose focal lengths are within 0.1 % and centre within 1 px of the truth,
#    and the covariance sidecar is written beside it;
#  - survey --refine-intrinsics --out-camera CAM2: CAM2 and its sidecar load, its intrinsics are
#    the report's, its covariance is positive definite, the report and the layout name CAM2;
#    --out-camera without --refine-intrinsics, or onto --camera, refused in one line (exit 2).
# usage: cli_success_test.sh SVMS MOCKUP_DIR CALIBRATION_BOARD_DIR
set -euo pipefail
svms=${1:?svms}; mock=${2:?mockup dir}; board=${3:?board images dir}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
py=/usr/bin/python3  # Debian's, with mrcal's Python module

"$svms" survey "$mock" --camera "$mock/true.cameramodel" --markers "$mock/markers.json" \
  --reference 10 --out "$tmp/layout.json" --report "$tmp/survey_report" --quiet \
  || fail "svms survey exited $?"
for f in layout.json survey_report/report.md survey_report/layout.png survey_report/markers.csv; do
  [ -s "$tmp/$f" ] || fail "survey: $f missing or empty"
done
"$py" - "$tmp/layout.json" "$mock/true_layout.json" <<'PY' || fail "survey: layout against the truth"
import json, sys
import numpy as np
from scipy.spatial.transform import Rotation

def pose(e):
    p = e["object_from_marker"]
    return Rotation.from_rotvec(p["rvec"]).as_matrix(), np.array(p["tvec"])

est = {e["marker"]["id"]: e for e in json.load(open(sys.argv[1]))["markers"]}
truth = {e["marker"]["id"]: e for e in json.load(open(sys.argv[2]))["markers"]}
R10, t10 = pose(truth[10])
bad, n = [], 0
for mid, e in est.items():
    if mid == 10 or mid not in truth or "covariance" not in e:
        continue
    R, t = pose(truth[mid])
    t_ref = R10.T @ (t - t10)  # the truth in the reference marker's frame, as the survey's
    err = pose(e)[1] - t_ref
    C = np.array(e["covariance"]).reshape(6, 6)[3:, 3:]  # [rotation, translation], row-major
    sigma = np.sqrt(err @ C @ err / (err @ err)) if err @ err > 0 else 0
    n += 1
    print(f"marker {mid}: position error {1e3 * np.linalg.norm(err):.3f} mm, sigma along it {1e3 * sigma:.3f} mm")
    if np.linalg.norm(err) > 5 * sigma + 5e-5:
        bad.append(mid)
if n < 6 or bad:
    sys.exit(f"{n} markers compared, beyond 5 sigma: {bad}")
PY

# --refine-intrinsics --out-camera: the refined camera is written with its sidecar, the report
# and the layout name it. An OPENCV4 start (the truth's first eight numbers): 8 views cannot
# determine OPENCV8's rational terms.
"$py" - "$mock/true.cameramodel" "$tmp/cam4.cameramodel" <<'PY'
import sys, mrcal
m = mrcal.cameramodel(sys.argv[1])
mrcal.cameramodel(intrinsics=("LENSMODEL_OPENCV4", m.intrinsics()[1][:8]),
                  imagersize=m.imagersize()).write(sys.argv[2])
PY
cp "$tmp/cam4.cameramodel" "$tmp/cam4.orig"
"$svms" survey "$mock" --camera "$tmp/cam4.cameramodel" --markers "$mock/markers.json" \
  --reference 10 --refine-intrinsics --out-camera "$tmp/cam2.cameramodel" \
  --out "$tmp/layout2.json" --report "$tmp/survey_report2" --quiet \
  || fail "svms survey --refine-intrinsics --out-camera exited $?"
[ -s "$tmp/cam2.cameramodel.covariance.json" ] || fail "--out-camera: no covariance sidecar"
"$svms" camera show "$tmp/cam2.cameramodel" | grep -q "used by svms pose" \
  || fail "--out-camera: the camera and its sidecar do not load"
"$py" - "$tmp/cam2.cameramodel" "$tmp/survey_report2/report.md" "$tmp/layout2.json" <<'PY' \
  || fail "--out-camera: camera, sidecar, report"
import json, re, sys
import numpy as np, mrcal
cam, report, layout = sys.argv[1:4]
lensmodel, intr = mrcal.cameramodel(cam).intrinsics()
line = [l for l in open(report) if "belongs to the camera" in l]
if len(line) != 1 or f"`{cam}`" not in line[0]:
    sys.exit("the report does not say the layout belongs to " + cam)
reported = [float(v) for v in re.findall(r"([-0-9.e+]+) \(", line[0].split("(sigma):")[1])]
print("refined:", np.round(intr, 6))
if len(reported) != len(intr) or np.max(np.abs(np.array(reported) - intr) / np.maximum(1, np.abs(intr))) > 1e-12:
    sys.exit(f"the camera's intrinsics {intr} are not the survey's {reported}")
side = json.load(open(cam + ".covariance.json"))
L = np.array(side["covariance_factor"])
ev = np.linalg.eigvalsh(L @ L.T)
print("covariance eigenvalues", ev.min(), "...", ev.max())
if side["lensmodel"] != lensmodel or np.any(ev <= 0):
    sys.exit("the sidecar's covariance is not positive definite for " + lensmodel)
if cam not in json.load(open(layout))["name"]:
    sys.exit("the layout's name does not name " + cam)
PY
cmp -s "$tmp/cam4.cameramodel" "$tmp/cam4.orig" || fail "--out-camera: the input camera changed"
set +e
err=$("$svms" survey "$mock" --camera "$tmp/cam4.cameramodel" --markers "$mock/markers.json" \
  --reference 10 --out-camera "$tmp/cam3.cameramodel" --out "$tmp/layout3.json" --quiet 2>&1)
rc=$?
[ $rc -eq 2 ] && [ "$(printf '%s\n' "$err" | wc -l)" -eq 1 ] && [[ $err == *--refine-intrinsics* ]] \
  || fail "--out-camera without --refine-intrinsics: exit $rc, '$err'"
err=$("$svms" survey "$mock" --camera "$tmp/cam4.cameramodel" --markers "$mock/markers.json" \
  --reference 10 --refine-intrinsics --out-camera "$tmp/cam4.cameramodel" \
  --out "$tmp/layout3.json" --quiet 2>&1)
rc=$?
set -e
[ $rc -eq 2 ] && [ "$(printf '%s\n' "$err" | wc -l)" -eq 1 ] || fail "--out-camera = --camera: exit $rc, '$err'"
cmp -s "$tmp/cam4.cameramodel" "$tmp/cam4.orig" || fail "--out-camera = --camera: the input changed"
[ ! -e "$tmp/layout3.json" ] || fail "a refused survey wrote its layout"

"$svms" dataset calibration --quick --no-render --out "$tmp/cal" --quiet > /dev/null
"$svms" calibrate "$board"/*.png --board "$tmp/cal/board_layout.json" --out "$tmp/cam.cameramodel" \
  --quiet || fail "svms calibrate exited $?"
[ -s "$tmp/cam.cameramodel.covariance.json" ] || fail "calibrate: no covariance sidecar"
"$py" - "$tmp/cam.cameramodel" "$tmp/cal/true.cameramodel" <<'PY' || fail "calibrate: model against the truth"
import sys
import mrcal
est, truth = mrcal.cameramodel(sys.argv[1]), mrcal.cameramodel(sys.argv[2])
e, t = est.intrinsics()[1], truth.intrinsics()[1]
print(f"fx {e[0]:.2f} fy {e[1]:.2f} cx {e[2]:.2f} cy {e[3]:.2f} (truth {t[0]} {t[1]} {t[2]} {t[3]})")
if est.intrinsics()[0] != truth.intrinsics()[0]:
    sys.exit("lens model " + est.intrinsics()[0])
if abs(e[0] / t[0] - 1) > 1e-3 or abs(e[1] / t[1] - 1) > 1e-3:
    sys.exit("focal lengths beyond 0.1 %")
if abs(e[2] - t[2]) > 1 or abs(e[3] - t[3]) > 1:
    sys.exit("centre beyond 1 px")
PY
echo "cli_success: survey and calibrate succeed and match the truth"

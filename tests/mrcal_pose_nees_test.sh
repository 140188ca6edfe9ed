#!/usr/bin/env bash
# A camera calibrated by mrcal's own tool (`mrcal-calibrate-cameras`, run by the quick calibration
# benchmark on its chessboard views) in `svms bench pose` on the quick approach, after
# `svms camera import-uncertainty`: the mean NEES with the imported covariance is that of the
# true camera (within a factor 1.5 either way: one calibration, so one draw of its error over
# 12 frames; 2.99 and 2.97 at 0.4.0), and far above it without the calibration's term (so the
# sidecar is what does it). What one calibration's error adds to the NEES is that draw seen
# through d pose / d intrinsics, which depends on how the fit weighs the corners: with the
# corners' joint covariance (bench pose --correlated-corners) 5.23 and 3.00.
# usage: mrcal_pose_nees_test.sh SVMS MRCAL_CAMERA APPROACH (the quick approach's folder, ctest's
# fixture approach_views; only read)
set -uo pipefail
svms=${1:?svms}; mrcal_cam=${2:?camera-0.cameramodel of mrcal-calibrate-cameras}
approach=${3:?usage: mrcal_pose_nees_test.sh SVMS MRCAL_CAMERA APPROACH}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
[ -s "$approach/truth.json" ] || fail "$approach: no rendered approach (truth.json)"
cp "$mrcal_cam" "$tmp/mrcal.cameramodel"
"$svms" camera import-uncertainty "$tmp/mrcal.cameramodel" || fail "import-uncertainty exited $?"
run() {  # NAME CAMERA [options]: the benchmark exits 3 when its NEES band is missed
  local name=$1; shift
  "$svms" bench pose --quick --data "$approach" --layout "$approach/true_layout.json" \
    "$@" --out "$tmp/$name" > "$tmp/$name.log" 2>&1
  local rc=$?
  [ $rc -eq 0 ] || [ $rc -eq 3 ] || fail "bench pose ($name) exited $rc: $(tail -3 "$tmp/$name.log")"
}
run truth
run mrcal --camera "$tmp/mrcal.cameramodel"
run without --camera "$tmp/mrcal.cameramodel" --no-calibration-covariance
/usr/bin/python3 - "$tmp" <<'PY' || fail "NEES"
import json, sys
d = sys.argv[1]
nees = {k: json.load(open(f"{d}/{k}/summary.json"))["nees_mean"] for k in ("truth", "mrcal", "without")}
print("mean NEES: true camera %.2f, mrcal's with its imported covariance %.2f, without it %.1f"
      % (nees["truth"], nees["mrcal"], nees["without"]))
assert nees["truth"] / 1.5 < nees["mrcal"] < 1.5 * nees["truth"], nees
assert nees["without"] > 10 * nees["mrcal"], nees
# With the calibration's error, one draw for all frames, the mean NEES is judged by the band
# for that one draw too (fusion/sequence_nees.h), wider than chi-square's for independent frames;
# without the calibration's term there is no common error and no such band.
s = {k: json.load(open(f"{d}/{k}/summary.json")) for k in ("truth", "mrcal", "without")}
assert s["truth"]["nees_bounds_one_draw"] is None and s["without"]["nees_bounds_one_draw"] is None
band = s["mrcal"]["nees_bounds_one_draw"]
lo, hi = band["bounds"]
chi = s["mrcal"]["nees_bounds"]
print("band for one draw of the calibration's error [%.2f, %.2f] (its share %.0f %%), "
      "independent frames [%.2f, %.2f]" % (lo, hi, 100 * band["common_share"], *chi))
assert 0 < band["common_share"] < 1, band
assert band["common_columns"] > 0, band
assert hi - lo > chi[1] - chi[0], (band, chi)
PY
echo "mrcal_pose_nees: ok"

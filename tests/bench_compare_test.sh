#!/usr/bin/env bash
# `svms bench compare --quick`: it meets its targets (exit 3 otherwise), and writes its report, tables and plots
# with a result for every system and the Fig. 9 distances.
set -euo pipefail
svms="$1"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

"$svms" bench compare --quick --out "$out" > "$out/stdout.txt" || fail "exit code $?"
for f in report.md summary.json markers.csv images.csv fig9.csv fig9_summary.csv \
         compare_size.png compare_size.svg compare_angle.png compare_occlusion.png \
         compare_size_orientation.svg fig9.png fig9.svg scenes/size_tag36h11.json; do
  [[ -s "$out/$f" ]] || fail "$f missing or empty"
done
head -1 "$out/report.md" | grep -q '^## ' || fail "report.md does not start with a ## section"
grep -q '!\[\](fig9.png)' "$out/report.md" || fail "report.md does not link fig9.png"
for sys in svms apriltag_d2 apriltag_d1 aruco_subpix aruco3; do
  grep -q "\"$sys\"" "$out/summary.json" || fail "summary.json has no $sys"
  grep -q "^| $sys |" "$out/report.md" || fail "report.md has no row for $sys"
done
grep -q '"useAruco3Detection": true' "$out/summary.json" || fail "settings not written"
# Every system finds the large head-on markers of the size sweep (60 px).
for sys in svms apriltag_d2 apriltag_d1 aruco_subpix; do
  grep -q "^size,size_060px_00,060,$sys,[a-z0-9]*,[0-9]*,1,1," "$out/markers.csv" ||
    fail "$sys did not find the 60 px marker"
done
[[ $(wc -l < "$out/fig9_summary.csv") -ge 6 ]] || fail "fig9_summary.csv has too few distances"
# Flips per size (quick: 10, 16 and 30 px), one row each.
grep -q '^Pose flips (orientation error > 10 deg) by size' "$out/report.md" || fail "no flips-by-size table"
for px in 10 16 30; do
  grep -q "^| $px | [0-9]*/[0-9]* ([0-9]*) |" "$out/report.md" || fail "no flips row for $px px"
done
# Each pose's distance to the truth's planar twin, and the planar flips counted.
head -1 "$out/markers.csv" |
  grep -q ',orientation_err_deg,twin_err_deg,pose_ambiguous,pose_nees,alternative_err_deg,alternative_weight$' ||
  fail "markers.csv has no twin_err_deg, pose_nees or alternative pose columns"
# The 60 px pose is not flagged, so it has no alternative pose.
grep -q '^size,size_060px_00,060,svms,.*,[0-9.]*,[0-9.]*,0,[0-9.]*,-,-$' "$out/markers.csv" ||
  fail "no twin error or NEES for the 60 px svms pose, or an alternative pose for it"
# SVMS gives a covariance, the peers none: NEES for svms only, and its table in the report.
grep -q '^size,size_060px_00,060,apriltag_d2,.*,0,-,-,-$' "$out/markers.csv" ||
  fail "a peer's pose has a NEES or an alternative pose"
grep -q '"pose_nees_within_chi2_95"' "$out/summary.json" || fail "summary.json has no NEES"
grep -q '^| all sweeps | [1-9][0-9]* | [0-9.]* | [0-9.]* | [0-9]* % |$' "$out/report.md" ||
  fail "report.md has no NEES row for all sweeps"
grep -q '^Largest NEES: [a-z]' "$out/report.md" || fail "report.md does not name the largest NEES"
grep -q '"planar_flips"' "$out/summary.json" || fail "summary.json has no planar_flips"
grep -q '"unflagged_flips"' "$out/summary.json" || fail "summary.json has no unflagged_flips"
grep -q '^- No pose flips: .*, of them planar [0-9]*, not flagged ambiguous [0-9]*, with the alternative pose given beside the flag within 10 deg of the truth [0-9]*)' "$out/report.md" ||
  fail "the flips target does not count the planar ones and the right alternatives"
grep -q '"flips_alternative_right"' "$out/summary.json" || fail "summary.json has no flips_alternative_right"
grep -q '"expected_flips"' "$out/summary.json" || fail "summary.json has no expected_flips"
grep -q '^| all sweeps | [0-9]* | [0-9]* | [0-9]* | [0-9.]* |$' "$out/report.md" ||
  fail "report.md has no row of flags, flips and predicted flips over all sweeps"
# A bad --size-views is refused with its name, before any work.
if "$svms" bench compare --size-views 0 --out "$out/bad" > /dev/null 2> "$out/bad.txt"; then
  fail "--size-views 0 was accepted"
fi
grep -q -- "--size-views" "$out/bad.txt" || fail "the error does not name --size-views"
# The default post, written down; a post beyond the square's side refused with its name.
grep -q '"svms_post_height_m": 0.025' "$out/summary.json" || fail "summary.json has no svms_post_height_m"
grep -q 'the SVMS post 25 mm tall' "$out/report.md" || fail "report.md does not give the post's height"
if "$svms" bench compare --post-height 2 --out "$out/bad" > /dev/null 2> "$out/bad2.txt"; then
  fail "--post-height 2 was accepted"
fi
grep -q -- "--post-height" "$out/bad2.txt" || fail "the error does not name --post-height"
# Edge pixels rendered with 256 rays by default, written down; a count that is not a square
# refused with its name and value.
grep -q '"edge_rays_per_pixel": 256' "$out/summary.json" || fail "summary.json has no edge_rays_per_pixel 256"
grep -q '16 rays per pixel, 256 on edge pixels' "$out/report.md" || fail "report.md does not give the rays per pixel"
if "$svms" bench compare --edge-rays 17 --out "$out/bad" > /dev/null 2> "$out/bad3.txt"; then
  fail "--edge-rays 17 was accepted"
fi
grep -q -- "--edge-rays.*17" "$out/bad3.txt" || fail "the error does not name --edge-rays and 17"
[[ ! -e "$out/bad" ]] || fail "--size-views 0 wrote output"
echo "bench compare --quick: ok"

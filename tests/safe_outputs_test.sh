#!/usr/bin/env bash
# Nothing lost, nothing crashes (docs/reliability.md): paths that are not UTF-8,
# outputs that would replace inputs, write failures (a file-size limit, /dev/full) that must
# leave every earlier output byte-identical and exit 1, requests beyond the memory limit,
# duplicate JSON keys, overflowing sidecars, unusable cameras, FIFOs as inputs, options
# checked before work. Runs as any user: write failures come from `ulimit -f` (with SIGXFSZ
# ignored, as the tools ignore it too), not from permissions.
# Usage: tests/safe_outputs_test.sh path/to/svms [MOCKUP]
# MOCKUP: a render of `svms dataset mockup --quick` to copy (ctest's fixture mockup_views, which
# bench_survey_quick renders); without it the test renders its own.
set -uo pipefail
svms=${1:?usage: safe_outputs_test.sh SVMS [MOCKUP]}
mockup_src=${2:-}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "$0")/expect.sh"
cd "$tmp"

# Inputs: the quick mockup (camera, marker set, true layout, 8 views) and the quick calibration
# boards.
if [ -n "$mockup_src" ]; then
  cp -r "$mockup_src" mockup && [ -s mockup/scene.json ] || { echo "no mockup in $mockup_src"; exit 1; }
else
  "$svms" dataset mockup --quick --out mockup --quiet --threads 2 >/dev/null || { echo "dataset failed"; exit 1; }
fi
"$svms" dataset calibration --quick --out calib --quiet --threads 2 >/dev/null || { echo "dataset failed"; exit 1; }
M=mockup; cam=$M/true.cameramodel; markers=$M/markers.json; layout=$M/true_layout.json
img=$M/mockup_0000.png

# Runs "$@" with a 4 KiB file-size limit (SIGXFSZ ignored): every write of more fails.
limited() { (trap '' XFSZ; ulimit -f 4; "$@"); }
# Records the checksums of files, and checks later that they are unchanged.
sums() { sha256sum "$@" 2>/dev/null; }
same() {  # same WHAT SUMS
  [ -n "$2" ] || { fail "$1: no earlier outputs to compare"; return; }
  local now; now=$(sha256sum $(awk '{print $2}' <<<"$2") 2>/dev/null)
  if [ "$now" == "$2" ]; then pass; else fail "$1: earlier outputs changed"; fi
}
# No temporaries may be left next to the outputs.
no_tmp() {  # no_tmp WHAT DIR...
  if find "${@:2}" -name '*.svms-tmp-*' -o -name '*.svms-plot' -o -name '*.svms-exr*' 2>/dev/null | grep -q .; then
    fail "$1: temporaries left"; else pass; fi
}

# --- 1. Paths that are not UTF-8 -----------------------------------------------------------
bad=$(printf 'caf\xe9.png')
cp "$img" "$bad"
out=$("$svms" detect "$bad" --camera "$cam" --markers "$markers" 2>&1); rc=$?
[ $rc -eq 0 ] && pass || fail "detect on a non-UTF-8 name: exit $rc: $out"
python3 - "$out" <<'PY' && pass || fail "detect's line does not give the name's bytes back: $out"
import json, sys
j = json.loads(sys.argv[1])
assert bytes.fromhex(j["image_hex"]) == b"caf\xe9.png", j
assert j["image"] == "caf\ufffd.png" and len(j["detections"]) == 4, j
PY
mkdir -p frames && cp "$M"/mockup_000[0-2].png frames/ && cp "$img" "frames/$bad"
expect 0 '"image_hex":"6672616d65732f636166e92e706e67"' "$svms" pose frames --camera "$cam" --layout "$layout" --quiet
out=$(printf 'x\xff\n%s 1.5\n' "$img" | "$svms" pose --stdin --camera "$cam" --layout "$layout" --quiet 2>/dev/null); rc=$?
[ $rc -eq 1 ] && [ "$(wc -l <<<"$out")" -eq 2 ] && grep -q '"image_hex":"78ff"' <<<"$out" && grep -q '"timestamp":1.5,"valid":true' <<<"$out" \
  && pass || fail "pose --stdin with a non-UTF-8 line: exit $rc: $out"
mkdir -p cal && cp calib/board/*.png cal/ && mv cal/calib_0000.png "cal/$(printf 'b\xe9.png')"
expect 0 "wrote rep/summary.json" "$svms" calibrate cal --board calib/board_layout.json --lensmodel LENSMODEL_PINHOLE --out c.cameramodel --report rep --quiet
python3 - <<'PY' && pass || fail "summary.json does not carry the image's bytes"
import json
j = json.load(open('rep/summary.json'))
assert j['camera']['file'] == 'c.cameramodel'
assert j['images'] == 4, j['images']
PY
# A report directory given with a trailing slash: the plots are drawn from this run's data.
expect 0 "" "$svms" calibrate cal --board calib/board_layout.json --lensmodel LENSMODEL_PINHOLE --out c2.cameramodel --report rep2/ --quiet
[ -s rep2/coverage.png ] && [ -s rep2/uncertainty.png ] && pass || fail "--report rep2/ lost its plots"
# A closed pipe as standard output: one line, exit 1 (not a silent death by SIGPIPE).
out=$(/usr/bin/python3 - "$svms" "$img" <<'PY'
import os, subprocess, sys
r, w = os.pipe(); os.close(r)
p = subprocess.run([sys.argv[1], "detect", sys.argv[2], sys.argv[2], "--quiet"], stdout=w, stderr=subprocess.PIPE)
print(p.returncode, p.stderr.decode().strip())
PY
)
grep -q "^1 .*Broken pipe" <<<"$out" && pass || fail "a closed pipe: $out"

# --- 2. --debug that is a file, or under one ------------------------------------------------
touch afile
expect 2 "--debug afile: is a file; expected a directory" "$svms" detect "$img" --debug afile
expect 2 "--debug afile/sub: cannot create the directory" "$svms" detect "$img" --debug afile/sub
expect 0 "" "$svms" detect "$img" --debug dbg
[ -s dbg/1_segments.png ] && [ -s dbg/2_quads.png ] && pass || fail "--debug wrote no pictures"

# --- 3. Bounded inputs and memory -----------------------------------------------------------
out=$( { head -c 300000 /dev/zero | tr '\0' a; printf '\n%s\n' "$img"; } | "$svms" pose --stdin --camera "$cam" --layout "$layout" --quiet 2>&1); rc=$?
[ $rc -eq 1 ] && grep -q "standard input, line 1: longer than 65536 bytes" <<<"$out" && grep -q '"valid":true' <<<"$out" \
  && pass || fail "an endless stdin line: exit $rc: ${out:0:400}"
expect 2 "needs about" "$svms" calibrate calib/board --board calib/board_layout.json --lensmodel LENSMODEL_SPLINED_STEREOGRAPHIC_order=3_Nx=200_Ny=200_fov_x_deg=100 --out s.cameramodel
[ ! -e s.cameramodel ] && pass || fail "a refused calibration wrote a model"
python3 - "$M/scene.json" big_scene.json <<'PY'
import json, sys
s = json.load(open(sys.argv[1]))
c = s["camera"]; c["width"] = c["height"] = 10000
c["intrinsics"][2] = c["intrinsics"][3] = 4999.5
s["views"] = s["views"][:1]
json.dump(s, open(sys.argv[2], "w"))
PY
SVMS_MEMORY_LIMIT=1G expect 2 "rendering 10000x10000 pixels on 1 thread(s) needs about" "$svms" render big_scene.json --out big
python3 -c "open('deep.json', 'w').write('[' * 66000000)"
expect 2 "nested deeper than 64 levels" "$svms" model check deep.json

# --- 4. Write failures leave earlier outputs as they were -----------------------------------
# survey: the layout and the report.
expect 0 "" "$svms" survey "$M" --camera "$cam" --markers "$markers" --reference 10 --out k.json --report surv --quiet
s=$(sums k.json surv/*)
out=$(limited "$svms" survey "$M" --camera "$cam" --markers "$markers" --reference 10 --out k.json --report surv --quiet 2>&1); rc=$?
[ $rc -eq 1 ] && grep -q "File too large" <<<"$out" && pass || fail "survey under ulimit -f: exit $rc: $out"
same "survey" "$s"; no_tmp survey . surv
# calibrate: the model, its sidecar and the report, as a pair.
expect 0 "" "$svms" calibrate calib/board --board calib/board_layout.json --lensmodel LENSMODEL_OPENCV4 --out cam2.cameramodel --report crep --quiet
s=$(sums cam2.cameramodel cam2.cameramodel.covariance.json crep/*)
out=$(limited "$svms" calibrate calib/board --board calib/board_layout.json --lensmodel LENSMODEL_OPENCV8 --out cam2.cameramodel --report crep --quiet 2>&1); rc=$?
[ $rc -eq 1 ] && grep -q "nothing written" <<<"$out" && pass || fail "calibrate under ulimit -f: exit $rc: $out"
same "calibrate" "$s"; no_tmp calibrate . crep
expect 0 "cam2.cameramodel.covariance.json) goes into the pose covariance" "$svms" pose "$img" --camera cam2.cameramodel --layout "$layout"
# generate: marker, sheet, board.
expect 0 "" "$svms" generate marker --id 3 --size 0.1 --out g
expect 0 "" "$svms" generate sheet --ids 1-4 --size 0.05 --out sh
s=$(sums g.* sh.*)
expect 1 "File too large" limited "$svms" generate marker --id 5 --size 0.1 --out g
expect 1 "File too large" limited "$svms" generate sheet --ids 5-8 --size 0.05 --out sh
same "generate" "$s"; no_tmp generate .
expect 1 "expected at most 400 megapixels" "$svms" generate marker --id 1 --size 100 --dpi 2400 --out huge
[ -z "$(ls huge.* 2>/dev/null)" ] && pass || fail "a failed generate left $(ls huge.*)"
# render: the view PNGs and truth.json.
mkdir -p r && cp "$M/scene.json" r/ && python3 - r/scene.json <<'PY'
import json, sys
s = json.load(open(sys.argv[1])); s["views"] = s["views"][:2]; json.dump(s, open(sys.argv[1], "w"))
PY
expect 0 "rendered 2 views" "$svms" render r/scene.json --out r --quiet
s=$(sums r/*.png r/truth.json)
out=$(limited "$svms" render r/scene.json --out r --quiet 2>&1); rc=$?
[ $rc -eq 1 ] && ! grep -q "^rendered" <<<"$out" && pass || fail "render under ulimit -f: exit $rc: $out"
same "render" "$s"; no_tmp render r
# dataset.
s=$(sums calib/board/*.png calib/*.json)
expect 1 "File too large" limited "$svms" dataset calibration --quick --out calib --quiet --threads 2
same "dataset" "$s"; no_tmp dataset calib
# detect and pose: overlays and debug pictures.
expect 0 "" "$svms" detect "$img" --camera "$cam" --markers "$markers" --overlay ov --debug dbg
s=$(sums ov/* dbg/*)
expect 1 "File too large" limited "$svms" detect "$img" --camera "$cam" --markers "$markers" --overlay ov
expect 1 "--debug: " limited "$svms" detect "$img" --debug dbg
expect 1 "File too large" limited "$svms" pose "$img" --camera "$cam" --layout "$layout" --overlay ov
same "detect/pose" "$s"; no_tmp detect ov dbg

# --- 5. Outputs that would replace inputs ----------------------------------------------------
mkdir -p in && cp "$M"/mockup_000[0-1].png in/
s=$(sums in/*)
expect 2 "--overlay in/mockup_0000.png: is the input in/mockup_0000.png" "$svms" detect in --overlay in
expect 2 "is the input" "$svms" pose in --camera "$cam" --layout "$layout" --overlay in
same "overlay onto inputs" "$s"
cp "$img" in/mockup_0000.jpg 2>/dev/null; mkdir -p in2 && cp "$img" in2/x.png && cp "$img" in2/x.pgm
expect 2 "would both write" "$svms" detect in2/x.png in2/x.pgm --overlay ov2
expect 2 "--out $markers: is the input $markers" "$svms" survey "$M" --camera "$cam" --markers "$markers" --reference 10 --out "$markers"

# --- 6. Failures reported as failures --------------------------------------------------------
expect 1 "standard output: cannot write: No space left on device" sh -c "\"$svms\" detect $img > /dev/full"
expect 1 "standard output: cannot write" sh -c "\"$svms\" pose $img --camera $cam --layout $layout > /dev/full"
expect 1 "standard output: cannot write" sh -c "echo $img | \"$svms\" pose --stdin --camera $cam --layout $layout > /dev/full"
expect 2 "--report afile/rep: cannot create the directory" "$svms" survey "$M" --camera "$cam" --markers "$markers" --reference 10 --out k2.json --report afile/rep

# --- 7. Duplicate JSON keys ------------------------------------------------------------------
"$svms" generate marker --id 17 --size 0.1 --dpi 60 --out m17 >/dev/null
sed 's/"id": 17,/"id": 17, "id": 18,/' m17.json > dupid.json
expect 2 "dupid.json: id: the field appears twice in one object" "$svms" model check dupid.json
python3 - "$layout" duppose.json <<'PY'
import sys
t = open(sys.argv[1]).read()
i = t.index('"object_from_marker"')
t = t[:i] + '"object_from_marker": {"rvec": [0, 0, 0], "tvec": [14, 0, 0]}, ' + t[i:]
open(sys.argv[2], "w").write(t)
PY
expect 2 "duppose.json: markers[0].object_from_marker: the field appears twice" "$svms" model check duppose.json
sed 's/"seed":/"seed": 1, "seed":/' "$M/scene.json" > dupscene.json
expect 2 "dupscene.json: seed: the field appears twice" "$svms" render dupscene.json --out dupr
cp cam2.cameramodel dupcam.cameramodel
sed 's/"views":/"views": 1, "views":/' cam2.cameramodel.covariance.json > dupcam.cameramodel.covariance.json
expect 2 "dupcam.cameramodel.covariance.json: views: the field appears twice" "$svms" pose "$img" --camera dupcam.cameramodel --layout "$layout"

# --- 8. A sidecar whose covariance overflows -------------------------------------------------
cp cam2.cameramodel big.cameramodel
python3 - cam2.cameramodel.covariance.json big.cameramodel.covariance.json <<'PY'
import json, sys
j = json.load(open(sys.argv[1])); j["covariance_factor"][0][0] = 1e300
json.dump(j, open(sys.argv[2], "w"))
PY
expect 2 "covariance_factor: the covariance it implies (L L^T) overflows" "$svms" pose "$img" --camera big.cameramodel --layout "$layout"
expect 2 "covariance_factor: the covariance it implies (L L^T) overflows" "$svms" detect "$img" --camera big.cameramodel

# --- 9. Cameras that cannot measure, and poses missing with a reason -------------------------
cam() {  # cam NAME LENSMODEL INTRINSICS
  printf "{ 'lensmodel': '%s', 'intrinsics': %s, 'extrinsics': [0, 0, 0, 0, 0, 0], 'imagersize': [1024, 1024], }\n" "$2" "$3" > "$1.cameramodel"
}
cam cahvore LENSMODEL_CAHVORE_linearity=0.00 "[1000, 1000, 511.5, 511.5, 0, 0, 0, 0, 0, 0, 0, 0]"
expect 2 "cahvore.cameramodel: LENSMODEL_CAHVORE_linearity=0.00: mrcal 2.2 can neither unproject" "$svms" detect "$img" --camera cahvore.cameramodel
cam tiny LENSMODEL_PINHOLE "[1e-300, 1000, 511.5, 511.5]"
expect 2 "tiny.cameramodel: intrinsics[0]: fx 1e-300 pixels is not a focal length a lens has" "$svms" detect "$img" --camera tiny.cameramodel
cam huge LENSMODEL_PINHOLE "[1000, 1e300, 511.5, 511.5]"
expect 2 "huge.cameramodel: intrinsics[1]: fy" "$svms" pose "$img" --camera huge.cameramodel --layout "$layout"
expect 0 '"pose_error":"no marker model for this ID (--markers): its size is unknown"' "$svms" detect "$img" --camera "$cam"

# --- 10. Silent defaults and late checks -----------------------------------------------------
expect 2 "--corner-sigma 0: expected a positive number of pixels" "$svms" survey "$M" --camera "$cam" --markers "$markers" --reference 10 --out k3.json --corner-sigma 0
expect 2 "--reference -1: expected the ID of a marker" "$svms" survey "$M" --camera "$cam" --markers "$markers" --reference -1 --out k3.json
out=$("$svms" survey "$M" --camera "$cam" --markers "$markers" --reference 999 --out k3.json 2>&1); rc=$?
[ $rc -eq 2 ] && grep -q -- "--reference 999: no marker with that ID" <<<"$out" && ! grep -q detecting <<<"$out" \
  && pass || fail "survey --reference 999: exit $rc (expected 2 before detecting): $out"
out=$("$svms" calibrate calib/board --board calib/board_layout.json --lensmodel LENSMODEL_FOO --out f.cameramodel 2>&1); rc=$?
[ $rc -eq 2 ] && grep -q "unknown lens model 'LENSMODEL_FOO'" <<<"$out" && ! grep -q detected <<<"$out" \
  && pass || fail "calibrate --lensmodel LENSMODEL_FOO: exit $rc (expected 2 before detecting): $out"
mkfifo fifo
for args in "detect $img --camera fifo" "detect $img --markers fifo" "pose $img --camera $cam --layout fifo" \
            "model check fifo" "render fifo --out fr" "survey $M --camera $cam --markers fifo --reference 10 --out k4.json"; do
  expect 2 "fifo: is a FIFO; expected a regular file" timeout 20 "$svms" $args
done
expect 0 "" "$svms" survey "$M" --camera "$cam" --markers "$markers" --reference 10 --out k5.json --report "rep o'brien" --quiet
[ -s "rep o'brien/layout.png" ] && [ -s "rep o'brien/residuals.png" ] && pass || fail "a report directory with a quote lost its plots"
# A missing image in a batch: the batch goes on, exit 1 (docs/conventions.md).
expect 1 "nope.png: no such file; expected an image" "$svms" detect nope.png "$img"

no_tmp "the whole test" .
echo "safe_outputs: $passes passed, $fails failed"
[ "$fails" -eq 0 ]

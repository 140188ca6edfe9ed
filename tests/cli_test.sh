#!/usr/bin/env bash
# End-to-end tests of the `svms` binary: outputs, exit codes and one-line errors.
# Usage: tests/cli_test.sh path/to/svms VERSION (the project's, from CMake)
set -uo pipefail
svms=${1:?usage: cli_test.sh SVMS VERSION}
version=${2:?usage: cli_test.sh SVMS VERSION}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "$0")/expect.sh"
# expect_stderr_lines N -- command: stderr has exactly N lines
expect_err_lines() {
  local n=$1; shift
  local lines
  lines=$("$@" 2>&1 >/dev/null | wc -l)
  [ "$lines" -eq "$n" ] && pass || fail "$* -> $lines stderr lines, expected $n"
}

expect 0 "svms $version" "$svms" --version
expect 0 "codec" "$svms" --help
for sub in "codec stats" "codec encode" "codec decode" "codec read" "model check" "generate marker" "generate sheet"; do
  # shellcheck disable=SC2086
  expect 0 "Examples:" "$svms" $sub --help
done
expect 2 "" "$svms"
expect 2 "" "$svms" frobnicate

# codec
bits=$("$svms" codec encode 17)
[ ${#bits} -eq 44 ] && pass || fail "encode printed '$bits'"
expect 0 "id 17 rotation 0 bit_errors 0" "$svms" codec decode "$bits"
flipped=$(python3 -c "import sys; b=list(sys.argv[1]); b[3]='1' if b[3]=='0' else '0'; b[40]='1' if b[40]=='0' else '0'; print(''.join(b))" "$bits")
expect 0 "id 17 rotation 0 bit_errors 2" "$svms" codec decode "$flipped"
expect 1 "no codeword" "$svms" codec decode "$flipped" --max-corrections 1
expect 2 "expected 44 characters of 0/1" "$svms" codec decode 0101
# A negative seed is refused (an unsigned seed would wrap it to 2^64 - 1 and run on).
expect 2 "--seed: Value -1 not in range" "$svms" dataset range --quick --seed -1 --out "$tmp/neg"
expect 2 "--seed: Value -3 not in range" "$svms" bench calibrate --seed -3 --out "$tmp/negb"
expect 2 "" "$svms" codec encode 32768
expect 0 '"verdict":"accepted"' "$svms" codec decode "$bits" --json
"$svms" codec stats --json --samples 20000 > "$tmp/stats.json" 2>/dev/null
python3 - "$tmp/stats.json" <<'PY' && pass || fail "codec stats --json fields"
import json, sys
s = json.load(open(sys.argv[1]))
for k in ["family", "bits", "ids", "min_distance", "rotation_min_distance", "false_accept"]:
    assert k in s, k
assert s["family"] == "svms44" and s["bits"] == 44 and s["ids"] >= 32768
assert s["min_distance"] >= 11 and s["rotation_min_distance"] >= 9
assert len(s["false_accept"]) == 6
PY

# generate + read back
expect 0 "wrote $tmp/m17.svg" "$svms" generate marker --id 17 --size 0.1 --out "$tmp/m17"
for ext in svg pdf png json; do [ -s "$tmp/m17.$ext" ] && pass || fail "missing m17.$ext"; done
expect 0 "read ID 17" "$svms" codec read "$tmp/m17.png" --model "$tmp/m17.json"
expect 0 "dual marker 3/4" "$svms" generate marker --id 3 --size 0.432 --inner-id 4 --inner-size 0.108 --dpi 60 --out "$tmp/dual"
expect 0 "read ID 4" "$svms" codec read "$tmp/dual.png" --model "$tmp/dual.json" --dpi 60
expect 0 "concave well" "$svms" generate marker --id 9 --size 0.1 --concave --out "$tmp/well"
# The PNG declares its resolution (pHYs) as another program reads it (PIL, when installed):
# 60 dpi is 2362 pixels per metre, and that times the page's width in the SVG is the width.
if /usr/bin/python3 -c "import PIL" 2>/dev/null; then
  /usr/bin/python3 - "$tmp/dual" <<'PY' && pass || fail "dual.png: pHYs missing or not its drawn resolution"
import re, sys
from PIL import Image
im = Image.open(sys.argv[1] + ".png")
dpi = im.info["dpi"]
ppm = round(dpi[0] / 0.0254)
assert ppm == 2362 and dpi[0] == dpi[1], dpi
w_mm, h_mm = map(float, re.search(r'width="([0-9.]+)mm" height="([0-9.]+)mm"', open(sys.argv[1] + ".svg").read()).groups())
assert abs(ppm * w_mm / 1000 - im.size[0]) <= 0.5 and abs(ppm * h_mm / 1000 - im.size[1]) <= 0.5, (ppm, w_mm, h_mm, im.size)
PY
fi
# Reading a PNG with the wrong model fails, and says so.
expect 1 "MISMATCH" "$svms" codec read "$tmp/m17.png" --model "$tmp/well.json"
expect 2 "" "$svms" generate marker --id 1 --size -1 --out "$tmp/x"
expect 2 "inner.size" "$svms" generate marker --id 1 --size 0.1 --inner-id 2 --inner-size 0.09 --out "$tmp/x"
expect 2 "--inner-id and --inner-size go together" "$svms" generate marker --id 1 --size 0.1 --inner-id 2 --out "$tmp/x"
expect 1 "/nonexistent/dir/x: cannot write: directory /nonexistent/dir does not exist" "$svms" generate marker --id 1 --size 0.1 --out /nonexistent/dir/x
expect 0 "6 markers on page A4" "$svms" generate sheet --ids 20-25 --size 0.05 --dpi 50 --out "$tmp/sheet"
expect 2 "expected a list like 1,2,5-8" "$svms" generate sheet --ids 5-2 --size 0.05 --out "$tmp/sheet"
expect 2 "appears twice" "$svms" generate sheet --ids 1,1 --size 0.05 --out "$tmp/sheet"
expect 2 "--page: expected A4" "$svms" generate sheet --ids 1 --size 0.05 --page B7 --out "$tmp/sheet"
expect 1 "more than the printable" "$svms" generate sheet --ids 1 --size 0.3 --out "$tmp/sheet"
expect 0 "6 markers on page 300x200" "$svms" generate sheet --markers "$tmp/sheet.json" --page 300x200 --dpi 50 --out "$tmp/sheet2"

# model check: good files, and a batch with a bad file in the middle goes on
expect 0 "marker set: 6 markers" "$svms" model check "$tmp/sheet.json"
python3 -c "import json; m=json.load(open('$tmp/m17.json')); m['size']=-0.1; json.dump(m, open('$tmp/bad.json','w'))"
expect 2 "$tmp/bad.json: size: expected a positive number of metres, got -0.1" "$svms" model check "$tmp/bad.json"
expect 2 "$tmp/dual.json: dual marker" "$svms" model check "$tmp/m17.json" "$tmp/bad.json" "$tmp/dual.json"
expect_err_lines 2 "$svms" model check "$tmp/m17.json" "$tmp/bad.json" "$tmp/dual.json"
printf '{"type": "svms.marker", "id": 3,,}' > "$tmp/syntax.json"
expect 2 "$tmp/syntax.json: line 1, column" "$svms" model check "$tmp/syntax.json"
expect 2 "/nonexistent.json: cannot open for reading" "$svms" model check /nonexistent.json

# render and dataset
expect 0 "angle" "$svms" dataset --list
expect 2 "expected one of range" "$svms" dataset moon --out "$tmp/moon"
expect 0 "rendered 6 views of 1024x1024" "$svms" dataset range --quick --quiet --out "$tmp/range"
python3 - "$tmp/range/truth.json" <<'PY' && pass || fail "range truth: outer square 30 px at 16 m"
import json, sys
t = json.load(open(sys.argv[1]))
far = t["views"][-1]["markers"][0]
assert far["id"] == 1 and abs(far["side_px"] - 30.0) < 0.5, far["side_px"]
assert t["views"][-1]["markers"][1]["nested_in"] == 1
assert all(len(m["corners"]) == 4 for v in t["views"] for m in v["markers"])
PY
[ -s "$tmp/range/range_0000.png" ] && pass || fail "range_0000.png missing"
expect 0 "views of" "$svms" render "$tmp/range/scene.json" --out "$tmp/range2" --quiet
cmp -s "$tmp/range/range_0003.png" "$tmp/range2/range_0003.png" && pass || fail "same scene, same seed: different bytes"
python3 -c "import json; s=json.load(open('$tmp/range/scene.json')); s['sensor']['bits']=12; json.dump(s, open('$tmp/bad_scene.json','w'))"
expect 2 "$tmp/bad_scene.json: sensor.bits: expected 8 or 16" "$svms" render "$tmp/bad_scene.json" --out "$tmp/x"
expect_err_lines 1 "$svms" render "$tmp/bad_scene.json" --out "$tmp/x"
expect 2 "/nonexistent.json: cannot open for reading" "$svms" render /nonexistent.json --out "$tmp/x"

# detect: artwork PNGs (no camera: IDs and corners), and bad images in a batch that goes on
mkdir -p "$tmp/det"
"$svms" generate marker --id 1234 --size 0.05 --dpi 100 --out "$tmp/det/a" >/dev/null
"$svms" generate marker --id 3 --size 0.1 --inner-id 4 --inner-size 0.025 --dpi 60 --out "$tmp/det/b" >/dev/null
expect 0 '"id":1234' "$svms" detect "$tmp/det/a.png" --quiet
"$svms" detect "$tmp/det/b.png" --quiet > "$tmp/det/b.jsonl"
python3 - "$tmp/det/b.jsonl" <<'PY' && pass || fail "dual artwork: both IDs, inner nested in outer"
import json, sys
j = json.loads(open(sys.argv[1]).readline())
ids = {d["id"]: d for d in j["detections"]}
assert set(ids) == {3, 4}, ids.keys()
assert ids[4].get("nested_in") == 3 and "nested_in" not in ids[3]
assert len(ids[3]["corners"]) == 4 and "cam_from_marker" not in ids[3]
PY
printf 'not an image' > "$tmp/det/junk.png"
python3 -c "open('$tmp/det/tiny.pgm','wb').write(b'P5 1 1 255 ' + bytes([7]))"
expect 1 "junk.png: not an image of a supported format" "$svms" detect "$tmp/det" --quiet
expect 1 "tiny.pgm: 1x1 pixels is too small" "$svms" detect "$tmp/det" --quiet
expect 1 "2 of 4 images failed" "$svms" detect "$tmp/det" --quiet
[ "$("$svms" detect "$tmp/det" --quiet 2>/dev/null | wc -l)" -eq 4 ] && pass || fail "detect: one JSON line per image, bad ones included"
expect 1 "/nonexistent.png: no such file" "$svms" detect /nonexistent.png --quiet
expect 2 "/nonexistent.cameramodel" "$svms" detect "$tmp/det/a.png" --camera /nonexistent.cameramodel

# generate board + calibrate: bad inputs (the full run is `svms bench calibrate --quick`)
expect 0 "30 markers" "$svms" generate board --rows 5 --cols 6 --size 0.06 --gap 0.015 --first-id 100 --dpi 20 --out "$tmp/board"
for ext in svg pdf png json; do [ -s "$tmp/board.$ext" ] && pass || fail "missing board.$ext"; done
"$svms" dataset calibration --no-render --quiet --out "$tmp/cal" >/dev/null
cmp -s "$tmp/board.json" "$tmp/cal/board_layout.json" && pass || fail "generate board: not the dataset's board_layout.json"
expect 0 "layout 'calibration board" "$svms" model check "$tmp/board.json"
expect 2 "--first-id: the board needs IDs 32760 to 32789" "$svms" generate board --rows 5 --cols 6 --size 0.06 --gap 0 --first-id 32760 --out "$tmp/x"
expect 0 "Examples:" "$svms" generate board --help
expect 0 "Examples:" "$svms" calibrate --help
expect 2 "/nonexistent.json: cannot open for reading" "$svms" calibrate "$tmp/det/a.png" --board /nonexistent.json --out "$tmp/c.cameramodel"
expect 2 "expected a layout" "$svms" calibrate "$tmp/det/a.png" --board "$tmp/m17.json" --out "$tmp/c.cameramodel"
expect 2 "the images show markers 1234 but none of the board's" "$svms" calibrate "$tmp/det/a.png" --board "$tmp/board.json" --out "$tmp/c.cameramodel" --quiet
expect 2 "junk.png: not an image of a supported format" "$svms" calibrate "$tmp/det/junk.png" --board "$tmp/board.json" --out "$tmp/c.cameramodel" --quiet
# The board's own artwork as the images: twice is too few views; three times, all
# fronto-parallel, is degenerate. No model either time.
for i in 1 2; do cp "$tmp/board.png" "$tmp/board_view$i.png"; done
expect 1 "too few views: 2 of 2 images" "$svms" calibrate "$tmp"/board_view*.png --board "$tmp/board.json" --out "$tmp/c.cameramodel" --quiet
cp "$tmp/board.png" "$tmp/board_view3.png"
expect 1 "degenerate views" "$svms" calibrate "$tmp"/board_view*.png --board "$tmp/board.json" --out "$tmp/c.cameramodel" --quiet
[ ! -e "$tmp/c.cameramodel" ] && pass || fail "calibrate wrote a model after failing"
# survey (bundle/): bad input named, exit 2; survey failures exit 1
expect 0 "Examples:" "$svms" survey --help
expect 2 "/nonexistent.cameramodel" "$svms" survey "$tmp/range" --camera /nonexistent.cameramodel --markers "$tmp/range/markers.json" --reference 1 --out "$tmp/l.json"
expect 2 "expected A:B:DISTANCE" "$svms" survey "$tmp/range" --camera "$tmp/range/true.cameramodel" --markers "$tmp/range/markers.json" --reference 1 --scale-bar 1:2 --out "$tmp/l.json"
expect 2 "expected --reference ID or three --control-point" "$svms" survey "$tmp/range" --camera "$tmp/range/true.cameramodel" --markers "$tmp/range/markers.json" --out "$tmp/l.json"
expect 2 "--reference 999: no marker with that ID" "$svms" survey "$tmp/range" --camera "$tmp/range/true.cameramodel" --markers "$tmp/range/markers.json" --reference 999 --out "$tmp/l.json" --quiet

# pose (fusion/): the range set's dual marker as a one-marker layout; a pose per frame, errors named
python3 - "$tmp/range/markers.json" "$tmp/range_layout.json" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))["markers"][0]
json.dump({"type": "svms.layout", "name": "range plate", "markers": [
    {"marker": m, "object_from_marker": {"rvec": [0, 0, 0], "tvec": [0, 0, 0]}}]}, open(sys.argv[2], "w"))
PY
expect 0 "Examples:" "$svms" pose --help
ls "$tmp"/range/range_000[0-2].png > "$tmp/frames.txt"
if out=$("$svms" pose --stdin --camera "$tmp/range/true.cameramodel" --layout "$tmp/range_layout.json" --quiet < "$tmp/frames.txt"); then
  python3 - "$out" <<'PY' && pass || fail "svms pose --stdin output: $out"
import json, sys
lines = [json.loads(l) for l in sys.argv[1].splitlines()]
assert len(lines) == 3, lines
for i, j in enumerate(lines):
    assert j["valid"] and j["timestamp"] == i and len(j["covariance"]) == 36, j
    assert len(j["cam_from_object"]["quaternion"]) == 4 and j["markers"][0] in (1, 2), j
PY
else fail "svms pose --stdin exited $?"; fi
# --frame-threads: the same lines as on one thread, bar the timings
strip_ms() { python3 -c "import json,sys; [print(json.dumps({k: v for k, v in json.loads(l).items() if k not in ('ms', 'latency_ms', 'detect_ms')}, sort_keys=True)) for l in sys.stdin]"; }
one=$("$svms" pose --stdin --camera "$tmp/range/true.cameramodel" --layout "$tmp/range_layout.json" --quiet < "$tmp/frames.txt" | strip_ms)
two=$("$svms" pose --stdin --camera "$tmp/range/true.cameramodel" --layout "$tmp/range_layout.json" --quiet --frame-threads 2 < "$tmp/frames.txt" | strip_ms)
[ -n "$one" ] && [ "$one" == "$two" ] && pass || fail "pose --frame-threads 2 differs: $two"
one=$("$svms" detect "$tmp"/range/range_000[0-2].png --camera "$tmp/range/true.cameramodel" --markers "$tmp/range/markers.json" --quiet | strip_ms)
two=$("$svms" detect "$tmp"/range/range_000[0-2].png --camera "$tmp/range/true.cameramodel" --markers "$tmp/range/markers.json" --quiet --frame-threads 3 | strip_ms)
grep -q cam_from_marker <<<"$one" && [ "$one" == "$two" ] && pass || fail "detect --frame-threads 3 differs: $two"
expect 2 "--frame-threads" "$svms" detect "$tmp/det/a.png" --frame-threads 0
# --decimate: the range's markers found with the same IDs (corners from the same full-image fit)
ids() { python3 -c "import json,sys; [print(sorted(d['id'] for d in json.loads(l)['detections'])) for l in sys.stdin]"; }
one=$("$svms" detect "$tmp"/range/range_000[0-2].png --quiet | ids)
two=$("$svms" detect "$tmp"/range/range_000[0-2].png --quiet --decimate 2 | ids)
grep -q "[0-9]" <<<"$one" && [ "$one" == "$two" ] && pass || fail "detect --decimate 2 finds other markers: $two against $one"
expect 2 "--decimate" "$svms" detect "$tmp/det/a.png" --decimate 5
expect 2 "--decimate" "$svms" pose --stdin --camera "$tmp/range/true.cameramodel" --layout "$tmp/range_layout.json" --decimate 0
printf '%s 12.5\n/nonexistent.png 13\n' "$(head -1 "$tmp/frames.txt")" > "$tmp/frames2.txt"
expect 1 "/nonexistent.png: no such file" "$svms" pose --stdin --camera "$tmp/range/true.cameramodel" --layout "$tmp/range_layout.json" --quiet < "$tmp/frames2.txt"
if out=$("$svms" pose --stdin --camera "$tmp/range/true.cameramodel" --layout "$tmp/range_layout.json" --quiet < "$tmp/frames2.txt" 2>/dev/null); then fail "bad frame: exit 0"
else grep -q '"timestamp":12.5' <<<"$out" && grep -q '"error"' <<<"$out" && pass || fail "bad frame lines: $out"; fi
# The camera's covariance sidecar (svms calibrate writes it): read, flagged, widens the
# covariance; one of another calibration is refused by name.
cp "$tmp/range/true.cameramodel" "$tmp/cal.cameramodel"
python3 - "$tmp/cal.cameramodel" <<'PY'
import ast, json, sys
m = ast.literal_eval(open(sys.argv[1]).read())
n = len(m["intrinsics"])
factor = [[(0.3 if i < 4 else 1e-4) if i == k else 0.0 for k in range(n)] for i in range(n)]
json.dump({"type": "svms.intrinsics_covariance", "lensmodel": m["lensmodel"],
           "imagersize": m["imagersize"], "intrinsics": m["intrinsics"], "noise_sigma_px": 0.05,
           "views": 20, "covariance_factor": factor}, open(sys.argv[1] + ".covariance.json", "w"))
PY
expect 0 "its calibration's uncertainty ($tmp/cal.cameramodel.covariance.json) goes into the pose covariance" \
  "$svms" pose "$(head -1 "$tmp/frames.txt")" --camera "$tmp/cal.cameramodel" --layout "$tmp/range_layout.json"
with=$("$svms" pose "$(head -1 "$tmp/frames.txt")" --camera "$tmp/cal.cameramodel" --layout "$tmp/range_layout.json" --quiet)
without=$("$svms" pose "$(head -1 "$tmp/frames.txt")" --camera "$tmp/range/true.cameramodel" --layout "$tmp/range_layout.json" --quiet)
python3 - "$with" "$without" <<'PY' && pass || fail "pose with a covariance sidecar: $with"
import json, sys
a, b = (json.loads(x) for x in sys.argv[1:3])
assert a["flags"]["calibration_in_covariance"] and not b["flags"]["calibration_in_covariance"]
assert a["cam_from_object"] == b["cam_from_object"]  # the pose itself does not change
for i in range(6):
    assert a["covariance"][7 * i] > b["covariance"][7 * i], (i, a["covariance"], b["covariance"])
PY
sed -i 's/"intrinsics": \[\([0-9.e+-]*\)/"intrinsics": [1\1/' "$tmp/cal.cameramodel.covariance.json"
expect 2 "$tmp/cal.cameramodel.covariance.json: intrinsics[0]: written for 1" \
  "$svms" pose "$tmp/range" --camera "$tmp/cal.cameramodel" --layout "$tmp/range_layout.json"
expect 2 "/nonexistent.cameramodel" "$svms" pose "$tmp/range" --camera /nonexistent.cameramodel --layout "$tmp/range_layout.json"
expect 2 "expected a layout" "$svms" pose "$tmp/range" --camera "$tmp/range/true.cameramodel" --layout "$tmp/range/markers.json"
expect 2 "not both and not neither" "$svms" pose --camera "$tmp/range/true.cameramodel" --layout "$tmp/range_layout.json"

echo "$passes passed, $fails failed"
[ "$fails" -eq 0 ]

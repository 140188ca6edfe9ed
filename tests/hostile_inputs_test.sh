#!/usr/bin/env bash
# Hostile inputs through the `svms` binary (docs/reliability.md): bad numbers in model,
# layout and camera files, odd and broken images, and a batch of a few hundred images with bad
# ones among them. Each must give a one-line error naming the file and field, a non-zero exit,
# and batches must complete.
# Usage: tests/hostile_inputs_test.sh path/to/svms
set -uo pipefail
svms=${1:?usage: hostile_inputs_test.sh SVMS}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "$0")/expect.sh"

# --- Model and layout files -----------------------------------------------------------------
"$svms" generate marker --id 17 --size 0.1 --dpi 60 --out "$tmp/m17" >/dev/null
# edit FILE OUT PYTHON: loads FILE as `m`, runs PYTHON, writes the text `out` (or m) to OUT.
edit() {
  python3 - "$1" "$2" "$3" <<'PY'
import json, sys
m = json.load(open(sys.argv[1]))
out = None
exec(sys.argv[3])
open(sys.argv[2], "w").write(out if out is not None else json.dumps(m))
PY
}
edit "$tmp/m17.json" "$tmp/inf.json" 'out = json.dumps(dict(m, size=12345.5)).replace("12345.5", "1e400")'
expect 2 "size: the number 1e400 is beyond the range of a double; expected a finite number" "$svms" model check "$tmp/inf.json"
expect 2 "$tmp/inf.json: line 1, column" "$svms" model check "$tmp/inf.json"
edit "$tmp/m17.json" "$tmp/nan.json" 'out = json.dumps(dict(m, size=float("nan")))'
expect 2 "$tmp/nan.json: line 1, column" "$svms" model check "$tmp/nan.json"
edit "$tmp/m17.json" "$tmp/zero.json" 'm["size"] = 0'
expect 2 "$tmp/zero.json: size: expected a positive number of metres, got 0" "$svms" model check "$tmp/zero.json"
edit "$tmp/m17.json" "$tmp/negpost.json" 'm["post"]["radius"] = -0.001'
expect 2 "$tmp/negpost.json: post.radius: expected a positive number" "$svms" model check "$tmp/negpost.json"
# Layouts: a good one, then overlapping, duplicate, non-finite and non-PSD variants.
layout='
m.pop("type")
mk = m
def entry(i, x, y=0.0, z=0.0, rx=0.0):
    return {"marker": dict(mk, id=i), "object_from_marker": {"rvec": [rx, 0, 0], "tvec": [x, y, z]}}
m = {"type": "svms.layout", "name": "t", "markers": [entry(1, 0), entry(2, 0.25), entry(3, 0.5)]}
'
edit "$tmp/m17.json" "$tmp/layout.json" "$layout"
expect 0 "layout 't': 3 markers" "$svms" model check "$tmp/layout.json"
edit "$tmp/m17.json" "$tmp/overlap.json" "$layout"'
m["markers"][2] = entry(3, 0.4)'
expect 2 "$tmp/overlap.json: markers[2].object_from_marker: marker 3 overlaps markers[1]: its printed square (0.2 m, to the outer edge of the bit ring) overlaps that of marker 2 (0.2 m) on the same plane" "$svms" model check "$tmp/overlap.json"
edit "$tmp/m17.json" "$tmp/close.json" "$layout"'
m["markers"][2] = entry(3, 0.01, 0.02, 0.03, 1.5708)'
expect 2 "closer than half the smaller black square (0.05 m)" "$svms" model check "$tmp/close.json"
edit "$tmp/m17.json" "$tmp/dup.json" "$layout"'
m["markers"][2] = entry(1, 0.5)'
expect 2 "$tmp/dup.json: markers[2].marker.id: ID 1 appears twice (also in markers[0]); expected unique IDs" "$svms" model check "$tmp/dup.json"
edit "$tmp/m17.json" "$tmp/inftvec.json" "$layout"'
m["markers"][1]["object_from_marker"]["tvec"][2] = 12345.5
out = json.dumps(m).replace("12345.5", "-1e400")'
expect 2 "tvec: the number -1e400 is beyond the range of a double" "$svms" model check "$tmp/inftvec.json"
edit "$tmp/m17.json" "$tmp/cov.json" "$layout"'
m["markers"][0]["covariance"] = [(-1.0 if i == 0 else 0.0) for i in range(36)]'
expect 2 "$tmp/cov.json: markers[0].covariance: expected a positive semi-definite matrix" "$svms" model check "$tmp/cov.json"
edit "$tmp/m17.json" "$tmp/infcov.json" "$layout"'
m["markers"][0]["covariance"] = [(12345.5 if i == 14 else 0.0) for i in range(36)]
out = json.dumps(m).replace("12345.5", "1e400")'
expect 2 "covariance: the number 1e400 is beyond the range of a double" "$svms" model check "$tmp/infcov.json"
# Endless input: refused after 64 MiB instead of eating memory.
expect 2 "/dev/zero: more than 64 MiB" "$svms" model check /dev/zero
# The marker file read by detect gets the same check.
expect 2 "svms detect: $tmp/overlap.json: markers[2].object_from_marker: marker 3 overlaps" "$svms" detect "$tmp/m17.png" --markers "$tmp/overlap.json"

# --- Camera models (svms detect --camera) --------------------------------------------------
cam() {  # cam NAME INTRINSICS [IMAGERSIZE] [EXTRINSICS]
  printf "{ 'lensmodel': 'LENSMODEL_PINHOLE', 'intrinsics': %s, 'extrinsics': %s, 'imagersize': %s, }\n" \
    "$2" "${4:-[0, 0, 0, 0, 0, 0]}" "${3:-[640, 480]}" > "$tmp/$1.cameramodel"
}
cam nan "[500, nan, 319.5, 239.5]"
expect 2 "$tmp/nan.cameramodel: intrinsics[1]: expected a finite number, got 'nan'" "$svms" detect "$tmp/m17.png" --camera "$tmp/nan.cameramodel"
cam inf "[500, 500, 1e400, 239.5]"
expect 2 "$tmp/inf.cameramodel: intrinsics[2]: expected a finite number" "$svms" detect "$tmp/m17.png" --camera "$tmp/inf.cameramodel"
cam zerof "[0, 500, 319.5, 239.5]"
expect 2 "$tmp/zerof.cameramodel: intrinsics[0]: expected a positive focal length fx (pixels), got 0" "$svms" detect "$tmp/m17.png" --camera "$tmp/zerof.cameramodel"
cam negf "[500, -500, 319.5, 239.5]"
expect 2 "$tmp/negf.cameramodel: intrinsics[1]: expected a positive focal length fy (pixels), got -500" "$svms" detect "$tmp/m17.png" --camera "$tmp/negf.cameramodel"
cam negsize "[500, 500, 319.5, 239.5]" "[640, -480]"
expect 2 "$tmp/negsize.cameramodel: imagersize: expected a positive width and height" "$svms" detect "$tmp/m17.png" --camera "$tmp/negsize.cameramodel"
cam infext "[500, 500, 319.5, 239.5]" "[640, 480]" "[0, 0, 0, 0, 0, inf]"
expect 2 "$tmp/infext.cameramodel: extrinsics[5]: expected a finite number" "$svms" detect "$tmp/m17.png" --camera "$tmp/infext.cameramodel"
expect 2 "/dev/zero: more than 64 MiB" "$svms" detect "$tmp/m17.png" --camera /dev/zero
# Truncated inside a string: mrcal 2.2 read past its buffer and svms crashed (found by fuzzing).
printf "{ 'lensmodel': 'LENSMODEL_PINHOLE', 'intrinsics': [1,1,1,1], 'extrinsics': [0,0,0,0,0,0], 'imagersiz" > "$tmp/cut.cameramodel"
expect 2 "$tmp/cut.cameramodel: the string opened on line 1 is not closed before the end of the file" "$svms" detect "$tmp/m17.png" --camera "$tmp/cut.cameramodel"
printf "# a comment without its newline" > "$tmp/comment.cameramodel"
expect 2 "$tmp/comment.cameramodel: " "$svms" detect "$tmp/m17.png" --camera "$tmp/comment.cameramodel"
: > "$tmp/empty.cameramodel"
expect 2 "$tmp/empty.cameramodel: the file is empty" "$svms" detect "$tmp/m17.png" --camera "$tmp/empty.cameramodel"

# --- Images ---------------------------------------------------------------------------------
mkdir -p "$tmp/img"
# png PATH WIDTH HEIGHT BITS CHANNELS [TRUNCATE_TO] [CLAIM_W CLAIM_H]: a PNG of a grey ramp.
png() {
  python3 - "$@" <<'PY'
import struct, sys, zlib
path, w, h, bits, ch = sys.argv[1], *map(int, sys.argv[2:6])
cut = int(sys.argv[6]) if len(sys.argv) > 6 and sys.argv[6] != "-" else None
cw, chh = (int(sys.argv[7]), int(sys.argv[8])) if len(sys.argv) > 8 else (w, h)
def chunk(t, d):
    return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xffffffff)
colour = {1: 0, 3: 2}[ch]
raw = b""
for y in range(h):
    row = b"\0"
    for x in range(w):
        v = (x * 7 + y * 3) % 256
        row += (struct.pack(">H", v * 257) if bits == 16 else bytes([v])) * ch
    raw += row
data = b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", cw, chh, bits, colour, 0, 0, 0))
data += chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b"")
open(path, "wb").write(data[:cut] if cut else data)
PY
}
png "$tmp/img/a_grey.png" 64 48 8 1
png "$tmp/img/b_deep.png" 64 48 16 1
png "$tmp/img/c_colour.png" 64 48 8 3
png "$tmp/img/d_one.png" 1 1 8 1
png "$tmp/img/e_cut.png" 64 48 8 1 60
png "$tmp/img/f_huge.png" 8 8 8 1 - 20000 20000
: > "$tmp/img/g_empty.png"
head -c 300 "$tmp/m17.png" > "$tmp/img/h_cut2.png"
printf 'P5\n64 48\n255\n' > "$tmp/img/i_short.pgm"
printf 'GIF89a' > "$tmp/img/j_gif.png"
mkdir -p "$tmp/img/k_dir.png"
out=$("$svms" detect "$tmp/img" --quiet 2>"$tmp/img.err"); rc=$?
[ "$rc" -eq 1 ] && pass || fail "detect on odd images: exit $rc, expected 1"
[ "$(wc -l <<<"$out")" -eq 10 ] && pass || fail "detect: one JSON line per image file (10), got $(wc -l <<<"$out")"
for want in \
  "d_one.png: 1x1 pixels is too small to hold a marker" \
  "e_cut.png: truncated PNG" \
  "f_huge.png: 20000x20000 pixels (400 megapixels) is over the limit of 100 megapixels; expected a smaller image" \
  "g_empty.png: empty file (0 bytes); expected an image" \
  "h_cut2.png: truncated PNG" \
  "i_short.pgm: truncated PNM" \
  "j_gif.png: not an image of a supported format" \
  "7 of 10 images failed"; do
  grep -qF -- "$want" "$tmp/img.err" && pass || fail "detect on odd images: stderr lacks '$want': $(cat "$tmp/img.err")"
done
python3 - "$out" <<'PY' && pass || fail "detect: the good images (8-bit, 16-bit, colour) are read, the bad ones carry their error"
import json, sys
lines = [json.loads(l) for l in sys.argv[1].splitlines()]
ok = {l["image"].rsplit("/", 1)[1] for l in lines if "detections" in l}
assert ok == {"a_grey.png", "b_deep.png", "c_colour.png"}, ok
assert all(("error" in l) != ("detections" in l) for l in lines)
PY
expect 1 "20000x20000 pixels" "$svms" detect "$tmp/img/f_huge.png" --quiet
expect 0 "" "$svms" detect "$tmp/img/a_grey.png" --quiet --max-megapixels 0.004
expect 1 "64x48 pixels (0.003072 megapixels) is over the limit of 0.003 megapixels" "$svms" detect "$tmp/img/a_grey.png" --quiet --max-megapixels 0.003
expect 2 "svms detect: no image files in the inputs" "$svms" detect "$tmp/img/k_dir.png" --quiet

# A batch of a few hundred tiny images (every 50th broken): it completes, in input order, and
# reports the failures at the end. (The 10,000-image run is measured by hand: docs/reliability.md.)
mkdir -p "$tmp/batch"
python3 - "$tmp/batch" "$tmp/img/a_grey.png" <<'PY'
import shutil, sys
for i in range(300):
    dst = f"{sys.argv[1]}/{i:05d}.png"
    if i % 50 == 7:
        open(dst, "wb").write(b"\x89PNG\r\n\x1a\n broken")
    else:
        shutil.copyfile(sys.argv[2], dst)
PY
out=$("$svms" detect "$tmp/batch" --threads 2 2>"$tmp/batch.err"); rc=$?
[ "$rc" -eq 1 ] && pass || fail "batch: exit $rc, expected 1"
python3 - "$out" <<'PY' && pass || fail "batch: 300 lines in input order, 6 errors"
import json, sys
lines = [json.loads(l) for l in sys.argv[1].splitlines()]
assert len(lines) == 300, len(lines)
assert [l["image"].rsplit("/", 1)[1] for l in lines] == [f"{i:05d}.png" for i in range(300)]
assert sum("error" in l for l in lines) == 6
PY
grep -qF "6 of 300 images failed" "$tmp/batch.err" && pass || fail "batch: no summary line: $(tail -2 "$tmp/batch.err")"

echo "$passes passed, $fails failed"
[ "$fails" -eq 0 ]

#!/usr/bin/env bash
# OpenCV cameras through the svms binary (docs/conventions.md "OpenCV cameras"): a camera file
# written by OpenCV's own Python (cv2.FileStorage) is imported with `svms camera import`, and
# `svms detect` gives the same poses with it as with the equivalent model written by mrcal's
# Python, on frames rendered through that (distorted, OPENCV8) camera; mrcal's Python reads
# the imported model and projects as cv2.projectPoints does; the export reads back in cv2 with
# the same numbers; bad camera files are refused in one line with exit 2.
# Usage: tests/camera_interop_test.sh path/to/svms
set -uo pipefail
svms=${1:?usage: camera_interop_test.sh SVMS}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
source "$(dirname "$0")/expect.sh"
cd "$tmp"
py=/usr/bin/python3  # Debian's, with numpy, OpenCV (python3-opencv) and mrcal (python3-mrcal)

# The range dataset's scene, seen through a distorted camera. Every intrinsic has at most 10
# significant digits, so that mrcal's Python writer (%.10g) writes it exactly.
"$svms" dataset range --quick --no-render --out d >/dev/null || { echo "dataset failed"; exit 1; }
"$py" - <<'PY' || { echo "cannot write the cameras with cv2 and mrcal"; exit 1; }
import json, numpy as np, cv2, mrcal
intr = [1111.0, 1109.0, 515.3, 508.7, -0.32, 0.12, 0.0006, -0.0004, -0.02, 0.01, 0.005, 0.001]
scene = json.load(open("d/scene.json"))
scene["camera"]["lensmodel"] = "LENSMODEL_OPENCV8"
scene["camera"]["intrinsics"] = intr
json.dump(scene, open("d/scene.json", "w"), indent=1)
K = np.array([[intr[0], 0, intr[2]], [0, intr[1], intr[3]], [0, 0, 1]])
fs = cv2.FileStorage("cam_cv.yml", cv2.FILE_STORAGE_WRITE)
fs.write("image_width", 1024)
fs.write("image_height", 1024)
fs.write("camera_matrix", K)
fs.write("distortion_coefficients", np.array([intr[4:]]))
fs.release()
# The same camera as OpenCV's XML, with the other common names.
fs = cv2.FileStorage("cam_cv.xml", cv2.FILE_STORAGE_WRITE)
fs.write("cameraMatrix", K)
fs.write("distCoeffs", np.array(intr[4:]).reshape(-1, 1))
fs.write("imageSize", (1024, 1024))
fs.release()
mrcal.cameramodel(intrinsics=("LENSMODEL_OPENCV8", np.array(intr)),
                  imagersize=(1024, 1024)).write("cam_mrcal.cameramodel")
PY
"$svms" render d/scene.json --out r --quiet >/dev/null || { echo "render failed"; exit 1; }
cp d/markers.json markers.json

expect 0 "LENSMODEL_OPENCV8 1024x1024" "$svms" camera import cam_cv.yml --out imported.cameramodel
expect 0 "LENSMODEL_OPENCV8 1024x1024" "$svms" camera import cam_cv.xml --out imported_xml.cameramodel
cmp -s imported.cameramodel imported_xml.cameramodel && pass || fail "the YAML and XML imports differ"

detect() { local cam=$1 out=$2; "$svms" detect r/*.png --camera "$cam" --markers markers.json --quiet > "$out" || fail "detect with $cam exited $?"; }
detect imported.cameramodel imported.jsonl
detect cam_mrcal.cameramodel mrcal.jsonl
# The same frames with the distortion left out: poses that differ, so the comparison can fail.
"$py" -c "import mrcal; m = mrcal.cameramodel('cam_mrcal.cameramodel'); i = m.intrinsics()[1]; mrcal.cameramodel(intrinsics=('LENSMODEL_PINHOLE', i[:4]), imagersize=m.imagersize()).write('pinhole.cameramodel')"
detect pinhole.cameramodel pinhole.jsonl

# Same poses with the imported model as with mrcal's (the same numbers: identical), close to
# the truth, and not those of the camera without distortion.
"$py" - imported.jsonl mrcal.jsonl pinhole.jsonl r/truth.json <<'PY' && pass || fail "poses with the imported camera differ from mrcal's (see above)"
import json, sys, numpy as np
load = lambda f: [json.loads(l) for l in open(f)]
imp, mr, pin = (load(f) for f in sys.argv[1:4])
poses = lambda frame: {d["id"]: d["cam_from_marker"] for d in frame["detections"] if "cam_from_marker" in d}
n = moved = 0
for a, b, c in zip(imp, mr, pin):
    pa, pb, pc = poses(a), poses(b), poses(c)
    assert pa.keys() == pb.keys(), (a["image"], pa.keys(), pb.keys())
    for i in pa:
        assert pa[i]["rvec"] == pb[i]["rvec"] and pa[i]["tvec"] == pb[i]["tvec"], (a["image"], i, pa[i], pb[i])
        n += 1
        if i in pc:
            moved += np.linalg.norm(np.subtract(pa[i]["tvec"], pc[i]["tvec"])) > 1e-4
assert n >= 6, f"only {n} poses"
assert moved >= 1, "the distortion changes no pose: the test cannot tell the cameras apart"
print(f"{n} poses identical; {moved} differ without the distortion")
PY

# mrcal's Python reads the imported model and projects as OpenCV does.
"$py" - <<'PY' && pass || fail "mrcal's Python and cv2.projectPoints disagree on the imported model"
import numpy as np, cv2, mrcal
m = mrcal.cameramodel("imported.cameramodel")
lens, intr = m.intrinsics()
assert lens == "LENSMODEL_OPENCV8", lens
assert tuple(m.imagersize()) == (1024, 1024)
fs = cv2.FileStorage("cam_cv.yml", cv2.FILE_STORAGE_READ)
K, D = fs.getNode("camera_matrix").mat(), fs.getNode("distortion_coefficients").mat()
x, y = np.meshgrid(np.linspace(-0.45, 0.45, 13), np.linspace(-0.45, 0.45, 13))
p = np.stack([x.ravel(), y.ravel(), np.ones(x.size)], axis=1) * 2.5
q_mrcal = mrcal.project(p, lens, intr)
q_cv, _ = cv2.projectPoints(p, np.zeros(3), np.zeros(3), K, D)
err = np.abs(q_mrcal - q_cv.reshape(-1, 2)).max()
assert err < 1e-8, err
PY

# Export: cv2 reads back the same numbers; export -> import -> export is byte-identical.
expect 0 "OpenCV camera" "$svms" camera export imported.cameramodel --format opencv --out back.yml
expect 0 "" "$svms" camera import back.yml --out back.cameramodel
expect 0 "" "$svms" camera export back.cameramodel --format opencv --out back2.yml
cmp -s back.yml back2.yml && pass || fail "export -> import -> export changed the file"
cmp -s imported.cameramodel back.cameramodel && pass || fail "import -> export -> import changed the model"
"$py" - <<'PY' && pass || fail "cv2 reads different numbers from the export"
import numpy as np, cv2
a = cv2.FileStorage("cam_cv.yml", cv2.FILE_STORAGE_READ)
b = cv2.FileStorage("back.yml", cv2.FILE_STORAGE_READ)
for k in ("camera_matrix", "distortion_coefficients"):
    assert np.array_equal(a.getNode(k).mat(), b.getNode(k).mat()), k
assert b.getNode("image_width").real() == 1024 and b.getNode("image_height").real() == 1024
PY
expect 0 "" "$svms" camera export imported.cameramodel --format opencv --out back.xml
expect 0 "" "$svms" camera import back.xml --out back_xml.cameramodel
cmp -s imported.cameramodel back_xml.cameramodel && pass || fail "export to XML and import changed the model"

# show: the model, its field of view and distortion, no uncertainty.
expect 0 "LENSMODEL_OPENCV8, 1024x1024 pixels" "$svms" camera show imported.cameramodel
expect 0 "k1 -0.32, k2 0.12" "$svms" camera show imported.cameramodel
expect 0 "uncertainty: none" "$svms" camera show imported.cameramodel
expect 0 "optimization_inputs: no" "$svms" camera show imported.cameramodel
expect 0 "distortion: none (pinhole)" "$svms" camera show pinhole.cameramodel

# Bad inputs: one line naming the file and field, exit 2, nothing written.
"$py" - <<'PY'
import numpy as np, cv2
fs = cv2.FileStorage("nosize.yml", cv2.FILE_STORAGE_WRITE)
fs.write("K", np.array([[500., 0, 320], [0, 500, 240], [0, 0, 1]])); fs.write("D", np.zeros((1, 5)))
fs.release()
open("fisheye.yaml", "w").write("image_width: 640\nimage_height: 480\ncamera_matrix:\n  rows: 3\n  cols: 3\n"
  "  data: [500, 0, 320, 0, 500, 240, 0, 0, 1]\ndistortion_model: equidistant\n"
  "distortion_coefficients:\n  rows: 1\n  cols: 4\n  data: [0.1, 0.01, -0.002, 0.0003]\n")
PY
expect 2 "nosize.yml: image size: missing" "$svms" camera import nosize.yml --out x.cameramodel
expect 2 "--image-size WxH" "$svms" camera import nosize.yml --out x.cameramodel
expect 0 "LENSMODEL_PINHOLE 640x480" "$svms" camera import nosize.yml --image-size 640x480 --out x.cameramodel
expect 2 "fisheye.yaml: distortion_model: cv::fisheye's Kannala-Brandt model has no lens model in mrcal 2.2" \
  "$svms" camera import fisheye.yaml --out y.cameramodel
[ -e y.cameramodel ] && fail "a refused import wrote its output" || pass
expect 2 "is the input" "$svms" camera import cam_cv.yml --out cam_cv.yml
expect 2 "--image-size 640" "$svms" camera import nosize.yml --image-size 640 --out x.cameramodel
expect 2 "no OpenCV equivalent" sh -c "'$py' -c \"import mrcal, numpy as np; mrcal.cameramodel(intrinsics=('LENSMODEL_STEREOGRAPHIC', np.array([500., 500, 320, 240])), imagersize=(640, 480)).write('st.cameramodel')\" && '$svms' camera export st.cameramodel --format opencv --out st.yml"
# Other commands point an OpenCV camera at `svms camera import`, without mrcal's parser line.
expect 2 "cam_cv.yml: an OpenCV camera file, not an mrcal .cameramodel; convert it with \`svms camera import cam_cv.yml" \
  "$svms" detect r/range_0000.png --camera cam_cv.yml --markers markers.json --quiet
out=$("$svms" detect r/range_0000.png --camera cam_cv.yml --markers markers.json --quiet 2>&1)
[ "$(wc -l <<<"$out")" -eq 1 ] && pass || fail "more than one line for an OpenCV --camera: $out"

echo "camera_interop: $passes passed, $fails failed"
[ "$fails" -eq 0 ]

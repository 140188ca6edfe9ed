#!/usr/bin/env bash
# `svms pose --rig` end to end: the quick approach's view 6 (module at 4.4 m) rendered by the
# simulator through a two-camera rig (a 20-degree and a 60-degree 640 x 480 pinhole, 0.5 m
# apart, both turned toward the module; the rig frame is the view's camera frame), then
#  - a frames list with one line of both images gives one valid JSON line whose rig_from_object
#    is consistent with the truth (NEES below chi-square(6)'s 99.9 % quantile) and uses markers of
#    both cameras; a line with '-' for the narrow camera still gives a pose (wide alone);
#  - a line with the wrong number of fields gets an "error" field and exit 1;
#  - a rig file with a non-symmetric covariance, or naming a missing camera model, exits 2 with
#    one line naming the file and the field.
# usage: rig_pose_cli_test.sh SVMS
set -euo pipefail
svms=${1:?svms}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
py=/usr/bin/python3  # Debian's, with numpy and mrcal's Python module

"$svms" dataset approach --quick --no-render --out "$tmp/ds" --quiet >/dev/null
"$py" - "$tmp" <<'PY' || fail "could not build the rig's scenes"
import json, sys, numpy as np, mrcal
from scipy.spatial.transform import Rotation
tmp = sys.argv[1]
scene = json.load(open(f"{tmp}/ds/scene.json"))
view = scene["views"][6]
R_rw = Rotation.from_rotvec(view["cam_from_world"]["rvec"]).as_matrix()
t_rw = np.array(view["cam_from_world"]["tvec"])
target = t_rw  # the module's origin (world origin) in the rig frame
rig = {"type": "svms.rig", "name": "test rig", "cameras": []}
for name, fov, x in (("narrow", 20, -0.25), ("wide", 60, 0.25)):
    f = 320 / np.tan(np.radians(fov) / 2)
    mrcal.cameramodel(intrinsics=("LENSMODEL_PINHOLE", np.array([f, f, 319.5, 239.5])),
                      imagersize=np.array([640, 480])).write(f"{tmp}/{name}.cameramodel")
    eye = np.array([x, 0, 0])
    z = (target - eye) / np.linalg.norm(target - eye)
    xa = np.cross(np.array([0, 1.0, 0]), z); xa /= np.linalg.norm(xa)
    R_cr = np.stack([xa, np.cross(z, xa), z])  # rows: camera axes in the rig frame
    t_cr = -R_cr @ eye
    R_cw, t_cw = R_cr @ R_rw, R_cr @ t_rw + t_cr
    s = dict(scene)
    s["camera"] = f"{name}.cameramodel"
    s["views"] = [{"name": "frame", "cam_from_world": {
        "rvec": Rotation.from_matrix(R_cw).as_rotvec().tolist(), "tvec": t_cw.tolist()}}]
    json.dump(s, open(f"{tmp}/{name}_scene.json", "w"))
    rig["cameras"].append({"name": name, "cameramodel": f"{name}.cameramodel",
        "rig_from_cam": {"rvec": Rotation.from_matrix(R_cr.T).as_rotvec().tolist(),
                         "tvec": eye.tolist()}})
json.dump(rig, open(f"{tmp}/port.rig", "w"))
json.dump({"rvec": view["cam_from_world"]["rvec"], "tvec": t_rw.tolist()},
          open(f"{tmp}/truth.json", "w"))
PY
for c in narrow wide; do
  "$svms" render "$tmp/${c}_scene.json" --out "$tmp/$c" --quiet >/dev/null \
    || fail "svms render $c exited $?"
done
printf '# t narrow wide\n1.5 narrow/frame.png wide/frame.png\n2.5 - wide/frame.png\n' > "$tmp/frames.txt"
"$svms" pose --rig "$tmp/port.rig" --layout "$tmp/ds/true_layout.json" \
  --frames-list "$tmp/frames.txt" --quiet > "$tmp/out.jsonl" || fail "svms pose --rig exited $?"
"$py" - "$tmp" <<'PY' || fail "svms pose --rig output"
import json, sys, numpy as np
from scipy.spatial.transform import Rotation
tmp = sys.argv[1]
lines = [json.loads(l) for l in open(f"{tmp}/out.jsonl")]
assert len(lines) == 2, lines
truth = json.load(open(f"{tmp}/truth.json"))
a, b = lines
assert a["valid"] and a["timestamp"] == 1.5 and a["line"] == 2, a
names = [c["name"] for c in a["cameras"]]
assert names == ["narrow", "wide"], names
assert all(len(c["markers"]) > 0 for c in a["cameras"]), a["cameras"]
assert a["flags"]["extrinsics_in_covariance"] is False
assert a["covariance_common"] is None  # no calibration's or extrinsics' uncertainty here
assert a["bias_factor"] is None
p = a["rig_from_object"]
R_t = Rotation.from_rotvec(truth["rvec"]).as_matrix()
R_e = Rotation.from_rotvec(p["rvec"]).as_matrix()
e = np.concatenate([Rotation.from_matrix(R_t @ R_e.T).as_rotvec(),
                    np.array(truth["tvec"]) - np.array(p["tvec"])])
C = np.array(a["covariance"]).reshape(6, 6)
nees = e @ np.linalg.solve(C, e)
print(f"rig: NEES {nees:.2f}, error {np.linalg.norm(e[:3])*1e3:.3f} mrad "
      f"{np.linalg.norm(e[3:])*1e3:.3f} mm, markers {[c['markers'] for c in a['cameras']]}")
assert nees < 22.46, nees
assert b["valid"] and b["timestamp"] == 2.5 and b["images"][0] is None, b
assert b["cameras"][0]["markers"] == [] and len(b["cameras"][1]["markers"]) > 0, b["cameras"]
PY

# The narrow camera's rig_from_cam with a covariance (0.1 mrad, 0.1 mm): flagged, and its share,
# common to every frame, given apart in covariance_common (within the covariance, and what the
# covariance gained over the run without it on the same frame's poses).
sed 's/"tvec": \[-0.25, 0.0, 0.0\]}}/"tvec": [-0.25, 0.0, 0.0]}, "covariance": [[1e-8,0,0,0,0,0],[0,1e-8,0,0,0,0],[0,0,1e-8,0,0,0],[0,0,0,1e-8,0,0],[0,0,0,0,1e-8,0],[0,0,0,0,0,1e-8]]}/' \
  "$tmp/port.rig" > "$tmp/cov.rig"
grep -q '"covariance"' "$tmp/cov.rig" || fail "cov.rig: the sed did not add the covariance"
"$svms" pose --rig "$tmp/cov.rig" --layout "$tmp/ds/true_layout.json" \
  --frames-list "$tmp/frames.txt" --quiet > "$tmp/cov.jsonl" || fail "svms pose --rig cov.rig exited $?"
"$py" - "$tmp" <<'PY' || fail "svms pose --rig with an extrinsics covariance"
import json, sys, numpy as np
tmp = sys.argv[1]
plain = [json.loads(l) for l in open(f"{tmp}/out.jsonl")]
cov = [json.loads(l) for l in open(f"{tmp}/cov.jsonl")]
a = cov[0]
assert a["valid"] and a["flags"]["extrinsics_in_covariance"] is True, a["flags"]
C = np.array(a["covariance"]).reshape(6, 6)
S = np.array(a["covariance_common"]).reshape(6, 6)
assert np.linalg.eigvalsh(S).min() > -1e-12 * S.max(), S
assert np.linalg.eigvalsh(S).max() > 0, S
assert np.linalg.eigvalsh(C - S).min() > -1e-12 * C.max(), (C, S)
B = np.array(a["bias_factor"])  # 6 x k, k = 6 (the narrow camera's rig_from_cam)
assert B.shape == (6, 6), B.shape
assert np.abs(B @ B.T - S).max() <= 1e-12 * np.abs(S).max(), (B @ B.T, S)
# The second line's pose rests on the wide camera alone, whose rig_from_cam has no covariance:
# no common share is needed there, but its columns stay (zeros), as every frame's do.
b = cov[1]
assert b["valid"], b
Sb = np.array(b["covariance_common"]).reshape(6, 6)
assert np.abs(Sb).max() <= 1e-12 * np.abs(np.array(b["covariance"])).max(), Sb
assert np.array(b["bias_factor"]).shape == (6, 6) and not np.any(b["bias_factor"]), b["bias_factor"]
PY

# A line that does not fit the rig: an error in its line, the stream goes on, exit 1.
printf 'narrow/frame.png\n1.5 narrow/frame.png wide/frame.png\n' > "$tmp/short.txt"
set +e
"$svms" pose --rig "$tmp/port.rig" --layout "$tmp/ds/true_layout.json" \
  --frames-list "$tmp/short.txt" --quiet > "$tmp/short.jsonl" 2> "$tmp/short.err"
rc=$?
set -e
[ "$rc" = 1 ] || fail "a bad frames-list line: exit $rc, expected 1"
grep -q '"error":.*short.txt, line 1: expected \[TIMESTAMP\] and 2 images' "$tmp/short.jsonl" \
  || fail "a bad frames-list line: $(cat "$tmp/short.jsonl")"
[ "$(wc -l < "$tmp/short.jsonl")" = 2 ] || fail "the stream stopped at the bad line"

# Bad rig files: one line naming the file and the field, exit 2.
bad_rig() {  # NAME SED-EXPRESSION EXPECTED
  sed "$2" "$tmp/port.rig" > "$tmp/$1.rig"
  set +e
  "$svms" pose --rig "$tmp/$1.rig" --layout "$tmp/ds/true_layout.json" \
    --frames-list "$tmp/frames.txt" --quiet > /dev/null 2> "$tmp/$1.err"
  local rc=$?
  set -e
  [ "$rc" = 2 ] || fail "$1: exit $rc, expected 2"
  [ "$(wc -l < "$tmp/$1.err")" = 1 ] || fail "$1: not one line: $(cat "$tmp/$1.err")"
  grep -q "$1.rig: $3" "$tmp/$1.err" || fail "$1: $(cat "$tmp/$1.err")"
}
bad_rig missing_model 's/narrow.cameramodel/nowhere.cameramodel/' 'cameras\[0\] .narrow.: .*nowhere.cameramodel'
bad_rig asymmetric 's/"tvec": \[-0.25, 0.0, 0.0\]}}/"tvec": [-0.25, 0.0, 0.0]}, "covariance": [[1,2,0,0,0,0],[0,1,0,0,0,0],[0,0,1,0,0,0],[0,0,0,1,0,0],[0,0,0,0,1,0],[0,0,0,0,0,1]]}/' 'cameras\[0\].covariance: expected a symmetric'
echo "rig_pose_cli_test: ok"

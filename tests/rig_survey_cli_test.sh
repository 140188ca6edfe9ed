#!/usr/bin/env bash
# `svms survey rig` end to end: the quick approach's views 5-8 (the module 5.2 m to 3.3 m away)
# rendered by the simulator through the two-camera rig of rig_pose_cli_test.sh (a 20-degree and
# a 60-degree 640 x 480 pinhole, 0.5 m apart, turned toward the module at view 6; the rig frame
# is each view's camera frame), then
#  - the survey from a rig file whose wide camera is off by 20 mrad and 30 mm writes a rig file
#    whose wide rig_from_cam is within 3 sigma of the truth (NEES below chi-square(6)'s 99.9 %
#    quantile) and within 2 mrad and 5 mm, the narrow (reference) camera as given, and a report;
#    `svms pose --rig` reads the new file (extrinsics_in_covariance);
#  - bad input exits 2 with one line naming the file or field (--out equal to --rig, a frames
#    line that does not fit, an unknown --reference); a wide camera never seen together with
#    the narrow one exits 1; no input is changed.
# usage: rig_survey_cli_test.sh SVMS
set -euo pipefail
svms=${1:?svms}
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }
py=/usr/bin/python3  # Debian's, with numpy and mrcal's Python module
views="5 6 7 8"

"$svms" dataset approach --quick --no-render --out "$tmp/ds" --quiet >/dev/null
"$py" - "$tmp" $views <<'PY' || fail "could not build the rig's scenes"
import json, sys, numpy as np, mrcal
from scipy.spatial.transform import Rotation
tmp, views = sys.argv[1], [int(v) for v in sys.argv[2:]]
scene = json.load(open(f"{tmp}/ds/scene.json"))
# The rig is aimed at the module as seen from view 6.
target = np.array(scene["views"][6]["cam_from_world"]["tvec"])
rig = {"type": "svms.rig", "name": "test rig", "cameras": []}
truth = {}
for name, fov, x in (("narrow", 20, -0.25), ("wide", 60, 0.25)):
    f = 320 / np.tan(np.radians(fov) / 2)
    mrcal.cameramodel(intrinsics=("LENSMODEL_PINHOLE", np.array([f, f, 319.5, 239.5])),
                      imagersize=np.array([640, 480])).write(f"{tmp}/{name}.cameramodel")
    eye = np.array([x, 0, 0])
    z = (target - eye) / np.linalg.norm(target - eye)
    xa = np.cross(np.array([0, 1.0, 0]), z); xa /= np.linalg.norm(xa)
    R_cr = np.stack([xa, np.cross(z, xa), z])  # rows: camera axes in the rig frame
    t_cr = -R_cr @ eye
    s = dict(scene)
    s["camera"] = f"{name}.cameramodel"
    s["views"] = []
    for v in views:
        view = scene["views"][v]
        R_rw = Rotation.from_rotvec(view["cam_from_world"]["rvec"]).as_matrix()
        t_rw = np.array(view["cam_from_world"]["tvec"])
        R_cw, t_cw = R_cr @ R_rw, R_cr @ t_rw + t_cr
        s["views"].append({"name": f"v{v}", "cam_from_world": {
            "rvec": Rotation.from_matrix(R_cw).as_rotvec().tolist(), "tvec": t_cw.tolist()}})
    json.dump(s, open(f"{tmp}/{name}_scene.json", "w"))
    rvec = Rotation.from_matrix(R_cr.T).as_rotvec()
    truth[name] = {"rvec": rvec.tolist(), "tvec": eye.tolist()}
    if name == "wide":  # the input rig's guess is off
        rvec = (Rotation.from_rotvec([0.012, -0.016, 0]) * Rotation.from_rotvec(rvec)).as_rotvec()
        eye = eye + np.array([0.02, -0.01, 0.02])
    rig["cameras"].append({"name": name, "cameramodel": f"{name}.cameramodel",
                           "rig_from_cam": {"rvec": rvec.tolist(), "tvec": eye.tolist()}})
json.dump(rig, open(f"{tmp}/port.rig", "w"))
json.dump(truth, open(f"{tmp}/truth.json", "w"))
PY
for c in narrow wide; do
  "$svms" render "$tmp/${c}_scene.json" --out "$tmp/$c" --quiet >/dev/null \
    || fail "svms render $c exited $?"
done
{
  echo "# t narrow wide"
  for v in $views; do echo "$v narrow/v$v.png wide/v$v.png"; done
} > "$tmp/frames.txt"
sums() { md5sum "$tmp/port.rig" "$tmp/frames.txt" "$tmp/ds/true_layout.json"; }
before=$(sums)
mkdir "$tmp/out"

"$svms" survey rig --rig "$tmp/port.rig" --layout "$tmp/ds/true_layout.json" \
  --frames-list "$tmp/frames.txt" --out "$tmp/out/surveyed.rig" --report "$tmp/report.md" \
  2> "$tmp/survey.err" && rc=0 || rc=$?
[ "$rc" = 0 ] || fail "svms survey rig exited $rc: $(cat "$tmp/survey.err")"
grep -q "| wide | 4 |" "$tmp/report.md" || fail "report: $(cat "$tmp/report.md")"
grep -q "chi2/dof" "$tmp/survey.err" || fail "no report on stderr: $(cat "$tmp/survey.err")"
"$py" - "$tmp" <<'PY' || fail "svms survey rig output"
import json, sys, numpy as np
from scipy.spatial.transform import Rotation
tmp = sys.argv[1]
out = json.load(open(f"{tmp}/out/surveyed.rig"))
truth = json.load(open(f"{tmp}/truth.json"))
given = json.load(open(f"{tmp}/port.rig"))
narrow, wide = out["cameras"]
assert narrow["cameramodel"] == "../narrow.cameramodel", narrow["cameramodel"]
assert narrow["rig_from_cam"] == given["cameras"][0]["rig_from_cam"], narrow
assert "covariance" not in narrow, narrow
def error(t, e):
    R = Rotation.from_rotvec(t["rvec"]).as_matrix() @ Rotation.from_rotvec(e["rvec"]).as_matrix().T
    return np.concatenate([Rotation.from_matrix(R).as_rotvec(),
                           np.array(t["tvec"]) - np.array(e["tvec"])])
e = error(truth["wide"], wide["rig_from_cam"])
e0 = error(truth["wide"], given["cameras"][1]["rig_from_cam"])
C = np.array(wide["covariance"])
nees = e @ np.linalg.solve(C, e)
sig = np.sqrt(np.diag(C))
print(f"wide camera: error {np.linalg.norm(e[:3])*1e3:.3f} mrad {np.linalg.norm(e[3:])*1e3:.3f} mm "
      f"(given: {np.linalg.norm(e0[:3])*1e3:.1f} mrad {np.linalg.norm(e0[3:])*1e3:.1f} mm), "
      f"sigma {np.linalg.norm(sig[:3])*1e3:.3f} mrad {np.linalg.norm(sig[3:])*1e3:.3f} mm, "
      f"NEES {nees:.2f}")
assert nees < 22.46, nees
assert np.linalg.norm(e[:3]) < 2e-3 and np.linalg.norm(e[3:]) < 5e-3, e
PY
# svms pose reads the surveyed rig, with its extrinsics' covariance.
echo "1.5 ../narrow/v6.png ../wide/v6.png" > "$tmp/out/one.txt"
"$svms" pose --rig "$tmp/out/surveyed.rig" --layout "$tmp/ds/true_layout.json" \
  --frames-list "$tmp/out/one.txt" --quiet > "$tmp/pose.jsonl" || fail "svms pose --rig on it"
grep -q '"extrinsics_in_covariance":true' "$tmp/pose.jsonl" || fail "pose: $(cat "$tmp/pose.jsonl")"

# Bad input: one line naming the file or field, exit 2; nothing written.
bad() {  # EXPECTED-RC EXPECTED-TEXT ARGS...
  local want_rc=$1 want=$2 rc
  shift 2
  "$svms" survey rig --layout "$tmp/ds/true_layout.json" "$@" --quiet > /dev/null 2> "$tmp/bad.err" \
    && rc=0 || rc=$?
  [ "$rc" = "$want_rc" ] || fail "$*: exit $rc, expected $want_rc: $(cat "$tmp/bad.err")"
  [ "$(wc -l < "$tmp/bad.err")" = 1 ] || fail "$*: not one line: $(cat "$tmp/bad.err")"
  grep -qF -- "$want" "$tmp/bad.err" || fail "$*: $(cat "$tmp/bad.err")"
}
bad 2 "--out $tmp/port.rig: is the input $tmp/port.rig" \
  --rig "$tmp/port.rig" --frames-list "$tmp/frames.txt" --out "$tmp/port.rig"
printf 'narrow/v5.png\n' > "$tmp/short.txt"
bad 2 "short.txt, line 1: expected [TIMESTAMP] and 2 images" \
  --rig "$tmp/port.rig" --frames-list "$tmp/short.txt" --out "$tmp/x.rig"
bad 2 "--reference left: no camera named 'left' in $tmp/port.rig (it has narrow, wide)" \
  --rig "$tmp/port.rig" --frames-list "$tmp/frames.txt" --out "$tmp/x.rig" --reference left
printf '5 narrow/v5.png -\n6 narrow/v6.png -\n7 - wide/v7.png\n8 - wide/v8.png\n' > "$tmp/apart.txt"
bad 1 "camera 'wide' sees the object in no frame together with the reference camera (camera 'narrow')" \
  --rig "$tmp/port.rig" --frames-list "$tmp/apart.txt" --out "$tmp/x.rig"
[ ! -e "$tmp/x.rig" ] || fail "a failed survey wrote its --out"
[ "$(sums)" = "$before" ] || fail "an input changed"
echo "rig_survey_cli_test: ok"

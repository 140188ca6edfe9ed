#!/bin/bash
# svms pose on the C tests' lone flat marker (written by svms_capi_fixture), rendered from its
# scene file by svms render: flagged ambiguous, the kept pose the wrong planar one, and the
# "alternative" the right one, as the C API gives it (capi_test.c).
# Usage: pose_cli_alternative_test.sh SVMS FIXTURE_DIR
set -u
svms=$1 fixture=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
"$svms" render "$fixture/lone_scene.json" --out "$tmp" --quiet || { echo "FAIL: svms render"; exit 1; }
"$svms" pose "$tmp/v.png" --camera "$fixture/lone.cameramodel" \
  --layout "$fixture/lone_layout.json" --quiet > "$tmp/pose.jsonl" || { echo "FAIL: svms pose exited $?"; exit 1; }
python3 - "$tmp/pose.jsonl" "$fixture/lone.txt" <<'PY'
import json, math, sys
lines = open(sys.argv[1]).read().splitlines()
assert len(lines) == 1, lines
j = json.loads(lines[0])
t = [float(x) for x in open(sys.argv[2]).read().split()][2:]

def quat(r):
    a = math.sqrt(sum(x * x for x in r))
    s = math.sin(a / 2) / a if a > 0 else 0.5
    return [math.cos(a / 2)] + [s * x for x in r]

def angle_deg(q1, q2):
    return math.degrees(2 * math.acos(min(1.0, abs(sum(a * b for a, b in zip(q1, q2))))))

assert j["valid"] and j["flags"]["ambiguous"], j
alt = j["alternative"]
assert 0.01 < alt["weight"] <= 0.5, alt
truth = quat(t[:3])
kept, other = angle_deg(truth, j["cam_from_object"]["quaternion"]), angle_deg(truth, alt["quaternion"])
assert kept > 10 and other < 2, (kept, other)
assert angle_deg(quat(alt["rvec"]), alt["quaternion"]) < 1e-4, alt
assert math.dist(alt["tvec"], t[3:]) < 0.01 * t[5], (alt["tvec"], t[3:])
print(f"pose_cli_alternative_test: kept pose {kept:.1f} deg off, alternative {other:.2f} deg, "
      f"weight {alt['weight']:.3f}")
PY

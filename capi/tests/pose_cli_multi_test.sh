#!/bin/bash
# svms pose with several --layout on the fixture's two-object frame (pair.pgm, written by
# svms_capi_fixture): one line per object in the order of the layouts, each named and near its
# truth, each identical to the single-layout run's pose, one detection for both; --unknown-ids
# lists the other object's markers; a missing layout file or an ID in two layouts is refused
# with one line naming the file(s), exit 2.
# Usage: pose_cli_multi_test.sh SVMS FIXTURE_DIR
set -u
svms=$1 fixture=$2
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
cam="$fixture/true.cameramodel" module="$fixture/true_layout.json" fix="$fixture/fixture_layout.json"
run() { "$svms" pose "$fixture/pair.pgm" --camera "$cam" --response linear --quiet "$@"; }
# The frame path after the layouts too: a --layout takes one value.
"$svms" pose --camera "$cam" --response linear --quiet --layout "$module" --layout "$fix" \
  "$fixture/pair.pgm" > "$tmp/both.jsonl" || { echo "FAIL: svms pose (two layouts) exited $?"; exit 1; }
run --layout "$module" > "$tmp/module.jsonl" || { echo "FAIL: svms pose (module) exited $?"; exit 1; }
run --layout "$fix" > "$tmp/fixture.jsonl" || { echo "FAIL: svms pose (fixture) exited $?"; exit 1; }
run --layout "$module" --unknown-ids > "$tmp/unknown.jsonl" || { echo "FAIL: --unknown-ids exited $?"; exit 1; }

# Bad input: one line on stderr naming the file, exit 2, nothing on stdout.
bad() {  # bad WHAT EXPECTED_TEXT... -- ARGS
  local what=$1; shift
  local expect=()
  while [ "$1" != "--" ]; do expect+=("$1"); shift; done; shift
  run "$@" > "$tmp/bad.out" 2> "$tmp/bad.err"
  local rc=$?
  [ $rc -eq 2 ] || { echo "FAIL: $what: exit $rc, expected 2"; cat "$tmp/bad.err"; exit 1; }
  [ ! -s "$tmp/bad.out" ] || { echo "FAIL: $what: wrote to stdout"; exit 1; }
  [ "$(wc -l < "$tmp/bad.err")" -eq 1 ] || { echo "FAIL: $what: not one line:"; cat "$tmp/bad.err"; exit 1; }
  for e in "${expect[@]}"; do
    grep -qF -- "$e" "$tmp/bad.err" || { echo "FAIL: $what: no '$e' in:"; cat "$tmp/bad.err"; exit 1; }
  done
}
bad "a missing layout" "$tmp/nope.json" -- --layout "$module" --layout "$tmp/nope.json"
bad "an ID in two layouts" "$fixture/clash_layout.json: marker ID 13 is also in $module" -- \
  --layout "$module" --layout "$fixture/clash_layout.json"

python3 - "$tmp" "$fixture/pair.txt" "$module" "$fix" <<'PY'
import json, math, sys
tmp, truth_file, module_path, fixture_path = sys.argv[1:]
lines = [json.loads(l) for l in open(tmp + "/both.jsonl").read().splitlines()]
assert len(lines) == 2, lines
truth = [[float(x) for x in l.split()] for l in open(truth_file).read().splitlines()]
single = [json.loads(open(tmp + f"/{n}.jsonl").read()) for n in ("module", "fixture")]
for j, name, path, t, s in zip(lines, ["mockup (true)", "fixture"], [module_path, fixture_path],
                               truth, single):
    assert j["object"] == name and j["layout"] == path, (j["object"], j["layout"])
    assert j["valid"] and len(j["markers"]) >= 2, j
    assert j["unassigned_markers"] == [], j["unassigned_markers"]
    err_mm = 1e3 * math.dist(j["cam_from_object"]["tvec"], t[3:])
    assert err_mm < 1, (name, err_mm)
    # The same pose as the single-layout run, to the last bit.
    for key in ("cam_from_object", "covariance", "markers", "chi2", "rms", "markers_seen"):
        assert j[key] == s[key], (name, key, j[key], s[key])
    # A single layout's line has no object, layout or unassigned_markers field.
    assert not {"object", "layout", "unassigned_markers"} & set(s), sorted(s)
    assert set(j) - set(s) == {"object", "layout", "unassigned_markers"}, sorted(set(j) - set(s))
# One detection for both objects: the frame's timing is on both lines.
assert lines[0]["detect_ms"] == lines[1]["detect_ms"]
assert lines[0]["latency_ms"] == lines[1]["latency_ms"]
u = json.loads(open(tmp + "/unknown.jsonl").read())
assert sorted(u["unassigned_markers"]) == [30, 31, 32], u["unassigned_markers"]
assert u["cam_from_object"] == single[0]["cam_from_object"]
print("pose_cli_multi_test: module %.3f mm, fixture %.3f mm off; detect %.1f ms, latency %.1f ms "
      "(two layouts), %.1f ms (module alone)" % (
          1e3 * math.dist(lines[0]["cam_from_object"]["tvec"], truth[0][3:]),
          1e3 * math.dist(lines[1]["cam_from_object"]["tvec"], truth[1][3:]),
          lines[0]["detect_ms"], lines[0]["latency_ms"], single[0]["latency_ms"]))
PY

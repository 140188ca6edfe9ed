#!/usr/bin/env bash
# scripts/jpeg_edge_bound: two trials give the table with finite, positive errors, the codec's
# error above the sensor's noise of 1 code, and the stored coefficients recovered; bad options
# end with one line naming them, exit 2.
set -euo pipefail
script="$1"
out="$(mktemp -d)"
trap 'rm -rf "$out"' EXIT
fail() { echo "FAIL: $*" >&2; exit 1; }

"$script" --trials 2 --stripe 5 > "$out/table.md" 2> "$out/stderr.txt" ||
  { cat "$out/stderr.txt" >&2; fail "exit code $?"; }
/usr/bin/python3 - "$out/table.md" <<'PY' || fail "table (above)"
import math, re, sys
text = open(sys.argv[1]).read()
rows = [l for l in text.splitlines() if l.startswith("| 5 |")]
assert len(rows) == 1, text
cells = [c.strip() for c in rows[0].split("|")[1:-1]]
assert float(cells[1]) > 1.0, cells  # the codec errs by more than the sensor's 1 code
for c in (cells[2], cells[4]):
    v = [float(x) for x in c.split("/")]
    assert len(v) == 3 and all(math.isfinite(x) and 0 < x < 0.5 for x in v), cells
m = re.search(r"rebuilt from them within 1 code, ([0-9.]+) %", text)
assert m and float(m.group(1)) == 100, text
PY
for bad in "--trials 0" "--quality 101" "--blur 0" "--stripe 20" "--nonesuch 1"; do
  rc=0
  # shellcheck disable=SC2086
  "$script" $bad > /dev/null 2> "$out/bad.txt" || rc=$?
  [[ $rc -eq 2 ]] || fail "$bad: exit code $rc, expected 2"
  opt="${bad%% *}"
  [[ $(wc -l < "$out/bad.txt") -eq 1 ]] || fail "$bad: not one line: $(cat "$out/bad.txt")"
  grep -q -- "$opt" "$out/bad.txt" || fail "$bad: the message does not name $opt: $(cat "$out/bad.txt")"
done
echo PASS

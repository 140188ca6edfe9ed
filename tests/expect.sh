# Helpers the shell tests share (sourced): pass/fail counters and `expect`.
fails=0 passes=0
pass() { passes=$((passes + 1)); }
fail() { echo "FAIL: $*" >&2; fails=$((fails + 1)); }
# expect CODE "substring of stdout+stderr" -- command...
expect() {
  local code=$1 want=$2; shift 2
  local out rc
  out=$("$@" 2>&1); rc=$?
  if [ "$rc" -ne "$code" ]; then fail "$* -> exit $rc, expected $code; output: $out"; return; fi
  if [ -n "$want" ] && ! grep -qF -- "$want" <<<"$out"; then fail "$* -> output lacks '$want': $out"; return; fi
  pass
}

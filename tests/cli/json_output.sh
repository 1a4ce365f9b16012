#!/usr/bin/env bash
# Every command's --json output (sirupp fk, sirupp ik; docs/json.md) parses as JSON and has the
# documented shape: for every shipped model and for a model whose name holds a tab, quotes, a
# backslash and a non-ASCII letter; ik with solutions and without (exit 1, reason given).
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
command -v python3 >/dev/null || { echo "FAIL python3 not found (scripts/install-deps.sh)"; exit 1; }
dir=$(mktemp -d)
trap 'rm -rf "$dir" "$out" "$err"' EXIT

# check_json NAME KIND [EXPECTED_MODEL_NAME]: $out holds one JSON document of kind fk or ik.
check_json() {
  python3 - "$out" "$2" "${3:-}" <<'PY' || { echo "FAIL $1: not the documented JSON:"; cat "$out"; fail=1; }
import json, sys
path, kind, name = sys.argv[1:4]
text = open(path, encoding="utf-8").read()
assert text.endswith("\n") and text.count("\n") == 1, "one line"
d = json.loads(text)
if name:
    assert d["model"] == name, repr(d["model"])
def numbers(v, n=None):
    assert isinstance(v, list) and (n is None or len(v) == n), v
    assert all(x is None or isinstance(x, (int, float)) for x in v), v
if kind == "fk":
    assert list(d) == ["model", "joints", "joint_units", "position_m", "position_file_units",
                       "file_length_unit", "rotation", "rpy_deg", "quaternion_wxyz",
                       "manipulability", "singularities"], list(d)
    numbers(d["joints"]); numbers(d["position_m"], 3); numbers(d["position_file_units"], 3)
    assert len(d["rotation"]) == 3; [numbers(row, 3) for row in d["rotation"]]
    numbers(d["rpy_deg"], 3); numbers(d["quaternion_wxyz"], 4)
    assert isinstance(d["manipulability"], (int, float))
    assert all(isinstance(s, str) for s in d["singularities"])
else:
    assert list(d) == ["model", "solver", "ok", "reason", "joint_units", "solutions"], list(d)
    assert d["solver"] in ("closed-form", "numeric") and isinstance(d["ok"], bool)
    assert (d["reason"] is None) == d["ok"], d["reason"]
    for s in d["solutions"]:
        assert list(s) == ["config", "joints", "position_error_m", "rotation_error_rad",
                           "singularities"], list(s)
        assert s["config"] is None or isinstance(s["config"], str)
        numbers(s["joints"])
PY
}

count=0
for model in config/robots/*.yaml config/robots/planar3.yaml; do
  name=$(basename "$model" .yaml)
  if [[ $count -eq 3 ]]; then
    # The same arm named with a tab, quotes, a backslash and a non-ASCII letter.
    model="$dir/odd.yaml"
    sed 's/^name: planar3/name: "tab\there \\"q\\" \\\\ \\u00e9"/' config/robots/planar3.yaml >"$model"
    name=$'tab\there "q" \\ \u00e9'
  fi
  joints=$("$SIRUPP" model check "$model" | sed -n 's/.*: \([0-9]*\) joints,.*/\1/p')
  zeros=$(printf '0 %.0s' $(seq "$joints"))
  run "fk $name" 0 fk --model "$model" --deg $zeros --json
  check_json "fk $name" fk "$name"
  run "ik unreachable $name" 1 ik --model "$model" --pose 9 9 9 0 0 0 --json
  check_json "ik unreachable $name" ik "$name"
  count=$((count + 1))
done
run "ik puma" 0 ik --model config/robots/puma260.yaml --pose 0.2 -0.14 0.5 0 90 0 --json
check_json "ik puma" ik puma260
python3 -c 'import json,sys; d=json.load(open(sys.argv[1])); assert d["ok"] and len(d["solutions"]) >= 2' "$out" ||
  { echo "FAIL ik puma: expected solutions"; fail=1; }

finish json_output "$count models, fk and ik each, one with a tab in its name"

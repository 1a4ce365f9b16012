#!/bin/bash
# Identification's loop on small data (issue 20): two movement sets run in one process
# (`sirupp fit-emulator --evaluate --data`) with the model and with a model `sirupp identify`
# wrote from the first run; `sirupp report RUN2 --compare RUN1` prints both runs' virtual-vs-real
# means side by side with the table means and the change in %, which the test recomputes from the
# printed rows. `identify` lowers its printed measure; `--last-move` fits fewer samples (the last
# move of each file). Bad arguments (a missing --compare file, --compare with --reference, a demo
# --model that does not load or clashes with the layout's own) exit 2 before anything runs.
# Needs $SIRUPP.
set -u
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
fail=0
bad() { echo "FAIL $*"; fail=1; }
expect() {  # $1 label, $2 exit, then the command; leaves $work/out and $work/err
  local label=$1 want=$2
  shift 2
  "$@" >"$work/out" 2>"$work/err" </dev/null
  local code=$?
  [[ $code -eq $want ]] || bad "$label: exit $code, expected $want: $(head -3 "$work/err")"
}
model=config/robots/puma260.yaml

expect "run A" 0 "$SIRUPP" fit-emulator --evaluate --sets 1 3 --data "$work/a"
expect "identify" 0 "$SIRUPP" identify "$work/a" --model $model --out "$work/m2.yaml" \
  --joints 1 3 --evaluations 12
# The fit's table is the first one (the moves check's follows it).
fit_row() { grep -m 1 '^| 1 | ' "$work/out"; }
samples_all=$(fit_row | sed -n 's/^| 1 | \([0-9]*\) |.*/\1/p')
# The moves check: a row per fitted joint under its header, M and M2 under the error limit.
grep -q '^| joint | M (counts) | M2 (counts) | error limit (counts) |' "$work/out" ||
  bad "identify: no moves check table"
[[ $(grep -c '^| [13] | [0-9]* | [0-9]* | 4000 | ' "$work/out") -eq 2 ]] ||
  bad "identify: the moves check's rows for joints 1 and 3: $(grep '4000' "$work/out")"
# What the fit lowers (the sets' last moves' transient and steady means): no higher after.
measure=$(fit_row | sed -n 's/^| 1 | [0-9]* | \([0-9.]*\) | \([0-9.]*\) |.*/\1 \2/p')
awk -v m="$measure" 'BEGIN { split(m, v, " "); exit !(v[1] > 0 && v[2] <= v[1]) }' ||
  bad "identify: joint 1's measure before/after '$measure'"
# --last-move: only each file's last move (here the move after the hold before it).
expect "identify --last-move" 0 "$SIRUPP" identify "$work/a" --model $model \
  --out "$work/m2last.yaml" --joints 1 --evaluations 5 --last-move
samples_last=$(fit_row | sed -n 's/^| 1 | \([0-9]*\) |.*/\1/p')
[[ -n $samples_all && -n $samples_last && $samples_last -gt 0 && $samples_last -lt $samples_all ]] ||
  bad "identify --last-move: joint 1 samples '$samples_last', all '$samples_all'"
expect "identify --last-move=x" 2 "$SIRUPP" identify "$work/a" --model $model \
  --out "$work/m2x.yaml" --last-move=x
[[ ! -e $work/m2x.yaml ]] || bad "identify --last-move=x: wrote its model"
expect "identify --other-moves 2" 2 "$SIRUPP" identify "$work/a" --model $model \
  --out "$work/m2x.yaml" --other-moves 2
grep -q "other-moves" "$work/err" || bad "--other-moves 2: not named: $(cat "$work/err")"
expect "run B" 0 "$SIRUPP" fit-emulator --evaluate --sets 1 3 --virtual-model "$work/m2.yaml" \
  --data "$work/b"
expect "report --compare" 0 "$SIRUPP" report "$work/b" --compare "$work/a" --out "$work/rep" \
  --no-plots
cp "$work/out" "$work/compare.md"
grep -q "^## Comparison: virtual vs real" "$work/compare.md" || bad "no comparison section"
grep -q "Transient, compared | Steady state, compared" "$work/compare.md" ||
  bad "Table II has no compared columns"
grep -q "^## Comparison" "$work/rep/report.md" || bad "report.md has no comparison section"
python3 - "$work/compare.md" <<'PY' || fail=1
import re, sys
text = open(sys.argv[1]).read()
section = text[text.index("## Comparison"):]
rows = re.findall(r"^\| (set\d) \| (\d) \| ([\d.]+) \| ([\d.]+) \| ([\d.]+) \| ([\d.]+) \|$",
                  section, re.M)
if sorted((s, j) for s, j, *_ in rows) != [("set1", "1"), ("set3", "3")]:
    sys.exit(f"FAIL comparison rows: {rows}")
a = [float(r[k]) for r in rows for k in (2, 4)]
b = [float(r[k]) for r in rows for k in (3, 5)]
m = re.search(r"A ([\d.]+) deg, B ([\d.]+) deg, change ([+-][\d.]+) %", section)
if not m:
    sys.exit("FAIL no means line")
mean_a, mean_b, change = (float(x) for x in m.groups())
if abs(mean_a - sum(a) / 4) > 0.01 or abs(mean_b - sum(b) / 4) > 0.01:
    sys.exit(f"FAIL means {mean_a} {mean_b} from rows {a} {b}")
if abs(change - 100 * (mean_b - mean_a) / mean_a) > 0.6:
    sys.exit(f"FAIL change {change} % for {mean_a} -> {mean_b}")
print(f"comparison: A {mean_a} deg, B {mean_b} deg, change {change} %")
PY

expect "--compare missing file" 2 "$SIRUPP" report "$work/b" --compare "$work/none.csv" \
  --out "$work/rep2"
grep -q "none.csv" "$work/err" || bad "--compare missing file: not named: $(cat "$work/err")"
expect "--compare and --reference" 2 "$SIRUPP" report "$work/b" --compare "$work/a" \
  --reference paper --out "$work/rep3"
grep -q "compare" "$work/err" || bad "--compare with --reference: $(cat "$work/err")"
expect "--compare without files" 2 "$SIRUPP" report "$work/b" --compare

expect "demo --model missing" 2 "$SIRUPP" demo --model "$work/none.yaml" --out "$work/demo1"
grep -q "none.yaml" "$work/err" || bad "demo --model missing: not named: $(cat "$work/err")"
[[ ! -e $work/demo1 ]] || bad "demo --model missing: made its results folder"
sed 's|run: sirupp-sim --mode realtime --pose ready|run: sirupp-sim --mode realtime --pose ready --model x.yaml|' \
  config/labs/demo.yaml >"$work/layout.yaml"
expect "demo --model clash" 2 "$SIRUPP" demo --model $model --layout "$work/layout.yaml" \
  --out "$work/demo2"
grep -q "layout.yaml:[0-9]*: process 'sim' names its model already" "$work/err" ||
  bad "demo --model clash: $(cat "$work/err")"
[[ ! -e $work/demo2 ]] || bad "demo --model clash: made its results folder"
exit $fail

#!/bin/bash
# Fault: sirupp-logger killed (kill -9) while it writes, in the middle of a linked move (sim
# realtime, controller, emulator and bridge, all as processes on a private network). What
# docs/logging.md promises, checked on the killed logger's file:
#  - every complete line parses: the header's '# ' lines up to the column line its first line
#    names, then CSV rows with the column line's number of fields, each empty or a number; at most
#    a final partial line (a kill during the one write()) is missing;
#  - no '# end:' line, and `sirupp report` accepts the file, says it was not closed, and analyses
#    the move that was cut;
#  - the file holds what the logger received up to the kill: its last row is at most 0.5 s (sim
#    time; the docs promise ~0.1 s) before the last row a second logger had written just before;
#  - the set-point, virtual and real columns were all being filled.
# Needs SIRUPP, SIRUPP_SIM, SIRUPP_CONTROL, SIRUPP_HARDWARE, SIRUPP_EMU, SIRUPP_LOGGER, ARM_WATCH.
set -u
PRIVATE_NET_PORT=7743
source "$(dirname "$0")/private_net.sh"
source "$(dirname "$0")/lib.sh"
source "$(dirname "$0")/rig.sh"
work=$(mktemp -d)
trap 'rig_cleanup; rm -rf "$work" "$out" "$err"' EXIT
started=$SECONDS

rig_start "" "" "" || finish fault_logger_kill
spawn ref "" "$SIRUPP_LOGGER" --lcm-url "$URL" --out "$work/data" --name ref
sleep 1

# The time_s of a data file's second-last row: the last line may be cut short.
last_time() { awk -F, '/^[0-9]/ { t = prev; prev = $1 } END { print t }' "$1"; }

"$SIRUPP" move joints --deg 90 -90 90 0 45 0 --lcm-url "$URL" >"$work/move.out" 2>&1 ||
  { echo "FAIL: move"; cat "$work/move.out"; fail=1; }
wait_for "joint 1 under way" 10 \
  bash -c '"$ARM_WATCH" --lcm-url "$0" --seconds 0.1 | awk "\$1 == \"virtual\" { exit !(\$5 > 20) }"' "$URL"
file="$work/data/run-01-manual.csv"
ref_time=$(last_time "$work/data/ref-01-manual.csv")
kill -9 "${rig_pid[logger]}"
wait "${rig_pid[logger]}" 2>/dev/null
"$SIRUPP" move joints --deg 0 -90 90 0 45 0 --wait --lcm-url "$URL" --timeout 30 >"$work/back.out" 2>&1 ||
  { echo "FAIL: move back"; cat "$work/back.out"; fail=1; }
expect_alive emu sim control hardware ref
rig_stop ref control hardware emu sim

[[ -s "$file" ]] || { echo "FAIL: no $file: $(ls "$work/data")"; finish fault_logger_kill; }
# Line by line. The last line counts as partial when the file does not end with a line end.
partial=0
[[ -z "$(tail -c 1 "$file")" ]] || partial=1
awk -F, -v partial="$partial" '
  NR == 1 {
    if (!match($0, /the column line is line [0-9]+/)) { print "FAIL line 1: no column line number: " $0; bad = 1; exit }
    column_line = substr($0, RSTART + 24, RLENGTH - 24) + 0
  }
  { lines = NR; text[NR] = $0; fields[NR] = NF }
  END {
    if (bad) exit 1
    last = lines - partial
    for (i = 1; i < column_line; i++) {
      if (substr(text[i], 1, 2) != "# ") { print "FAIL line " i ": a header line without \"# \": " text[i]; exit 1 }
    }
    if (substr(text[column_line], 1, 7) != "time_s,") { print "FAIL line " column_line ": not the column line: " text[column_line]; exit 1 }
    n = fields[column_line]
    for (i = column_line + 1; i <= last; i++) {
      if (substr(text[i], 1, 6) == "# end:") { print "FAIL line " i ": an end line in a killed logger'\''s file"; exit 1 }
      if (substr(text[i], 1, 2) == "# ") { notes++; continue }  # gain changes, real-time factor
      if (fields[i] != n) { print "FAIL line " i ": " fields[i] " fields, the column line has " n; exit 1 }
      m = split(text[i], cell, ",")
      for (k = 1; k <= m; k++) {
        if (cell[k] != "" && cell[k] !~ /^-?[0-9]+(\.[0-9]+)?([eE][-+]?[0-9]+)?$/) { print "FAIL line " i ", column " k ": \"" cell[k] "\" is not a number"; exit 1 }
      }
    }
    printf "killed logger'\''s file: %d header lines, %d complete rows of %d columns, %d comment lines among them, %s\n", column_line - 1, last - column_line - notes, n, notes, partial ? "a partial last line" : "ends with a whole line"
  }' "$file" || fail=1

filled=$(awk -F, '/^#/ { next } !header { header = 1; for (i = 1; i <= NF; i++) col[$i] = i; next }
  $col["j1_set_deg"] != "" && $col["j1_virt_deg"] != "" && $col["j1_real_deg"] != "" { n++ } END { print n + 0 }' "$file")
[[ $filled -ge 100 ]] || { echo "FAIL: $filled rows with set-point, virtual and real angles"; fail=1; }
killed_time=$(last_time "$file")
echo "last row: ${killed_time:-?} s; the reference logger had written up to ${ref_time:-?} s just before the kill"
awk -v k="${killed_time:-0}" -v r="${ref_time:-1e9}" 'BEGIN { exit !(k >= r - 0.5) }' ||
  { echo "FAIL: the killed logger's file ends at ${killed_time:-?} s, before ${ref_time:-?} s - 0.5 s"; fail=1; }

run report_killed 0 report "$file" --out "$work/report" --no-plots
has report_killed "$err" "no '# end:' line: the logger did not close this file"
has report_killed "$out" "| 1 (waist) | from 0.0 to "
finish fault_logger_kill "$TEST_NET network, $((SECONDS - started)) s"

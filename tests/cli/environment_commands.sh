#!/usr/bin/env bash
# `sirupp env check` and `sirupp env show` as a user meets them: exit codes, summaries, the listing
# and the message for every file of the malformed-environment corpus. Run by CTest from the source
# root with SIRUPP set to the binary.
set -u
source "$(dirname "$0")/lib.sh"

# Every shipped environment is valid.
for env in config/environments/*.xml; do
  run "check $env" 0 env check "$env"
  has "check $env" "$out" "$env: ok: environment"
  lines "check $env is one line" "$out" 1
done
run "check table" 0 env check config/environments/table.xml
has "check table summary" "$out" 'config/environments/table.xml: ok: environment "table", 8 objects (5 static, 3 free)'
run "check empty" 0 env check config/environments/empty.xml
has "check empty summary" "$out" 'ok: environment "empty", 0 objects (0 static, 0 free)'

run "show table" 0 env show config/environments/table.xml
has "show table header" "$out" 'Environment "table" from config/environments/table.xml: 8 objects (5 static, 3 free)'
has "show table top" "$out" "table_top        box       0.3500 x 0.6000 x 0.0200      [ 0.4250  0.0000  0.1100]"
has "show leg" "$out" "leg_front_right  cylinder  radius 0.0150 length 0.1000   [ 0.5700 -0.2700  0.0500]"
has "show yaw" "$out" "[   0.0    0.0   30.0]   free 0.040 kg"
has "show ball" "$out" "ball             sphere    radius 0.0200"
has "show ball bounces" "$out" "free 0.030 kg   0.5       0.6"
run "show empty" 0 env show config/environments/empty.xml
has "show empty" "$out" "No objects: the robot stands alone."

# The malformed corpus: exit 2 and one line, "error: FILE:LINE: ...", with the text of line 2.
count=0
for bad in tests/data/bad_environments/*.xml; do
  expect=$(sed -n '2s/^<!-- expect: \(.*\) -->$/\1/p' "$bad")
  [[ -n $expect ]] || { echo "FAIL $bad: no expect line"; fail=1; }
  run "check $bad" 2 env check "$bad"
  has "message of $bad" "$err" "error: $bad:$expect"
  lines "no ok line for $bad" "$out" 0
  lines "message of $bad is one line" "$err" 1
  count=$((count + 1))
done
[[ $count -ge 15 ]] || { echo "FAIL corpus has only $count files"; fail=1; }

# Several files: each gets its line, and one bad file makes the exit code 2.
run "check several" 2 env check config/environments/table.xml tests/data/bad_environments/18_size_zero.xml config/environments/empty.xml
lines "check several ok lines" "$out" 2
has "check several error" "$err" "error: tests/data/bad_environments/18_size_zero.xml:4: box \"table_top\".size: z = 0 is not allowed"
run "show bad" 2 env show tests/data/bad_environments/31_color_out_of_range.xml
has "show bad" "$err" "error: tests/data/bad_environments/31_color_out_of_range.xml:4: box \"table_top\".color: r = 140 is not allowed"
run "missing file" 2 env check /nonexistent/env.xml
has "missing file" "$err" "error: /nonexistent/env.xml: cannot read the file: No such file or directory"

# Usage errors: exit 2.
run "env alone" 2 env
has "env alone" "$err" "env: expected a subcommand; allowed: check, show"
run "env bad subcommand" 2 env list config/environments/table.xml
has "env bad subcommand" "$err" "unknown subcommand 'list'; allowed: check, show"
run "check without file" 2 env check
has "check without file" "$err" "env check: missing FILE"
run "show two files" 2 env show config/environments/table.xml config/environments/empty.xml
has "show two files" "$err" "env show: FILE takes 1 value(s), got 2"
run "env help" 0 env --help
has "env help" "$out" "usage: sirupp env [options] COMMAND"
run "help lists env" 0 help
has "help lists env" "$out" "environment files: check, show"

finish cli_environment_commands "$count malformed environments"

#!/usr/bin/env bash
# `sirupp plan check` on plans a user should not be able to send: too large for one ARM_PLAN
# message, binary garbage, a byte-order mark. Exit codes and messages; no rig needed.
set -u
source "$(dirname "$0")/lib.sh"
dir=$(mktemp -d)
trap 'rm -rf "$dir" "$out" "$err"' EXIT

# 420 KB of plan: refused up front, naming the size and the limit (it was lost on ARM_PLAN).
for i in $(seq 20000); do echo "move j1=10 speed=50%"; done >"$dir/big.plan"
size=$(stat -c %s "$dir/big.plan")
run "big plan" 2 plan check "$dir/big.plan"
has "big plan message" "$err" "error: $dir/big.plan: the plan file has $size bytes; allowed at most 262144 (256 KiB, so that it travels in one ARM_PLAN message)"
lines "big plan one line" "$err" 1

# Binary garbage is escaped, never written raw to the terminal.
printf 'move j1=10\n\x1b[2J\x07\xff\xfe\x01\n' >"$dir/garbage.plan"
run "garbage plan" 2 plan check "$dir/garbage.plan"
has "garbage escaped" "$err" "garbage.plan:2:1: \\x1B[2J\\x07\\xFF\\xFE\\x01: unknown statement '\\x1B[2J\\x07\\xFF\\xFE\\x01'"
if LC_ALL=C grep -q $'[\x01-\x08\x0b-\x1f\x7f-\xff]' "$err"; then
  echo "FAIL garbage plan: raw control or non-ASCII bytes in the message"; fail=1
fi

# A byte-order mark (as some editors write) is skipped.
printf '\xef\xbb\xbfmove j1=10\nwait done\n' >"$dir/bom.plan"
run "bom plan" 0 plan check "$dir/bom.plan"
has "bom plan ok" "$out" "bom.plan: ok: 2 steps, 1 moves"

finish plan_commands

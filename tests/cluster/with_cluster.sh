#!/usr/bin/env bash
# Runs a command beside a one-node Slurm cluster of its own (slurm_cluster.sh): starts it in a
# temporary folder, runs the command with SLURM_CONF exported, then stops the cluster (also when
# the command fails or the run is interrupted) and fails when anything of it was left behind.
#   tests/cluster/with_cluster.sh COMMAND [ARGS...]
# Skips (77) where Slurm is not installed, except in CI (lib.sh).
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
# shellcheck source=tests/cluster/lib.sh
source "$here/lib.sh"
require_slurm
[[ $# -ge 1 ]] || { echo "usage: $0 COMMAND [ARGS...]" >&2; exit 2; }
work=$(mktemp -d /tmp/sirupp-slurm.XXXXXX)
status=0
finish() {
  "$here/slurm_cluster.sh" stop "$work/cluster" || status=1
  rm -rf "$work"
  exit $status
}
trap finish EXIT
trap 'status=130; exit' INT TERM
eval "$("$here/slurm_cluster.sh" start "$work/cluster")"
export SLURM_TEST_DIR="$work/cluster"
"$@" || status=$?

# Shared by the cluster tests (source it). require_slurm: exit 77 (CTest's skip) with the reason
# where Slurm or munge is not installed, or where not root; in CI (CI=true) that is a failure
# instead, so a missing install step cannot pass as a skip.
require_slurm() {
  local missing=()
  local tool
  for tool in munged mungekey slurmctld slurmd sbatch squeue scancel; do
    command -v "$tool" >/dev/null || missing+=("$tool")
  done
  local why=""
  [[ ${#missing[@]} -eq 0 ]] || why="not installed: ${missing[*]} (scripts/install-deps.sh --services)"
  [[ -n "$why" || $(id -u) -eq 0 ]] || why="needs root (slurmd starts jobs as their users)"
  [[ -z "$why" ]] && return 0
  if [[ "${CI:-}" == true ]]; then
    echo "FAIL: $why" >&2
    exit 1
  fi
  echo "SKIP: $why" >&2
  exit 77
}

#!/usr/bin/env bash
# `sirupp model export` as a user meets it: every shipped model (config/robots/*.yaml) exported as
# URDF, which check_urdf (liburdfdom-tools) must accept with the whole chain, and as MJCF, which
# must be well-formed XML (MuJoCo itself loads it in test_model_export_mujoco); writing to '-';
# exit codes for bad arguments, a bad model and an unwritable file.
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
command -v check_urdf >/dev/null || { echo "FAIL check_urdf not found: install liburdfdom-tools (scripts/install-deps.sh)"; exit 1; }
command -v python3 >/dev/null || { echo "FAIL python3 not found (scripts/install-deps.sh)"; exit 1; }
dir=$(mktemp -d)
trap 'rm -rf "$dir" "$out" "$err"' EXIT

count=0
for model in config/robots/*.yaml; do
  name=$(basename "$model" .yaml)
  run "export $name" 0 model export --urdf "$dir/$name.urdf" --mjcf "$dir/$name.xml" "$model"
  if check_urdf "$dir/$name.urdf" >"$dir/$name.check" 2>&1; then
    joints=$("$SIRUPP" model check "$model" | sed -n 's/.*: \([0-9]*\) joints,.*/\1/p')
    # The chain: world, the base, one link per joint, the tool.
    links=$(grep -c 'child(1):' "$dir/$name.check")
    [[ $links -eq $((joints + 2)) ]] || { echo "FAIL check_urdf $name: $links links below world, expected $((joints + 2))"; cat "$dir/$name.check"; fail=1; }
    echo "check_urdf $name: $(grep -c . "$dir/$name.check") lines, $links links below world: ok"
  else
    echo "FAIL check_urdf $name rejected the URDF:"; cat "$dir/$name.check"; fail=1
  fi
  python3 -c 'import sys, xml.etree.ElementTree as E; E.parse(sys.argv[1])' "$dir/$name.xml" \
    || { echo "FAIL MJCF of $name is not well-formed XML"; fail=1; }
  count=$((count + 1))
done
[[ $count -ge 3 ]] || { echo "FAIL only $count shipped models"; fail=1; }

run "urdf to stdout" 0 model export --urdf - config/robots/planar3.yaml
has "urdf to stdout" "$out" '<robot name="planar3"'
run "mjcf to stdout" 0 model export --mjcf - config/robots/planar3.yaml
has "mjcf to stdout" "$out" '<mujoco model="planar3">'
run "help" 0 model export --help
has "help" "$out" "usage: sirupp model export"

run "nothing to write" 2 model export config/robots/planar3.yaml
has "nothing to write" "$err" "give --urdf FILE and/or --mjcf FILE"
run "no model" 2 model export --urdf "$dir/x.urdf"
run "two models" 2 model export --urdf "$dir/x.urdf" config/robots/planar3.yaml config/robots/puma260.yaml
run "unknown option" 2 model export --sdf "$dir/x.sdf" config/robots/planar3.yaml
run "both to stdout" 2 model export --urdf - --mjcf - config/robots/planar3.yaml
run "bad model" 2 model export --urdf "$dir/x.urdf" tests/data/bad_models/$(ls tests/data/bad_models | head -1)
run "unwritable" 1 model export --urdf "$dir/no/such/dir/x.urdf" config/robots/planar3.yaml
has "unwritable" "$err" "cannot write"

finish cli_model_export "$count models through check_urdf"

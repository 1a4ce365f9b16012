#!/usr/bin/env bash
# `sirupp fk` and `sirupp ik` as a user meets them: values, exit codes and messages.
set -u
source "$(dirname "$0")/lib.sh"
puma=config/robots/puma260.yaml

# Zero pose worked out by hand from Table I: (8, -5.6, 23.2) inches, identity rotation.
run "fk zero" 0 fk --model $puma --deg 0 0 0 0 0 0
has "fk zero position" "$out" "tool position     [0.203200 -0.142240 0.589280] m = [8.0000 -5.6000 23.2000] inch"
has "fk zero rotation" "$out" "rotation matrix   [1.000000 0.000000 0.000000]"
has "fk zero singular" "$out" "singularities     wrist"
run "fk default model" 0 fk --deg 0 0 0 0 0 0
has "fk default model is the PUMA 260" "$out" "tool position     [0.203200 -0.142240 0.589280] m"
run "fk json" 0 fk --model $puma --rad 0 0 0 0 0 0 --json
has "fk json" "$out" '"position_m":[0.2032,-0.14224,0.58928]'
run "fk help" 0 fk --help
has "fk help" "$out" "R = Rz(yaw) Ry(pitch) Rx(roll)"

# A reachable pose: four of the eight solutions lie inside the PUMA 260's limits.
run "ik all" 0 ik --model $puma --pose 0.2 -0.14 0.5 0 90 0
has "ik all" "$out" "right-down-noflip  [0.897 6.895 -24.016 -0.939 107.119 -0.276] deg"
has "ik outside" "$out" "outside the joint limits:"
run "ik config" 0 ik --model $puma --pose 0.2 -0.14 0.5 0 90 0 --config left-up-flip
[[ $(grep -c "deg  |error|" "$out") -eq 1 ]] || { echo "FAIL ik config: not exactly one solution"; cat "$out"; fail=1; }
run "ik nearest" 0 ik --model $puma --pose 0.2 -0.14 0.5 0 90 0 --config nearest --from 90 -70 -20 90 -90 80
has "ik nearest" "$out" "left-up-flip"
run "ik json" 0 ik --model $puma --pose 0.2 -0.14 0.5 0 90 0 --json
has "ik json" "$out" '"solver":"closed-form","ok":true'
run "ik numeric planar" 0 ik --model config/robots/planar3.yaml --pose 0.45 0 0.75 90 0 0
has "ik numeric planar" "$out" "numeric solver"

# No solution: exit 1 and the reason.
run "ik unreachable" 1 ik --model $puma --pose 2 0 0 0 0 0
has "ik unreachable" "$out" "no solution: unreachable: the wrist centre is 2.03195 m from the shoulder"
run "ik limits" 1 ik --model $puma --pose 0.3 0.1 0.3 180 0 0
has "ik limits" "$out" "no solution: outside joint limits"

# Bad arguments: exit 2 and one line naming the problem.
run "fk count" 2 fk --model $puma --deg 1 2 3
has "fk count" "$err" "fk: --deg Q1 .. QN takes 6 value(s), got 3"
run "fk both" 2 fk --model $puma --deg 0 0 0 0 0 0 --rad 0 0 0 0 0 0
run "fk number" 2 fk --model $puma --deg 0 0 x 0 0 0
has "fk number" "$err" "fk --deg value 3: 'x' is not a finite number"
run "fk unknown" 2 fk --model $puma --degrees 0
has "fk unknown" "$err" "unknown option '--degrees'"
run "ik missing pose" 2 ik --model $puma
has "ik missing pose" "$err" "ik: missing --pose X Y Z ROLL PITCH YAW"
run "ik bad config" 2 ik --model $puma --pose 0.2 -0.14 0.5 0 90 0 --config sideways
run "ik config not applicable" 2 ik --model config/robots/planar3.yaml --pose 0.45 0 0.75 90 0 0 --config left-up-flip
has "ik config not applicable" "$err" "it uses modified DH"
run "ik bad model" 2 ik --model tests/data/bad_models/07_mass_negative.yaml --pose 0 0 0 0 0 0
has "ik bad model" "$err" "07_mass_negative.yaml:29:14: links[1].mass_kg"

finish cli_kinematics_commands

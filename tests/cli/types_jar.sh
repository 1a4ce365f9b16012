#!/usr/bin/env bash
# The Java jar of our LCM types holds one class per .lcm file, each with the LCM_FINGERPRINT field that
# lcm-spy uses to recognise a channel's type.
set -u
jar_file=$1
[[ -s "$jar_file" ]] || { echo "FAIL: $jar_file missing or empty"; exit 1; }
listing=$(jar tf "$jar_file")
fail=0
n=0
for lcm in lcmtypes/*.lcm; do
  type=$(basename "$lcm" .lcm)
  grep -qx "sirupp/$type.class" <<<"$listing" || { echo "FAIL: sirupp/$type.class not in the jar"; fail=1; }
  n=$((n + 1))
done
fields=$(javap -cp "$jar_file:/usr/share/java/lcm.jar" sirupp.arm_state_t sirupp.image_t 2>&1)
[[ $(grep -c "static final long LCM_FINGERPRINT;" <<<"$fields") -eq 2 ]] || {
  echo "FAIL: LCM_FINGERPRINT missing"; echo "$fields"; fail=1; }
[[ $fail -eq 0 ]] || exit 1
echo "types jar: $n types, fingerprints present"

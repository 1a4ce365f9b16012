#!/usr/bin/env bash
# The package test's last step (CTest fixture cleanup): `apt-get purge sirupp`, then nothing of
# the package is left: none of the paths it installed (install.sh kept the list), no /etc/sirupp,
# /var/lib/sirupp, byte-code, service user or group, process of that user, or dpkg record.
# Usage: purge.sh BUILD_DIR
set -u
source "$(dirname "$0")/lib.sh"
build=${1:?usage: purge.sh BUILD_DIR}
list="$build/packages/sirupp.files"
export DEBIAN_FRONTEND=noninteractive
uid=$(id -u sirupp 2>/dev/null || true)

t=$(now)
apt-get purge -y -qq sirupp >"$build/packages/apt-purge.log" 2>&1 ||
  { echo "FAIL apt-get purge"; cat "$build/packages/apt-purge.log"; exit 1; }
echo "apt-get purge: $(since "$t") s"

status=$(dpkg-query -W -f='${Status}' sirupp 2>/dev/null || true)
[[ -z "$status" || "$status" == "unknown ok not-installed" || "$status" == "deinstall ok not-installed" ]] ||
  { echo "FAIL dpkg still knows sirupp: $status"; fail=1; }
if [[ -f "$list" ]]; then
  while read -r path; do
    [[ -d "$path" && ! -L "$path" ]] && continue  # folders shared with other packages (/usr/bin)
    [[ -e "$path" || -L "$path" ]] && { echo "FAIL left: $path"; fail=1; }
  done <"$list"
else
  echo "FAIL no file list from install.sh ($list)"; fail=1
fi
for path in /usr/share/sirupp /usr/include/sirupp /usr/lib/python3/dist-packages/sirupp \
            /usr/share/doc/sirupp /etc/sirupp /var/lib/sirupp; do
  [[ -e "$path" ]] && { echo "FAIL left: $path"; ls -la "$path" | head; fail=1; }
done
getent passwd sirupp >/dev/null && { echo "FAIL the user sirupp is left"; fail=1; }
getent group sirupp >/dev/null && { echo "FAIL the group sirupp is left"; fail=1; }
if [[ -n "$uid" ]]; then
  left=$(ps -o pid=,comm= -u "$uid" 2>/dev/null)
  [[ -z "$left" ]] || { echo "FAIL processes of uid $uid left: $left"; fail=1; }
fi
found=$(find /usr /etc /var /opt -xdev \( -iname '*sirupp*' \) -not -path '/var/tmp/*' 2>/dev/null)
[[ -z "$found" ]] || { echo "FAIL paths named sirupp left: $found"; fail=1; }
finish package_purge

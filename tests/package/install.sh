#!/usr/bin/env bash
# The package test's first step (CTest fixture sirupp_package): builds the Debian package from the
# build tree given (scripts/package.sh --lintian: no lintian error), installs it with apt (after a
# purge of any sirupp installed before), and checks what the maintainer scripts made and that
# systemd-analyze accepts the unit. Prints the package's size, the install time and lintian's
# report. Usage: install.sh BUILD_DIR
set -u
source "$(dirname "$0")/lib.sh"
build=${1:?usage: install.sh BUILD_DIR}
root=$(cd "$(dirname "$0")/../.." && pwd)
out="$build/packages"
export DEBIAN_FRONTEND=noninteractive

if dpkg-query -W -f='${Status}' sirupp 2>/dev/null | grep -q "installed\|config-files"; then
  apt-get purge -y -qq sirupp >/dev/null 2>&1 || { echo "FAIL: could not purge the sirupp installed before"; exit 1; }
fi

t=$(now)
mkdir -p "$out"
"$root/scripts/package.sh" --build-dir "$build" --out "$out" --lintian >"$out/package.out" 2>"$out/lintian.txt"
rc=$?
deb=$(tail -n 1 "$out/package.out")
cat "$out/lintian.txt"
[[ $rc -eq 0 && -f "$deb" ]] || { echo "FAIL package.sh (exit $rc)"; exit 1; }
echo "package: $deb, $(stat -c %s "$deb") bytes, made in $(since "$t") s"

t=$(now)
apt-get install -y -qq --no-install-recommends "$deb" >"$out/apt-install.log" 2>&1 ||
  { echo "FAIL apt-get install"; cat "$out/apt-install.log"; exit 1; }
echo "apt-get install of the .deb: $(since "$t") s"
dpkg -L sirupp | sort >"$out/sirupp.files"
echo "installed: $(wc -l <"$out/sirupp.files") paths"

# What the maintainer scripts made: a system user with no login, its folders.
entry=$(getent passwd sirupp)
check "service user" test -n "$entry"
IFS=: read -r _ _ uid _ _ home shell <<<"$entry"
check "system uid ($uid)" test "${uid:-1000}" -lt 1000
check "home /var/lib/sirupp ($home)" test "$home" = /var/lib/sirupp
check "no login shell ($shell)" test "$shell" = /usr/sbin/nologin
check "/var/lib/sirupp" test "$(stat -c '%U:%G %a' /var/lib/sirupp)" = "sirupp:sirupp 750"
check "/etc/sirupp/classes" test "$(stat -c '%U:%G %a' /etc/sirupp/classes)" = "root:sirupp 750"
check "byte-compiled module" test -d /usr/lib/python3/dist-packages/sirupp/__pycache__
for p in sirupp sirupp-sim sirupp-control sirupp-controller-host sirupp-logger sirupp-viewer \
         sirupp-panel sirupp-hardware sirupp-picservo-emu sirupp-sandbox-exec sirupp-python-controller-host \
         sirupp-planner-host; do
  check "/usr/bin/$p" test -x "/usr/bin/$p"
done
for f in /usr/share/sirupp/config/robots/puma260.yaml /usr/share/sirupp/panel/web/index.html \
         /usr/share/sirupp/class/web/teacher.html /usr/share/sirupp/include/sirupp/controller.h \
         /usr/include/sirupp/controller.h /usr/include/sirupp/student_planner.h \
         /usr/share/sirupp/include/sirupp/student_planner.h /usr/share/sirupp/notebooks/01_forward_kinematics.ipynb \
         /usr/share/sirupp/config/grading/basic.yaml /usr/share/doc/sirupp/copyright; do
  check "$f" test -s "$f"
done

# The unit: systemd-analyze verify reads it without systemd as PID 1 and prints every problem
# (a bad value is only a warning there, so any output fails).
verify=$(systemd-analyze verify /usr/lib/systemd/system/sirupp-class@check.service 2>&1)
rc=$?
[[ $rc -eq 0 && -z "$verify" ]] || { echo "FAIL systemd-analyze verify (exit $rc): $verify"; fail=1; }
finish package_install "$(stat -c %s "$deb") bytes"

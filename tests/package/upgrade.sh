#!/usr/bin/env bash
# An upgrade keeps a class's files and data (docs/install.md, "Upgrading, removing"): with a class
# file in /etc/sirupp/classes and its data (tokens, a student's file) in /var/lib/sirupp, the
# installed package is upgraded with apt to the same contents under the next version (the .deb
# install.sh made, repacked with dpkg-deb), then the files are all there with their contents,
# owners and modes, the service user keeps its uid, `sirupp class check` accepts the class as that
# user, and dpkg knows the new version. Then apt goes back to the package as it was (a downgrade),
# so the tests after this one use what install.sh installed. Usage: upgrade.sh BUILD_DIR
set -u
source "$(dirname "$0")/lib.sh"
build=${1:?usage: upgrade.sh BUILD_DIR}
export DEBIAN_FRONTEND=noninteractive
deb=$(tail -n 1 "$build/packages/package.out" 2>/dev/null)
[[ -f "$deb" ]] || { echo "FAIL no package from install.sh ($build/packages/package.out)"; exit 1; }
version=$(dpkg-deb -f "$deb" Version)
[[ $(dpkg-query -W -f='${Version}' sirupp 2>/dev/null) == "$version" ]] ||
  { echo "FAIL sirupp $version is not the installed package"; exit 1; }
work=$(mktemp -d /tmp/sirupp-package-upgrade.XXXXXX)
class=/etc/sirupp/classes/upgrade-check.yaml
data=/var/lib/sirupp/upgrade-check
cleanup() { rm -rf "$work" "$data" "$class"; }
trap cleanup EXIT

# The class, as docs/install.md has the administrator write it.
cat >"$class" <<YAML
class: upgrade-check
robot: config/robots/puma260.yaml
students: [alice, bob]
data: $data
grading: {suite: config/grading/basic.yaml}
YAML
chgrp sirupp "$class" && chmod 0640 "$class"
install -d -m 0750 -o sirupp -g sirupp "$data" "$data/students" "$data/students/alice"
printf 'student,token\nalice,%s\n' "$(openssl rand -hex 8)" >"$data/tokens.csv"
printf 'int main() { return 0; }\n' >"$data/students/alice/controller.cpp"
chown sirupp:sirupp "$data/tokens.csv" "$data/students/alice/controller.cpp"
chmod 0600 "$data/tokens.csv"
state() {  # every file and folder of the class with its owner, mode and checksum
  find /etc/sirupp "$data" -printf '%p %u:%g %m\n' | sort
  find "$class" "$data" -type f -exec sha256sum {} + | sort
  stat -c '%n %U:%G %a' /var/lib/sirupp
}
state >"$work/before"
uid=$(id -u sirupp)

# The next version: the same files, the version raised (0.1.0 -> 0.1.0.1).
dpkg-deb -R "$deb" "$work/root"
sed -i "s/^Version: .*/Version: $version.1/" "$work/root/DEBIAN/control"
dpkg-deb -Zxz -b "$work/root" "$work/next.deb" >/dev/null || { echo "FAIL dpkg-deb -b"; exit 1; }
t=$(now)
apt-get install -y -qq --no-install-recommends "$work/next.deb" >"$work/apt.log" 2>&1 ||
  { echo "FAIL apt-get install of $version.1"; cat "$work/apt.log"; exit 1; }
echo "upgrade $version -> $version.1 with apt: $(since "$t") s"
check "installed version" test "$(dpkg-query -W -f='${Version}' sirupp)" = "$version.1"
state >"$work/after"
diff "$work/before" "$work/after" >"$work/diff" ||
  { echo "FAIL the upgrade changed the class's files:"; cat "$work/diff"; fail=1; }
check "service user's uid kept" test "$(id -u sirupp)" = "$uid"
runuser -u sirupp -- sirupp class check "$class" >"$work/check.out" 2>&1 ||
  { echo "FAIL sirupp class check as sirupp after the upgrade"; cat "$work/check.out"; fail=1; }

# Back to the package install.sh installed, for the tests after this one.
t=$(now)
apt-get install -y -qq --no-install-recommends --allow-downgrades "$deb" >"$work/apt.log" 2>&1 ||
  { echo "FAIL apt-get install of $version again (downgrade)"; cat "$work/apt.log"; exit 1; }
echo "back to $version with apt: $(since "$t") s"
check "installed version after the downgrade" test "$(dpkg-query -W -f='${Version}' sirupp)" = "$version"
state >"$work/back"
diff "$work/before" "$work/back" >"$work/diff" ||
  { echo "FAIL the downgrade changed the class's files:"; cat "$work/diff"; fail=1; }
finish package_upgrade "$(wc -l <"$work/before") lines of files, owners, modes and checksums kept"

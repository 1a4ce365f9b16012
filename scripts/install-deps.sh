#!/usr/bin/env bash
# Installs every Debian 12 package SIRUPP-LCM needs to build, test and run.
# Idempotent: when everything is present it only runs dpkg-query (well under a second).
# Usage: scripts/install-deps.sh [--check] [--peers] [--services]
#   --check     list what is missing, install nothing
#   --peers     also install the peers (KDL, MuJoCo; compared against in bench/, MuJoCo also the
#               oracle of the MJCF export's tests, which skip without it); never needed to build
#   --services  also install the services the tests start themselves, in folders of their own on
#               127.0.0.1 (scripts/test.sh asks for it): Slurm and munge (slurmctld, slurmd,
#               slurm-client, munge: the class on a one-node cluster, tests/cluster/) and Apache
#               (apache2, apache2-utils: the sign-in front, tests/package/), and lintian. Never
#               needed to build or run. They are installed with their daemons NOT started (a
#               policy-rc.d refuses it during the install) and, on a machine run by systemd, their
#               services disabled afterwards, so no daemon of theirs listens unless a test starts it.
#   --cluster   the same as --services (its earlier name)
set -euo pipefail
check=0
peers=0
services=0
for arg in "$@"; do
  case "$arg" in
    --check) check=1 ;;
    --peers) peers=1 ;;
    --services|--cluster) services=1 ;;
    *) echo "install-deps: unknown option '$arg'; allowed: --check, --peers, --services" >&2; exit 2 ;;
  esac
done

packages=(
  # build tools
  build-essential cmake ninja-build pkg-config git ccache
  # scripts/long-functions.sh (function lengths)
  universal-ctags
  # messaging: C/C++ library, lcm-gen, lcm.jar, lcm-logger/lcm-logplayer, jchart2d for lcm-spy;
  # glib's headers and .pc, which lcm.pc requires: without them `pkg-config --libs lcm` fails
  liblcm-dev liblcm-bin liblcm-java libjchart2d-java libglib2.0-dev
  # JDK to compile the Java types jar for lcm-spy; the full JRE (AWT for X11) to show lcm-spy's window
  default-jdk-headless default-jre
  # physics, maths, images
  libode-dev libeigen3-dev
  # motion planning: OMPL's planners (planning/)
  libompl-dev
  libopencv-core-dev libopencv-imgproc-dev libopencv-imgcodecs-dev libopencv-videoio-dev libopencv-highgui-dev
  # off-screen OpenGL
  libosmesa6-dev libgl-dev libglu1-mesa-dev
  # strict config files with line numbers
  libyaml-cpp-dev libtinyxml2-dev
  # --json output of the sirupp commands, and the panel's JSON
  nlohmann-json3-dev
  # every command line (flags, --help, --version, checks): CLI11, header-only
  libcli11-dev
  # sirupp-panel: HTTP server (header-only), the page's 3D and plot libraries (served from
  # /usr/share/javascript, never a CDN)
  libcpp-httplib-dev libjs-three libjs-dygraphs
  # the panel's browser tests: headless Chromium driven by Selenium (system python3)
  chromium chromium-driver python3-selenium
  # tests; check_urdf for the URDF export, python3 to parse exported XML and JSON output
  libgtest-dev libgmock-dev liburdfdom-tools python3
  # multi-host tests (network namespaces), process tools
  iproute2 procps
  # the Python module `sirupp` (pybind11 over the C++ libraries, numpy arrays), its pytest tests,
  # the course notebooks (plots, headless execution in the suite, `sirupp notebook`); nbclient and
  # ipykernel also run notebook assignments in the grader's sandbox (`sirupp grade notebook`)
  pybind11-dev python3-dev python3-numpy python3-matplotlib python3-pytest
  python3-nbclient python3-nbformat python3-ipykernel jupyter-nbconvert jupyter-notebook
  # the class server: token hashes and randomness, HTTPS (libssl-dev); test certificates (openssl)
  libssl-dev openssl
  # sandboxes for students' controllers (namespaces without root), the class server's limits
  bubblewrap
  # the Debian package (scripts/package.sh: dpkg-shlibdeps)
  dpkg-dev
  # an X server without a screen, for the test that starts lcm-spy (sirupp spy)
  xvfb xauth
)
if [[ $peers -eq 1 ]]; then
  packages+=(liborocos-kdl-dev libmujoco-dev)
fi
# Packages with daemons, for the tests that start them (--services).
# jupyterhub (with node-configurable-http-proxy, its proxy): the notebooks' hub (hub/, docs/notebooks.md),
# started by `sirupp class notebooks` and by its tests as the current user, never by the package:
# Debian's unit runs it as root with a config it never reads (hub/README.md).
service_packages=(slurmctld slurmd slurm-client munge apache2 apache2-utils jupyterhub node-configurable-http-proxy)
service_units=(slurmctld slurmd munge apache2 jupyterhub)
if [[ $services -eq 1 ]]; then
  packages+=("${service_packages[@]}" lintian)
fi

missing=()
for p in "${packages[@]}"; do
  status=$(dpkg-query -W -f='${Status}' "$p" 2>/dev/null || true)
  [[ "$status" == "install ok installed" ]] || missing+=("$p")
done

if [[ ${#missing[@]} -eq 0 ]]; then
  exit 0
fi
if [[ $check -eq 1 ]]; then
  printf 'missing: %s\n' "${missing[*]}"
  exit 1
fi

echo "install-deps: installing ${#missing[@]} package(s): ${missing[*]}"
SUDO=""
if [[ $(id -u) -ne 0 ]]; then
  command -v sudo >/dev/null || { echo "install-deps: not root and no sudo; install as root: ${missing[*]}" >&2; exit 1; }
  SUDO=sudo
fi
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
# A daemon installed for the tests is not started by its package (policy-rc.d answers 101,
# "action forbidden", to invoke-rc.d and deb-systemd-invoke) unless the machine has a policy of its own.
policy=/usr/sbin/policy-rc.d
own_policy=0
if [[ $services -eq 1 && ! -e $policy ]]; then
  printf '#!/bin/sh\n# scripts/install-deps.sh --services: no daemon started while it installs\nexit 101\n' |
    $SUDO tee "$policy" >/dev/null
  $SUDO chmod 755 "$policy"
  own_policy=1
  trap '$SUDO rm -f "$policy"' EXIT
fi
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
if [[ $own_policy -eq 1 ]]; then
  $SUDO rm -f "$policy"
  trap - EXIT
  # Under systemd the packages enable their services for the next boot: not for these.
  if [[ -d /run/systemd/system ]]; then
    for unit in "${service_units[@]}"; do
      if [[ " ${missing[*]} " == *" $unit "* ]]; then $SUDO systemctl disable --now "$unit" >/dev/null 2>&1 || true; fi
    done
  fi
fi
echo "install-deps: done"

# Source this first in a test script that runs processes over UDP multicast. Where it can, it
# re-runs the script in a fresh network namespace with multicast on its loopback interface, so no
# datagram can leave; where namespaces are not allowed (some containers), the script stays on this
# host's network with ttl=0: multicast that never leaves the machine. Sets URL (an LCM URL of the
# script's own) and TEST_NET (namespace or host). PRIVATE_NET_PORT: the port inside a namespace.
if [ -z "${TEST_NET:-}" ]; then
  if unshare -n true 2>/dev/null; then
    exec unshare -n env TEST_NET=namespace bash "$0" "$@"
  elif unshare -rn true 2>/dev/null; then
    exec unshare -rn env TEST_NET=namespace bash "$0" "$@"
  fi
  TEST_NET=host
  echo "note: no network namespace allowed here; multicast with ttl=0 on this host"
fi
if [ "$TEST_NET" = namespace ]; then
  ip link set lo up && ip link set lo multicast on && ip route add 224.0.0.0/4 dev lo || {
    echo "FAIL: cannot set up multicast on lo in the test namespace"
    exit 1
  }
  URL="udpm://239.255.76.67:${PRIVATE_NET_PORT:-7731}?ttl=0"
else
  URL="udpm://239.255.76.67:$((20000 + $$ % 20000))?ttl=0"  # per process: scripts run in parallel
fi

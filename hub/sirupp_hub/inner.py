"""Inside the notebook sandbox (stage 2, uid 1000): the inner bus bridge, the forwarder to the
hub's API, then the notebook server itself (exec), on a Unix socket.

    python3 -m sirupp_hub.inner /run/sirupp/inner.json
"""

import json
import os
import socket
import subprocess
import sys
import time

from . import sandbox


def wait_for_port(port, seconds):
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        try:
            with socket.create_connection(("127.0.0.1", port), timeout=0.5):
                return True
        except OSError:
            time.sleep(0.05)
    return False


def main(argv):
    with open(argv[0], encoding="utf-8") as source:
        plan = json.load(source)
    os.unlink(argv[0])  # it holds the server's token: read once
    run = sandbox.INSIDE_RUN
    env = dict(plan["env"])
    logs = open(os.path.join(run, "inner.log"), "ab", buffering=0)
    if plan.get("bridge"):
        subprocess.Popen([os.path.join(plan["bin_dir"], "sirupp-notebook-bridge"),
                          "--lcm", plan["inner_lcm_url"], "--connect", os.path.join(run, "bus.sock")],
                         stdout=logs, stderr=logs, env=env)
    hub_port = plan["hub_api_port"]
    subprocess.Popen([sys.executable, "-m", "sirupp_hub.forward", f"tcp:127.0.0.1:{hub_port}",
                      "unix:" + os.path.join(run, "hubapi.sock")], stdout=logs, stderr=logs, env=env)
    if not wait_for_port(hub_port, 10):
        print("sirupp_hub.inner: the forwarder to the hub's API did not start", file=sys.stderr)
        return 1
    command = ["/usr/bin/jupyterhub-singleuser"] + plan["args"]
    os.execve(command[0], command, env)
    return 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

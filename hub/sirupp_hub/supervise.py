"""One student's notebook server from outside its sandbox: the supervisor the spawner starts (in a
session of its own, so that it outlives a restarted hub) and JupyterHub's poll() follows by pid.

It runs, and ends together:
- the outer bus bridge (sirupp-notebook-bridge --listen RUN/bus.sock) on the student's rig bus;
- the forwarders: 127.0.0.1:PORT (the hub's proxy's target) -> RUN/nb.sock (the notebook server),
  RUN/hubapi.sock (the notebook server's way to the hub's API) -> the hub's API; inside a rig's
  Slurm job (a step on its node, started by srun) the first listens on the node's address
  (listen_host) on a port it picks there (port 0), and tells it in RUN/port.json
  {port, host, job, step} (written whole, then renamed), which the spawner waits for;
- the sandbox (sirupp_hub.sandbox), in which sirupp_hub.inner starts the notebook server.

It exits with the sandbox's exit status (0 when the notebook server shut itself down after its
idle timeout), after stopping the bridge; on SIGTERM it ends the sandbox first. On SIGHUP (from the
spawner) it moves the outer bridge to the bus in RUN/rig.url: the rig was started again elsewhere.

    python3 -m sirupp_hub.supervise RUN/launch.json
"""

import asyncio
import ctypes
import json
import os
import signal
import subprocess
import sys

from . import forward, sandbox

PR_SET_PDEATHSIG = 1


def _die_with_parent():
    ctypes.CDLL("libc.so.6", use_errno=True).prctl(PR_SET_PDEATHSIG, signal.SIGTERM)


def stop_process(process):
    process.terminate()
    try:
        process.wait(3)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()


def write_port_file(path, told):
    """The port this server listens on, for the spawner: written whole, then renamed in."""
    temporary = path + ".new"
    with open(os.open(temporary, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600), "w") as out:
        json.dump(told, out)
    os.rename(temporary, path)


def log(line):
    print(f"sirupp_hub.supervise: {line}", file=sys.stderr, flush=True)


async def run(plan):
    run_dir = plan["run_dir"]
    sock_dir = os.path.join(run_dir, "sock")
    etc_dir = os.path.join(run_dir, "etc")
    os.makedirs(sock_dir, mode=0o700, exist_ok=True)  # the sandbox's uid 1000 is ours outside
    sandbox.write_etc(etc_dir, plan["name"])
    for stale in ("nb.sock", "hubapi.sock", "bus.sock"):
        try:
            os.unlink(os.path.join(sock_dir, stale))
        except FileNotFoundError:
            pass

    def start_bridge(url):
        return subprocess.Popen(
            [os.path.join(plan["bin_dir"], "sirupp-notebook-bridge"), "--lcm", url,
             "--listen", os.path.join(sock_dir, "bus.sock")], preexec_fn=_die_with_parent)

    bridges = [start_bridge(plan["lcm_url"])] if plan.get("lcm_url") else []
    listen_host = plan.get("listen_host") or "127.0.0.1"
    try:
        servers = [
            await forward.serve(("tcp", listen_host, plan["port"]),
                                ("unix", os.path.join(sock_dir, "nb.sock"))),
            await forward.serve(("unix", os.path.join(sock_dir, "hubapi.sock")),
                                ("tcp", plan["hub_api_host"], plan["hub_api_port"])),
        ]
    except OSError as error:
        log(f"{plan['name']}: cannot listen on {listen_host}:{plan['port']}: {error}")
        for bridge in bridges:
            stop_process(bridge)
        return 1
    port = servers[0].sockets[0].getsockname()[1]
    if plan.get("port_file"):
        write_port_file(plan["port_file"], {
            "port": port, "host": listen_host, "job": os.environ.get("SLURM_JOB_ID", ""),
            "step": os.environ.get("SLURM_STEP_ID", "")})
    inner_plan = os.path.join(sock_dir, "inner.json")
    with open(os.open(inner_plan, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o644), "w") as out:
        json.dump({"env": plan["inner_env"], "args": plan["args"], "bin_dir": plan["bin_dir"],
                   "bridge": bool(plan.get("lcm_url")), "inner_lcm_url": plan["inner_lcm_url"],
                   "hub_api_port": plan["hub_api_port"]}, out)
    inner_env_path = ":".join(plan["inner_pythonpath"])
    command = sandbox.full_command(sandbox.bwrap_arguments(
        plan["home"], sock_dir, etc_dir, plan["read_only"],
        ["/usr/bin/env", "PYTHONPATH=" + inner_env_path, "PYTHONNOUSERSITE=1",
         "HOME=" + sandbox.INSIDE_HOME, "PATH=/usr/bin:/bin",
         "/usr/bin/python3", "-m", "sirupp_hub.inner",
         os.path.join(sandbox.INSIDE_RUN, "inner.json")]))
    process = await asyncio.create_subprocess_exec(
        *command, preexec_fn=sandbox.limit_process(plan["memory_mb"], plan["processes"]))
    log(f"{plan['name']}: sandbox pid {process.pid}, listening on {listen_host}:{port}" +
        (f" (Slurm job {os.environ['SLURM_JOB_ID']} step {os.environ.get('SLURM_STEP_ID', '?')})"
         if os.environ.get("SLURM_JOB_ID") else ""))

    stop = asyncio.Event()
    loop = asyncio.get_running_loop()
    for sig in (signal.SIGTERM, signal.SIGINT):
        loop.add_signal_handler(sig, stop.set)

    def follow_rig():
        # SIGHUP from the spawner: the rig runs on another bus now (RUN/rig.url); the outer
        # bridge moves there and the inner one connects again.
        try:
            with open(os.path.join(run_dir, "rig.url"), encoding="utf-8") as source:
                url = source.read().strip()
        except OSError:
            return
        if not url.startswith("udpm://"):
            return
        for old in bridges:
            stop_process(old)
        bridges[:] = [start_bridge(url)]
        log(f"{plan['name']}: the rig's bus is now {url}")

    loop.add_signal_handler(signal.SIGHUP, follow_rig)
    waiter = asyncio.ensure_future(process.wait())
    stopper = asyncio.ensure_future(stop.wait())
    await asyncio.wait([waiter, stopper], return_when=asyncio.FIRST_COMPLETED)
    if not waiter.done():
        log(f"{plan['name']}: stopping the sandbox")
        process.terminate()
        try:
            await asyncio.wait_for(waiter, 5)
        except asyncio.TimeoutError:
            process.kill()
            await waiter
    stopper.cancel()
    code = process.returncode
    for server in servers:
        server.close()
    for bridge in bridges:
        stop_process(bridge)
    log(f"{plan['name']}: the sandbox ended with {code}")
    return 0 if code is None or code < 0 and stop.is_set() else code


def main(argv):
    with open(argv[0], encoding="utf-8") as source:
        plan = json.load(source)
    os.unlink(argv[0])  # it holds the server's token: read once
    return asyncio.run(run(plan))


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))

#!/usr/bin/python3
"""A student's notebook server inside their rig's Slurm job (docs/notebooks.md), on the one-node
cluster of with_cluster.sh (SLURM_CONF exported): a class of alice whose rigs are Slurm jobs
(cluster:) with notebooks:, the class server and `sirupp class notebooks` (tests/hub/hub_run.py).

- alice signs in by her class token (her page's Notebooks link) before her rig job has reported:
  the hub waits for the job, then starts her server with srun as a step of that job;
- `squeue --steps` lists the step (notebook-alice) in her rig's job, the supervisor's environment
  has SLURM_JOB_ID of that job, its parent is slurmstepd, and the notebook server
  (jupyterhub-singleuser) runs under it;
- a kernel started over the hub's REST and WebSocket API runs sirupp.connect() and a joint move;
  the class server's panel API for alice's rig (proxied to the job) shows the arm at the goal;
- the hub's stop of the server ends its step and not the rig's job; started again it is a new
  step of the same job; the hub restarted finds it (srun and supervisor) again;
- scancel of the rig's job ends the step and the server: the hub's poll sees it stopped, and no
  supervisor, srun, step or notebook server is left.

Everything started is stopped at the end, also after a failure (HubRun.stop, then
with_cluster.sh's check that nothing of the cluster is left).

Usage: with_cluster.sh notebooks_cluster_test.py BIN_DIR SOURCE_DIR"""

import json
import math
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(HERE, "..", "hub"))
from hub_run import HubRun, Session, run_code  # noqa: E402
from hub_test import GOAL, MOVE, check  # noqa: E402

CLUSTER_YAML = ("cluster:\n"
                "  engine: slurm\n"
                "  rig: {time_limit_min: 30, cpus: 1, memory_mb: 2048}\n"
                "  poll_s: 1\n")


def squeue(*args):
    return subprocess.run(["squeue", "-h", *args], capture_output=True, text=True,
                          timeout=20).stdout


def rig_job(name):
    """alice's rig job's id, or None while it is not listed."""
    for line in squeue("-o", "%i|%j").splitlines():
        job, _, job_name = line.partition("|")
        if job_name.strip() == "sirupp-rig-" + name:
            return job.strip()
    return None


def steps_of(job):
    """[(step id, step name)] that squeue lists for `job`."""
    rows = [line.split("|") for line in squeue("--steps", "-j", job, "-o", "%i|%j").splitlines()
            if "|" in line]
    return [(r[0].strip(), r[1].strip()) for r in rows]


def proc_text(pid, what):
    try:
        with open(f"/proc/{pid}/{what}", "rb") as source:
            return source.read()
    except OSError:
        return b""


def environ(pid):
    pairs = (item.partition(b"=") for item in proc_text(pid, "environ").split(b"\0") if item)
    return {k.decode(errors="replace"): v.decode(errors="replace") for k, _, v in pairs}


def parent(pid):
    text = proc_text(pid, "stat").decode(errors="replace")
    return int(text[text.rfind(")") + 2:].split()[1]) if text else 0


def descendants(root):
    children = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            children.setdefault(parent(int(entry)), []).append(int(entry))
    found, todo = [], [root]
    while todo:
        for child in children.get(todo.pop(), []):
            found.append(child)
            todo.append(child)
    return found


def notebook_processes(hub):
    """The supervisors and sruns of this run (their command lines name its run folder), and the
    notebook servers under them."""
    pids = hub.supervisors()
    servers = [p for s in pids for p in descendants(s)
               if b"jupyterhub-singleuser" in proc_text(p, "cmdline")]
    return pids + servers


def wait_for(what, seconds, probe):
    deadline = time.time() + seconds
    last = None
    while time.time() < deadline:
        last = probe()
        if last:
            return last
        time.sleep(0.3)
    raise AssertionError(f"{what}: not within {seconds} s (last: {last!r})")


def main(bin_dir, source_dir):
    started = time.time()
    hub = HubRun(bin_dir, source_dir, ["alice"], poll_interval_s=2, extra_yaml=CLUSTER_YAML)
    ok = False
    try:
        hub.start()
        # alice signs in by her page's Notebooks link; her rig job is submitted by the hub's ask.
        status, link = hub.cls.http("GET", "/s/alice/class/status", hub.cls.token("alice"))
        check(status == 200 and "notebooks_url" in link,
              f"alice's page links to Notebooks: {status}")
        alice = Session(hub)
        t0 = time.time()
        status, url, _ = alice.get(link["notebooks_url"][len(hub.hub_base):])
        check(status == 200 and "token=" not in url, f"alice signs in with her token: {status}")
        hub.wait_server(alice, "alice", timeout=90)
        print(f"alice: server up {time.time() - t0:.1f} s after sign-in (rig job and step)")
        waited = [line for line in hub.hub_log().splitlines() if "waiting for the rig" in line]
        print("the hub waited for the rig's job:", waited[0][-160:] if waited else "no (ready)")

        # Her server runs inside her rig's job.
        job = rig_job("alice")
        check(job is not None, f"alice's rig is a Slurm job: {job}")
        steps = steps_of(job)
        check(any(s[0].startswith(job + ".") and s[1] == "notebook-alice" for s in steps),
              f"squeue --steps lists the notebook's step in job {job}: {steps}")
        supervisors = [p for p in hub.supervisors() if b"srun" not in proc_text(p, "cmdline")
                       .split(b"\0")[0]]
        check(len(supervisors) == 1, f"one supervisor (beside its srun): {supervisors}")
        supervisor = supervisors[0]
        job_env = environ(supervisor).get("SLURM_JOB_ID")
        check(job_env == job, f"the supervisor runs with SLURM_JOB_ID={job_env} (the rig's {job})")
        above = proc_text(parent(supervisor), "comm").decode().strip()
        check(above.startswith("slurmstepd"), f"the supervisor's parent is {above}")
        servers = [p for p in descendants(supervisor)
                   if b"jupyterhub-singleuser" in proc_text(p, "cmdline")]
        check(len(servers) == 1, f"the notebook server runs under it (in the sandbox): {servers}")
        answer = json.loads(open(hub.data("hub", "run", "alice", "port.json")).read())
        check(answer["job"] == job and answer["host"] == "127.0.0.1",
              f"it listens on the node's address the job reported: {answer}")

        # A kernel moves her rig; the class server's panel API (proxied to the job) shows it.
        token = hub.user_token(alice, "alice")
        reply, out, error = run_code(hub, "alice", token, MOVE)
        check(reply == "ok",
              f"sirupp.connect() and a move in alice's kernel: {reply} {out} {error}")
        status, state = hub.cls.http("GET", "/s/alice/api/state", hub.cls.token("alice"))
        check(status == 200 and "virtual" in state,
              f"alice's rig state through the proxy: {status}")
        goal_deg = [math.degrees(x) for x in GOAL]
        far = max(abs(a - b) for a, b in zip(state["virtual"]["q"], goal_deg))
        check(far < 2.0, f"the panel API shows alice's arm at the kernel's goal: "
                         f"{state['virtual']['q']} ({far:.2f} deg off)")

        # The hub's stop ends the step (SIGTERM to srun, which passes it on), not the rig's job;
        # started again, the server is a new step of the same job.
        status, _ = alice.api("DELETE", "/hub/api/users/alice/server", token=token)
        check(status in (202, 204), f"alice's server stopped from the hub's API: {status}")
        wait_for("the step and its processes gone after the hub's stop", 30,
                 lambda: not notebook_processes(hub) and
                 [s[1] for s in steps_of(job)] == ["batch"])
        check(rig_job("alice") == job, f"alice's rig job {job} still runs")
        status, _ = alice.api("POST", "/hub/api/users/alice/server", token=token)
        check(status in (201, 202), f"alice's server started again: {status}")
        hub.wait_server(alice, "alice", timeout=60)
        steps = steps_of(job)
        check(any(s[1] == "notebook-alice" and s[0] != job + ".0" for s in steps),
              f"it is a new step of job {job}: {steps}")

        # A restarted hub finds the server in the job again (its database: srun's pid and start,
        # the node's address and port), no longer as its child.
        before = sorted(hub.supervisors())
        hub.stop_hub(keep_servers=True)
        hub.start_hub()
        hub.wait_server(alice, "alice", timeout=40)
        check(sorted(hub.supervisors()) == before,
              f"the restarted hub reaches the same server in job {job}: {before}")

        # The rig's job ends: its step and the notebook server end with it, and the hub sees it.
        subprocess.run(["scancel", job], check=True, timeout=20)
        t0 = time.time()

        def stopped():
            status, user = alice.api("GET", "/hub/api/users/alice", token=token)
            return user if status == 200 and not user.get("server") and \
                not user.get("pending") else None

        wait_for("the hub sees alice's server stopped after scancel", 40, stopped)
        print(f"the hub saw alice's server stopped {time.time() - t0:.1f} s after scancel")
        wait_for("no supervisor, srun or notebook server left", 20,
                 lambda: not notebook_processes(hub))
        wait_for(f"job {job} and its steps gone from squeue", 30, lambda: not steps_of(job) and
                 job not in squeue("-o", "%i").split())
        check(True, "nothing of alice's notebook server is left after scancel")
        ok = True
    finally:
        if not ok:
            print(hub.hub_log()[-5000:])
            print("alice's server:\n" + hub.server_log("alice")[-4000:])
            print("class server:\n" + hub.cls.server_log()[-3000:])
        left = hub.stop()
        if left:
            print("left running (killed):", left)
            ok = False
        else:
            print("ok: nothing of the test is left running")
        if ok:
            hub.clean()
    print(f"{'ok' if ok else 'FAIL'} ({time.time() - started:.0f} s)")
    return 0 if ok else 1


if __name__ == "__main__":
    if not os.access("/usr/bin/jupyterhub", os.X_OK):
        print("skipped: /usr/bin/jupyterhub is not installed (scripts/install-deps.sh --services)")
        sys.exit(77)
    sys.exit(main(sys.argv[1], sys.argv[2]))

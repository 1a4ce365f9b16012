#!/usr/bin/python3
"""A rig's start through Slurm: from the student's page request to the rig ready behind the class
server's proxy (its API answering through the proxy), p50 and p95 over --starts starts, against
the goal p95 <= 3 s (issue 39). Also the same for the class server's own processes (no cluster:)
on this machine, and the live stream's frame rate through the proxy.

Runs beside a Slurm cluster (SLURM_CONF exported), e.g. the one-node cluster of the tests:
  tests/cluster/with_cluster.sh /usr/bin/python3 bench/cluster_bench.py [--starts 20]
Each start: the teacher stops the rig (scancel), then the student's page asks for it again.
"""
import argparse
import json
import os
import statistics
import sys
import time
import urllib.request

ROOT = os.path.abspath(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
sys.path.insert(0, os.path.join(ROOT, "tests", "class"))
from class_run import ClassRun  # noqa: E402

CLUSTER_YAML = ("cluster:\n"
                "  engine: slurm\n"
                "  rig: {time_limit_min: 30, cpus: 1, memory_mb: 2048}\n"
                "  poll_s: 1\n")


def percentile(values, p):
    values = sorted(values)
    return values[min(len(values) - 1, int(round(p / 100 * (len(values) - 1))))]


def one_start(run, name, timeout_s=60):
    """Seconds from the page request to the rig's API answering through the server."""
    token = run.token(name)
    start = time.time()
    code, _ = run.http("GET", f"/s/{name}/", token)
    if code != 200:
        raise AssertionError(f"the page answered {code}")
    while time.time() - start < timeout_s:
        code, body = run.http("GET", f"/s/{name}/api/state", token)
        if code == 200:
            return time.time() - start
        time.sleep(0.02)
    raise AssertionError(f"{name}'s rig not ready within {timeout_s} s")


def stream_rate(run, name, seconds=5, hz=30):
    request = urllib.request.Request(f"{run.base}/s/{name}/api/events?hz={hz}",
                                     headers={"X-Sirupp-Token": run.token(name)})
    frames = 0
    start = time.time()
    with urllib.request.urlopen(request, timeout=15) as stream:
        while time.time() - start < seconds:
            if stream.readline().startswith(b"data: "):
                frames += 1
    return frames / (time.time() - start)


def measure(bin_dir, starts, cluster):
    run = ClassRun(bin_dir, ROOT, ["s00"], extra_yaml=CLUSTER_YAML if cluster else "")
    run.start()
    times = []
    try:
        for i in range(starts):
            if i > 0:
                code, body = run.http("POST", "/teacher/api/rigs/s00/stop", run.token("teacher"))
                if code != 200:
                    raise AssertionError(f"stop: {code} {body}")
                if cluster:  # the job gone before the next start, so none waits behind it
                    time.sleep(1.5)
            times.append(one_start(run, "s00"))
        rate = stream_rate(run, "s00")
    finally:
        run.stop()
        run.clean()
    return times, rate


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--bin", default=os.path.join(ROOT, "build", "bin"))
    parser.add_argument("--starts", type=int, default=20)
    args = parser.parse_args()
    if not os.environ.get("SLURM_CONF"):
        sys.exit("cluster_bench: no SLURM_CONF; run it under tests/cluster/with_cluster.sh")
    for cluster in (True, False):
        times, rate = measure(args.bin, args.starts, cluster)
        what = "Slurm job (sbatch to ready, behind the proxy)" if cluster else "local processes"
        line = (f"rig start, {what}: {len(times)} starts, p50 {statistics.median(times):.2f} s, "
                f"p95 {percentile(times, 95):.2f} s, max {max(times):.2f} s; "
                f"stream {rate:.1f} frames/s at hz=30")
        if cluster:
            line += f"; goal p95 <= 3 s: {'met' if percentile(times, 95) <= 3 else 'NOT met'}"
        print(line, flush=True)


if __name__ == "__main__":
    main()

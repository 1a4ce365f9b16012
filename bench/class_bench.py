#!/usr/bin/python3
"""How many complete rigs one class server holds at real time, and how fast a rig starts.

For each N (--counts, default 2 4 6 ...): a class server (`sirupp class serve`) with N students,
every rig started through its page (sirupp-sim realtime + sirupp-control + sirupp-logger, the
panel's hub and API in the server), each with a live event stream open at 30 updates a second and
running movement set VII in a loop through the panel's API. Over --seconds of steady running it
measures each rig's real-time factor (sim time advanced / wall time, from the state) and counts
failed plans (a controller fault or error, or a plan that did not finish in time). Prints one line
per N, the largest N holding real-time factor >= 0.99 with no failed plan, that per core, and the
rig start times (median, p95) over every start.

Usage: class_bench.py BIN_DIR SOURCE_DIR [--counts 2 4 6] [--seconds 30] [--first-port 9431]
                      [--cluster]
--cluster (issue 39): each N twice, first with every rig a Slurm job (the class file's cluster:,
each rig asking for 1 CPU and 512 MB) and then as the server's own processes, in the same run;
each line also gives the class server's CPU per rig (its process alone: for jobs, what proxying a
rig's API and stream costs it). Needs SLURM_CONF, e.g. beside the tests' one-node cluster:
  tests/cluster/with_cluster.sh /usr/bin/python3 bench/class_bench.py build/bin . --cluster ...
The rigs lease udpm ports from --first-port on, away from the class file's default range (7900)
that the class tests use: two class servers on one machine leasing the same port would share
their rigs' traffic.
(without --counts: 2, 4, ... up to 6 per core, stopping at the first N that does not hold). The
load column is the machine's 1-minute load average after the trial: the figures only mean
something on an otherwise idle machine.
Uses Debian's /usr/bin/python3; every process it starts is ended before it exits."""

import argparse
import json
import os
import statistics
import sys
import threading
import time
import urllib.request

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "class"))
from class_run import ClassRun  # noqa: E402

TICKS = os.sysconf("SC_CLK_TCK")
CLUSTER_YAML = ("cluster:\n"
                "  engine: slurm\n"
                "  rig: {time_limit_min: 30, cpus: 1, memory_mb: 512}\n"
                "  poll_s: 1\n")

SET7 = open(os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "config", "plans",
                         "set7.plan")).read()


class Stream(threading.Thread):
    """Reads a rig's live state at 30 updates a second, as a page does; keeps the newest."""

    def __init__(self, run, name):
        super().__init__(daemon=True)
        self.url = f"{run.base}/s/{name}/api/events?hz=30"
        self.token = run.token(name)
        self.frames = 0
        self.latest = None
        self.stop = False

    def run(self):
        req = urllib.request.Request(self.url, headers={"X-Sirupp-Token": self.token})
        try:
            with urllib.request.urlopen(req, timeout=30) as r:
                for line in r:
                    if self.stop:
                        return
                    if line.startswith(b"data: "):
                        self.frames += 1
                        self.latest = json.loads(line[6:])
        except Exception:
            pass


class Driver(threading.Thread):
    """Runs set VII in a loop on one rig through the panel's API; counts finished and failed plans."""

    def __init__(self, run, name, stream):
        super().__init__(daemon=True)
        self.run_ = run
        self.name = name
        self.stream = stream
        self.done = 0
        self.failed = []
        self.stop = False

    def run(self):
        token = self.run_.token(self.name)
        status, body = self.run_.http("POST", f"/s/{self.name}/api/lock", token, {"name": "bench"})
        if status != 200:
            self.failed.append(f"lock: {status} {body}")
            return
        while not self.stop:
            status, body = self.run_.http("POST", f"/s/{self.name}/api/plan/run", token,
                                          {"name": "set7.plan", "text": SET7})
            if status != 200:
                self.failed.append(f"plan run: {status} {body}")
                time.sleep(1)
                continue
            start = time.time()
            started = False
            error_before = ((self.stream.latest or {}).get("controller") or {}).get("last_error", "")
            while not self.stop:
                time.sleep(0.1)
                s = self.stream.latest or {}
                c = s.get("controller", {})
                if c.get("plan_name") == "set7.plan" and c.get("state") in ("moving", "waiting"):
                    started = True
                if c.get("state") == "fault" or c.get("last_error", "") not in ("", error_before):
                    self.failed.append(f"controller: {c.get('state')} {c.get('last_error')}")
                    self.run_.http("POST", f"/s/{self.name}/api/plan/clear-fault", token, {})
                    break
                if started and c.get("state") == "idle" and c.get("plan_step", 0) >= c.get("plan_steps", 1):
                    self.done += 1
                    break
                if time.time() - start > 60:
                    self.failed.append("set VII did not finish within 60 s")
                    break


def cpu_seconds(pid):
    """user + system CPU seconds of every thread of pid; None once it is gone."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / TICKS  # utime, stime (fields 14, 15)


def percentile(values, p):
    values = sorted(values)
    return values[min(len(values) - 1, int(round(p / 100 * (len(values) - 1))))]


def bench_class(bin_dir, src, n, first_port, pin, pace_ticks, cluster=False):
    """A class of n students s00.. with limits.pin_rigs and rigs.pace_ticks as given. Another class
    server on this machine (the class tests) leasing the same udpm ports would share its rigs'
    traffic: the rigs keep to ports from first_port on (0: the class file's default range)."""
    names = [f"s{i:02d}" for i in range(n)]
    run = ClassRun(bin_dir, src, names, max_rigs=n,
                   extra_limits=f", pin_rigs: {'true' if pin else 'false'}",
                   extra_yaml=CLUSTER_YAML if cluster else "")
    ports = f"first_port: {first_port}, port_count: {max(n, 8)}, " if first_port else ""
    with open(run.class_file, "a") as f:
        f.write(f"rigs: {{{ports}pace_ticks: {pace_ticks}}}\n")
    return run, names


def wait_ready(run, name, timeout_s=60):
    """Until the rig's API answers through the server (a rig job's page answers before that)."""
    end = time.time() + timeout_s
    while time.time() < end:
        if run.http("GET", f"/s/{name}/api/state", run.token(name))[0] == 200:
            return
        time.sleep(0.02)
    raise RuntimeError(f"{name}'s rig not ready within {timeout_s} s")


def trial(bin_dir, src, n, seconds, start_times, first_port, pin=False, pace_ticks=4, cluster=False):
    """(rtf min, rtf mean, failed plans, plans done, stream Hz min, failure reasons, the class
    server's CPU share of one core per rig) of n rigs over seconds of steady running."""
    run, names = bench_class(bin_dir, src, n, first_port, pin, pace_ticks, cluster)
    run.start()
    streams, drivers = [], []
    try:
        for name in names:
            t0 = time.time()
            status, body = run.http("GET", f"/s/{name}/", run.token(name))
            if status != 200:
                raise RuntimeError(f"{name}'s rig did not start: {status} {body!r:.300}")
            wait_ready(run, name)
            start_times.append(time.time() - t0)
        for name in names:
            s = Stream(run, name)
            s.start()
            streams.append(s)
        for name, s in zip(names, streams):
            d = Driver(run, name, s)
            d.start()
            drivers.append(d)
        time.sleep(3)  # settle: every rig running its plan
        begin = [(time.time(), (s.latest or {}).get("sim", {}).get("sim_time_s"), s.frames) for s in streams]
        server0, wall0 = cpu_seconds(run.proc.pid), time.time()
        time.sleep(seconds)
        server_share = (cpu_seconds(run.proc.pid) - server0) / (time.time() - wall0) / n
        end = [(time.time(), (s.latest or {}).get("sim", {}).get("sim_time_s"), s.frames) for s in streams]
        rtfs, rates = [], []
        for (w0, t0, f0), (w1, t1, f1) in zip(begin, end):
            rtfs.append((t1 - t0) / (w1 - w0) if t0 is not None and t1 is not None else 0.0)
            rates.append((f1 - f0) / (w1 - w0))
        failed = sum(len(d.failed) for d in drivers)
        done = sum(d.done for d in drivers)
        reasons = sorted({r for d in drivers for r in d.failed})[:3]
        return min(rtfs), statistics.mean(rtfs), failed, done, min(rates), reasons, server_share
    finally:
        end_rigs(run, drivers, streams)


RIG_PROCESSES = {"sirupp-sim", "sirupp-control", "sirupp-logger", "sirupp-rig-job"}


def rig_processes():
    """pids of every rig process on this machine (a class server's or a rig job's)."""
    pids = []
    for entry in os.listdir("/proc"):
        try:
            with open(f"/proc/{entry}/comm") as f:
                if entry.isdigit() and f.read().strip() in RIG_PROCESSES:
                    pids.append(int(entry))
        except OSError:
            pass
    return pids


def end_rigs(run, drivers, streams, timeout_s=60):
    """Stops the plan drivers and the page streams, then the class server and its rigs, and waits
    until every rig process has ended (a rig job ends after the server's scancel, on its own time):
    the next trial must not share the machine with this one's rigs."""
    for d in drivers:
        d.stop = True
    for s in streams:
        s.stop = True
    run.stop()
    run.clean()
    end = time.time() + timeout_s
    while rig_processes():
        if time.time() > end:
            raise RuntimeError(f"rig processes still running {timeout_s} s after the trial: "
                               f"{rig_processes()}")
        time.sleep(0.2)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("bin_dir")
    parser.add_argument("source_dir")
    parser.add_argument("--counts", type=int, nargs="+", default=None)
    parser.add_argument("--seconds", type=float, default=30)
    parser.add_argument("--first-port", type=int, default=9431,
                        help="first udpm port of the rigs (0: the class file's default, 7900)")
    parser.add_argument("--pin", action="store_true",
                        help="limits.pin_rigs: true (each rig's processes on one CPU; default off)")
    parser.add_argument("--pace-ticks", type=int, default=4,
                        help="rigs.pace_ticks: each sim sleeps once per N ticks (1: every tick)")
    parser.add_argument("--cluster", action="store_true",
                        help="each N as Slurm jobs and then locally (needs SLURM_CONF)")
    args = parser.parse_args()
    if args.cluster and not os.environ.get("SLURM_CONF"):
        sys.exit("class_bench: --cluster needs SLURM_CONF; run it under tests/cluster/with_cluster.sh")
    cores = os.cpu_count()
    counts = args.counts or list(range(2, 6 * cores + 1, 2))
    print(f"class bench: {cores} cores, {args.seconds:.0f} s per trial, set VII in a loop per rig, "
          f"one 30 Hz stream per rig, {'each rig on one CPU' if args.pin else 'no rig pinned'}, "
          f"pace_ticks {args.pace_ticks}",
          flush=True)
    print(f"{'rigs':>4} {'where':>5} {'rtf min':>8} {'rtf mean':>8} {'plans done':>10} {'failed':>6} "
          f"{'stream Hz min':>13} {'server %/rig':>12} {'load':>6}", flush=True)
    best = {}
    starts = {}
    for n in counts:
        all_hold = True
        for cluster in ((True, False) if args.cluster else (False,)):
            where = "slurm" if cluster else "local"
            rtf_min, rtf_mean, failed, done, rate, reasons, server = trial(
                args.bin_dir, args.source_dir, n, args.seconds, starts.setdefault(where, []),
                args.first_port, args.pin, args.pace_ticks, cluster)
            holds = rtf_min >= 0.99 and failed == 0
            all_hold = all_hold and holds
            load = open("/proc/loadavg").read().split()[0]
            print(f"{n:>4} {where:>5} {rtf_min:>8.3f} {rtf_mean:>8.3f} {done:>10} {failed:>6} "
                  f"{rate:>13.1f} {100 * server:>12.2f} {load:>6}"
                  f"  {'holds' if holds else 'does not hold'}"
                  f"{'  ' + '; '.join(reasons) if reasons else ''}", flush=True)
            if holds:
                best[where] = max(best.get(where, 0), n)
        if not all_hold and args.counts is None:
            break  # ramping up: the first N that does not hold ends it
    for where, times in starts.items():
        n = best.get(where, 0)
        print(f"{where}: largest N holding real time (rtf >= 0.99, no failed plan): {n} rigs = "
              f"{n / cores:.1f} per core")
        print(f"{where}: rig start (page request until its API answers), {len(times)} starts: "
              f"median {statistics.median(times):.2f} s, p95 {percentile(times, 95):.2f} s, "
              f"max {max(times):.2f} s")


if __name__ == "__main__":
    main()

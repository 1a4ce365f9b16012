#!/usr/bin/python3
"""Notebooks through the hub (docs/notebooks.md): how long from sign-in to a kernel that answers,
and what a student costs in memory.

A class server and `sirupp class notebooks` on 127.0.0.1 (tests/hub/hub_run.py, a temporary
folder). For each student: sign-in by the front's header, the hub spawning their sandboxed server
(the class rig started for them), the server's page through the hub's OAuth, an API token, a
kernel over REST and its first answer over the WebSocket (kernel_info). Timed from the sign-in
request to that answer:
  - alone: --alone students one after another (default 5);
  - at once: --together students signing in at the same moment (default 10), each in a thread.
Then memory (resident set, from /proc) per student with a kernel open: the notebook server's side
(supervisor, bridges, forwarders, sandbox, notebook server, kernel) and the class rig (sim,
control, logger); the hub and its proxy once.

Then the CPU each student's notebook side and rig use at rest (kernels open, arms still) over
--idle-seconds (20).

Usage: bench_notebooks.py BIN_DIR SOURCE_DIR [--alone 5] [--together 10] [--idle-seconds 20]
Prints the figures; every process it starts is ended before it exits. The figures only mean
something on an otherwise idle machine (the load average is printed)."""

import argparse
import os
import statistics
import sys
import threading
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "hub"))
from hub_run import HubRun, Session, run_code  # noqa: E402


def percentile(values, p):
    ordered = sorted(values)
    index = min(len(ordered) - 1, max(0, int(round(p / 100 * (len(ordered) - 1)))))
    return ordered[index]


def children():
    """{pid: [child pids]} and {pid: rss kB} of every process."""
    tree, rss = {}, {}
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as source:
                fields = source.read().rsplit(")", 1)[1].split()
            with open(f"/proc/{entry}/status") as source:
                kb = next((int(line.split()[1]) for line in source if line.startswith("VmRSS")), 0)
        except (OSError, StopIteration, ValueError):
            continue
        tree.setdefault(int(fields[1]), []).append(int(entry))
        rss[int(entry)] = kb
    return tree, rss


def tree_rss(root, tree, rss):
    total, stack = 0, [root]
    while stack:
        pid = stack.pop()
        total += rss.get(pid, 0)
        stack.extend(tree.get(pid, []))
    return total


def cpu_seconds(pid):
    """utime + stime of one process, seconds (None once it has ended)."""
    try:
        with open(f"/proc/{pid}/stat") as source:
            fields = source.read().rsplit(")", 1)[1].split()
    except OSError:
        return None
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def tree_pids(root, tree):
    pids, stack = [], [root]
    while stack:
        pid = stack.pop()
        pids.append(pid)
        stack.extend(tree.get(pid, []))
    return pids


def student_to_kernel(hub, name, times, errors, tokens):
    t0 = time.monotonic()
    try:
        session = hub.front(name)
        hub.sign_in(session)
        hub.wait_server(session, name, timeout=180)
        token = hub.user_token(session, name)
        status, kernel = Session(hub).api("POST", f"/user/{name}/api/kernels",
                                          {"name": "python3"}, token=token)
        assert status in (200, 201), f"kernel: {status} {kernel}"
        reply, out, error = run_code(hub, name, token, "print(1)", timeout=120)
        assert reply == "ok" and out.strip() == "1", f"{reply} {out} {error}"
        times[name] = time.monotonic() - t0
        tokens[name] = token
    except Exception as error:  # reported with the figures
        errors[name] = str(error)[:300]


def run(hub, names):
    times, errors, tokens = {}, {}, {}
    threads = [threading.Thread(target=student_to_kernel, args=(hub, n, times, errors, tokens))
               for n in names]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    return times, errors, tokens


def line(label, values):
    if not values:
        return f"{label}: none"
    return (f"{label}: n={len(values)} p50 {statistics.median(values):.1f} s, "
            f"p95 {percentile(values, 95):.1f} s, max {max(values):.1f} s")


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("bin_dir")
    parser.add_argument("source_dir")
    parser.add_argument("--alone", type=int, default=5)
    parser.add_argument("--together", type=int, default=10)
    parser.add_argument("--idle-seconds", type=float, default=20,
                        help="how long the CPU at rest is measured")
    args = parser.parse_args()
    alone = [f"solo{i}" for i in range(args.alone)]
    together = [f"class{i}" for i in range(args.together)]
    load_before = os.getloadavg()[0]
    hub = HubRun(args.bin_dir, args.source_dir, alone + together)
    failed = False
    try:
        hub.start()
        solo_times, solo_errors = [], {}
        for name in alone:
            times, errors, _ = run(hub, [name])
            solo_times += list(times.values())
            solo_errors.update(errors)
        print(line("sign-in to a running kernel, alone", solo_times))
        times, errors, tokens = run(hub, together)
        print(line(f"sign-in to a running kernel, {len(together)} at once", list(times.values())))
        for name, error in {**solo_errors, **errors}.items():
            print(f"  failed: {name}: {error}")
            failed = True
        # Memory, each of the together students with a kernel open (and importing sirupp).
        for name, token in tokens.items():
            status, _ = Session(hub).api("POST", f"/user/{name}/api/kernels", {"name": "python3"},
                                         token=token)
        time.sleep(3)
        tree, rss = children()
        rig_parent = hub.cls.proc.pid
        per_student = []
        roots = {}  # student: (notebook side's roots, rig's roots)
        for name in tokens:
            supervisors = [p for p in hub.supervisors()
                           if os.path.exists(f"/proc/{p}") and
                           f"/run/{name}/" in open(f"/proc/{p}/cmdline").read().replace("\0", " ")]
            server = sum(tree_rss(p, tree, rss) for p in supervisors)
            rig = 0
            rig_roots = []
            for pid in tree.get(rig_parent, []):
                try:
                    text = open(f"/proc/{pid}/cmdline").read()
                except OSError:
                    continue
                if f"/students/{name}/" in text:
                    rig += tree_rss(pid, tree, rss)
                    rig_roots.append(pid)
            per_student.append((server, rig))
            roots[name] = (supervisors, rig_roots)
        if per_student:
            servers = [s for s, _ in per_student]
            rigs = [r for _, r in per_student]
            print(f"memory per student (RSS, {len(per_student)} students, a kernel open): "
                  f"notebook side {statistics.median(servers) / 1024:.0f} MB median "
                  f"(max {max(servers) / 1024:.0f}), class rig {statistics.median(rigs) / 1024:.0f} MB, "
                  f"together {statistics.median([s + r for s, r in per_student]) / 1024:.0f} MB")
        # CPU at rest: each student's notebook side (server, idle kernel, bridges) and rig (the arm
        # standing still), over --idle-seconds.
        if roots:
            groups = {name: ([q for r in nb for q in tree_pids(r, tree)],
                             [q for r in rg for q in tree_pids(r, tree)])
                      for name, (nb, rg) in roots.items()}
            start = {pid: cpu_seconds(pid) for nb, rg in groups.values() for pid in nb + rg}
            wall0 = time.monotonic()
            time.sleep(args.idle_seconds)
            wall = time.monotonic() - wall0
            end = {pid: cpu_seconds(pid) for pid in start}

            def share(pids):
                used = sum(end[p] - start[p] for p in pids
                           if start[p] is not None and end[p] is not None)
                return 100.0 * used / wall

            notebook = [share(nb) for nb, _ in groups.values()]
            rig_idle = [share(rg) for _, rg in groups.values()]
            print(f"CPU per student at rest over {wall:.0f} s ({len(groups)} students, a kernel "
                  f"open, the arm still): notebook side {statistics.median(notebook):.2f} % of a "
                  f"core median (max {max(notebook):.2f}), class rig "
                  f"{statistics.median(rig_idle):.2f} % (a moving rig: bench/rig_cpu.py)")
        # The hub's own tree without the servers' supervisors (counted per student above).
        supervisors = set(hub.supervisors())
        hub_rss, stack = 0, [hub.hub.pid]
        while stack:
            pid = stack.pop()
            hub_rss += rss.get(pid, 0)
            stack.extend(c for c in tree.get(pid, []) if c not in supervisors)
        print(f"the hub and its proxy: {hub_rss / 1024:.0f} MB; the class server with its rigs: "
              f"{tree_rss(rig_parent, tree, rss) / 1024:.0f} MB")
        print(f"load average after: {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs "
              f"(before: {load_before:.1f})")
    finally:
        left = hub.stop()
        if left:
            print("left running (killed):", left)
        hub.clean()
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

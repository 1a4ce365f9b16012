#!/usr/bin/python3
"""What one class rig costs in CPU, per process, robust to a machine shared with other work.

A class server (`sirupp class serve`) with --rigs students (1), each rig started through its page
(sirupp-sim realtime + sirupp-control + sirupp-logger; the panel's hub and API in the server), a
live event stream open at 30 updates a second and movement set VII running in a loop through the
panel's API, as bench/class_bench.py runs them. Over --seconds of steady running it reads each
process's user + system CPU time from /proc/PID/stat (every thread) and the simulated time the
rigs advanced (from their streams), and prints, per process kind, the CPU seconds it used per
simulated second (= the share of one core it needs at real time), the total per rig, and the
rigs one core could hold at that cost (1 / total).

CPU seconds per simulated second do not depend on how busy the machine is (a rig slowed by its
neighbours uses less CPU per wall second, but not per simulated second), unlike the real-time
factor class_bench.py measures; so this is the figure to compare before and after a change on a
shared machine. The server's line includes what is the same for any number of rigs (its own
threads); with --rigs N it is divided by N.

Usage: rig_cpu.py BIN_DIR SOURCE_DIR [--seconds 20] [--rigs 1] [--rounds 1] [--first-port 9431]
                  [--pace-ticks 4] [--pin | --compare-pin]
--compare-pin runs each round twice, with the class file's limits.pin_rigs on (each rig's
processes on one CPU) and off, and prints the ratio of the medians.
The rigs lease udpm ports from --first-port on, away from the class file's default range (7900),
which the class tests use: two class servers on one machine leasing the same port would share
their rigs' traffic.
Uses Debian's /usr/bin/python3; every process it starts is ended before it exits."""

import argparse
import os
import statistics
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from class_bench import Driver, Stream, bench_class, cpu_seconds, end_rigs  # noqa: E402


def comm(pid):
    try:
        with open(f"/proc/{pid}/comm") as f:
            return f.read().strip()
    except OSError:
        return "?"


def sim_time(stream):
    return ((stream.latest or {}).get("sim") or {}).get("sim_time_s")


def round_(bin_dir, src, rigs, seconds, first_port, pin, pace_ticks):
    run, names = bench_class(bin_dir, src, rigs, first_port, pin, pace_ticks)
    run.start()
    streams, drivers = [], []
    try:
        for name in names:
            status, body = run.http("GET", f"/s/{name}/", run.token(name))
            if status != 200:
                raise RuntimeError(f"{name}'s rig did not start: {status} {body!r:.300}")
        for name in names:
            s = Stream(run, name)
            s.start()
            streams.append(s)
        for name, s in zip(names, streams):
            d = Driver(run, name, s)
            d.start()
            drivers.append(d)
        time.sleep(3)  # settle: every rig running its plan
        pids = {pid: comm(pid) for pid in run.rig_pids()}
        pids[run.proc.pid] = "class server"
        cpu0 = {pid: cpu_seconds(pid) for pid in pids}
        sim0 = [sim_time(s) for s in streams]
        wall0 = time.time()
        time.sleep(seconds)
        cpu1 = {pid: cpu_seconds(pid) for pid in pids}
        sim1 = [sim_time(s) for s in streams]
        wall1 = time.time()
        if None in sim0 or None in sim1:
            raise RuntimeError("a rig's stream gave no simulated time")
        simulated = sum(b - a for a, b in zip(sim0, sim1))  # over every rig
        per_kind = {}
        for pid, kind in pids.items():
            if cpu0[pid] is None or cpu1[pid] is None:
                raise RuntimeError(f"{kind} (pid {pid}) ended during the measurement")
            per_kind[kind] = per_kind.get(kind, 0.0) + cpu1[pid] - cpu0[pid]
        failed = sum(len(d.failed) for d in drivers)
        done = sum(d.done for d in drivers)
        rtf = simulated / rigs / (wall1 - wall0)
        reasons = sorted({r for d in drivers for r in d.failed})[:3]
        return {k: v / simulated for k, v in per_kind.items()}, rtf, done, failed, reasons
    finally:
        end_rigs(run, drivers, streams)


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("bin_dir")
    parser.add_argument("source_dir")
    parser.add_argument("--seconds", type=float, default=20)
    parser.add_argument("--rigs", type=int, default=1)
    parser.add_argument("--rounds", type=int, default=1)
    parser.add_argument("--first-port", type=int, default=9431,
                        help="first udpm port of the rigs (0: the class file's default, 7900)")
    parser.add_argument("--pin", action="store_true",
                        help="limits.pin_rigs: true (each rig's processes on one CPU; default off)")
    parser.add_argument("--pace-ticks", type=int, default=4,
                        help="rigs.pace_ticks: each sim sleeps once per N ticks (1: every tick)")
    parser.add_argument("--compare-pin", action="store_true",
                        help="every round twice: pinned, then not (same minutes, same load)")
    args = parser.parse_args()
    print(f"rig CPU: {args.rigs} rig(s), pace_ticks {args.pace_ticks}, set VII in a loop, one 30 Hz stream each, "
          f"{args.seconds:.0f} s per round; CPU seconds per simulated second (% of one core "
          f"at real time)", flush=True)
    variants = [True, False] if args.compare_pin else [args.pin]
    results = {pin: [] for pin in variants}
    for r in range(args.rounds):
        for pin in variants:
            shares, rtf, done, failed, reasons = round_(args.bin_dir, args.source_dir, args.rigs,
                                                        args.seconds, args.first_port, pin,
                                                        args.pace_ticks)
            load = open("/proc/loadavg").read().split()[0]
            total = sum(shares.values())
            line = "  ".join(f"{k} {100 * v:5.1f} %" for k, v in sorted(shares.items()))
            print(f"round {r + 1}, {'pinned' if pin else 'not pinned'}: {line}  | rig total "
                  f"{100 * total:5.1f} % = {1 / total:4.1f} rigs per core | rtf {rtf:.3f}, "
                  f"plans done {done}, failed {failed}, load {load}"
                  f"{'  ' + '; '.join(reasons) if reasons else ''}",
                  flush=True)
            results[pin].append((shares, total))
    medians = {}
    for pin in variants if args.rounds > 1 or len(variants) > 1 else []:
        kinds = sorted(results[pin][0][0])
        med = {k: statistics.median(s.get(k, 0.0) for s, _ in results[pin]) for k in kinds}
        medians[pin] = statistics.median(t for _, t in results[pin])
        print(f"median, {'pinned' if pin else 'not pinned'}: " +
              "  ".join(f"{k} {100 * v:5.1f} %" for k, v in med.items()) +
              f"  | rig total {100 * medians[pin]:5.1f} % = {1 / medians[pin]:4.1f} rigs per core")
    if len(medians) == 2:
        print(f"pinned / not pinned: {medians[True] / medians[False]:.2f} of the CPU per rig")

if __name__ == "__main__":
    main()

#!/usr/bin/python3
"""Python benchmarks of issue 31, printed in one run:

1. Lockstep ticks per second of a controller written in Python as a process controller
   (sirupp.run_process_controller with example 7's computed torque + PID law) against example 5's
   C++ process controller (build/bin/joint_pid), each sirupp-sim --mode lockstep's only
   participant on a leased udpm port (ttl=0), for D simulated seconds; the rate is the sim's ticks
   over its wall time (start to exit). Goal: Python / C++ >= 0.5.
2. fkine calls per second from Python (sirupp.Model.fkine, the C++ chain) against a plain-numpy
   standard-DH forward kinematics of the same chain (the same 4x4 product a student would write).
   Goal: >= 5x.

Usage: PYTHONPATH=build/python /usr/bin/python3 bench/python_bench.py [BIN_DIR] [--seconds D]
       [--rounds R] [--calls N]      (from the source root; BIN_DIR default build/bin)
"""
import argparse
import os
import subprocess
import sys
import textwrap
import time

import numpy as np

import sirupp

PUMA = "config/robots/puma260.yaml"
PY_CONTROLLER = textwrap.dedent("""
    import sys, sirupp
    sys.path.insert(0, "examples/07_python_controller")
    from computed_torque_pid import Controller
    sirupp.run_process_controller(Controller, lcm_url=sys.argv[1], name="python", stale_s=0.5)
""")


def lockstep_rate(bin_dir, url, participant, controller_argv, seconds):
    controller = subprocess.Popen(controller_argv, stdout=subprocess.DEVNULL,
                                  stderr=subprocess.PIPE, text=True)
    try:
        time.sleep(0.5 if participant == "cpp-pid" else 1.5)  # let it subscribe (Python imports)
        start = time.perf_counter()
        sim = subprocess.run([os.path.join(bin_dir, "sirupp-sim"), "--lcm-url", url, "--mode",
                              "lockstep", "--participants", participant, "--duration",
                              str(seconds), "--lockstep-timeout", "5"],
                             capture_output=True, text=True)
        wall = time.perf_counter() - start
    finally:
        controller.terminate()
        controller.wait()
    if sim.returncode != 0 or " 0 lockstep timeouts" not in sim.stderr:
        raise SystemExit("sirupp-sim with %s failed: %s" % (participant, sim.stderr[-1500:]))
    return seconds / 0.000512 / wall


def dh_numpy(dh, q):
    """Standard DH: T = prod Rz(theta) Tz(d) Tx(a) Rx(alpha), one 4x4 per joint."""
    T = np.eye(4)
    for (a, alpha, d, offset), qi in zip(dh, q):
        theta = qi + offset
        ct, st, ca, sa = np.cos(theta), np.sin(theta), np.cos(alpha), np.sin(alpha)
        T = T @ np.array([[ct, -st * ca, st * sa, a * ct],
                          [st, ct * ca, -ct * sa, a * st],
                          [0.0, sa, ca, d],
                          [0.0, 0.0, 0.0, 1.0]])
    return T


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument("bin_dir", nargs="?", default="build/bin")
    parser.add_argument("--seconds", type=float, default=4.0)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--calls", type=int, default=20000)
    args = parser.parse_args()
    print("load average at start: %.2f %.2f %.2f" % os.getloadavg())

    lease = sirupp._sirupp._PortLease.acquire(20000, 10000, os.getpid())
    url = sirupp._sirupp._rig_url(lease.port)
    cpp, python = [], []
    for _ in range(args.rounds):  # alternating, so both see the same machine
        cpp.append(lockstep_rate(args.bin_dir, url, "cpp-pid",
                                 [os.path.join(args.bin_dir, "joint_pid"), "--lcm-url", url,
                                  "--deg", "30", "-20", "40", "25", "-30", "45"], args.seconds))
        python.append(lockstep_rate(args.bin_dir, url, "python",
                                    [sys.executable, "-c", PY_CONTROLLER, url], args.seconds))
    lease.release()
    c, p = float(np.median(cpp)), float(np.median(python))
    print("lockstep, %g s simulated, median of %d rounds: C++ process controller (example 5) "
          "%.0f ticks/s, Python process controller (example 7's law) %.0f ticks/s" % (
              args.seconds, args.rounds, c, p))
    print("  rounds C++: %s; Python: %s" % (", ".join("%.0f" % v for v in cpp),
                                            ", ".join("%.0f" % v for v in python)))
    print("  Python / C++ = %.2f (goal >= 0.5: %s)" % (p / c, "met" if p / c >= 0.5 else "NOT met"))

    m = sirupp.Model(PUMA)
    dh = m.dh
    rng = np.random.default_rng(1)
    qs = rng.uniform(-1, 1, (args.calls, m.n))
    base, tool = m.base, m.tool
    # Same answer first (the numpy chain with the model's base and tool).
    for q in qs[:100]:
        assert np.allclose(base @ dh_numpy(dh, q) @ tool, m.fkine(q), atol=1e-12)
    start = time.perf_counter()
    for q in qs:
        m.fkine(q)
    ours = args.calls / (time.perf_counter() - start)
    start = time.perf_counter()
    for q in qs:
        base @ dh_numpy(dh, q) @ tool
    numpy_rate = args.calls / (time.perf_counter() - start)
    print("fkine from Python: sirupp.Model.fkine %.0f calls/s, plain-numpy DH %.0f calls/s: "
          "%.1fx (goal >= 5x: %s)" % (ours, numpy_rate, ours / numpy_rate,
                                      "met" if ours / numpy_rate >= 5 else "NOT met"))
    print("load average at end: %.2f %.2f %.2f" % os.getloadavg())


if __name__ == "__main__":
    main()

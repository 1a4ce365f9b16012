#!/usr/bin/python3
"""sirupp-panel's figures, measured with a real browser: sirupp-sim (realtime, 1953 Hz) +
sirupp-control + sirupp-panel on a private udpm port, one headless Chromium page at 60 frames of
state per second while the arm runs set VII.

Prints: state-to-browser latency (median, p95), measured in the page as the time from the panel
receiving a SIM_ARM_STATE to the page drawing it (same machine, same clock); the page's frame rate;
the panel process's CPU share of one core and its resident memory; the sim's real-time factor.
Goals (issue 18): latency median < 50 ms, >= 30 fps, panel < 10 % of a core.

Usage: bench/panel_bench.py BIN_DIR [SECONDS [PANEL_ARGS...]]   (run from the source tree)
e.g. PANEL_ARGS --lcm-ticks: the per-tick channels through LCM, as before the batched reader."""

import os
import statistics
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "panel"))
from panel_rig import Rig, http, open_panel, wait_for  # noqa: E402

BIN = sys.argv[1]
SECONDS = float(sys.argv[2]) if len(sys.argv) > 2 else 10.0
PANEL_ARGS = sys.argv[3:]
TICK = os.sysconf("SC_CLK_TCK")


def cpu_seconds(pid):
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / TICK  # utime + stime


def thread_cpu(pid):
    """{thread name/tid: CPU seconds} of every thread of `pid` (the profile: where the time goes)."""
    out = {}
    for tid in os.listdir(f"/proc/{pid}/task"):
        try:
            with open(f"/proc/{pid}/task/{tid}/stat") as f:
                head, rest = f.read().rsplit(")", 1)
            fields = rest.split()
            out[head.split("(", 1)[1] + "/" + tid] = (int(fields[11]) + int(fields[12])) / TICK
        except OSError:
            pass
    return out


def rss_mib(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return float("nan")


rig = Rig(BIN, os.getcwd(), port=7950 + os.getpid() % 40, panel_args=PANEL_ARGS).start()
try:
    page = rig.browser(1280, 800)
    open_panel(page, rig.address, hz=60)
    base = rig.address
    headers = {"X-Sirupp-Client": "bench", "Content-Type": "application/json"}
    http("POST", base + "api/lock", {"name": "bench"}, headers)
    with open("config/plans/set7.plan") as f:
        plan = f.read()
    http("POST", base + "api/plan/run", {"name": "set7.plan", "text": plan}, headers)
    time.sleep(2)  # warm up
    page.execute_script("window.panelStats.latencies = []")
    frames0 = page.execute_script("return window.panelStats.frames")
    drawn0 = page.execute_script("return window.panelStats.drawn || 0")
    cpu0, t0 = cpu_seconds(rig.panel.pid), time.time()
    threads0 = thread_cpu(rig.panel.pid)
    states0 = page.execute_script("return window.panelStats.received")
    time.sleep(SECONDS)
    frames1 = page.execute_script("return window.panelStats.frames")
    cpu1, t1 = cpu_seconds(rig.panel.pid), time.time()
    threads1 = thread_cpu(rig.panel.pid)
    drawn1 = page.execute_script("return window.panelStats.drawn || 0")
    states1 = page.execute_script("return window.panelStats.received")
    latencies = sorted(page.execute_script("return window.panelStats.latencies"))
    rss = rss_mib(rig.panel.pid)
    _, processes = http("GET", base + "api/processes")
    wall = t1 - t0
    sim_rate = [r["rates"].get("out SIM_ARM_STATE", 0) for r in processes["processes"] if r["process"] == "sirupp-sim"]
    print(f"panel_bench: {wall:.1f} s with the sim publishing SIM_ARM_STATE at "
          f"{sim_rate[0] if sim_rate else float('nan'):.0f} Hz "
          f"(real-time factor {processes.get('realtime_factor', float('nan')):.3f}); "
          f"{os.cpu_count()} cores, load average {os.getloadavg()[0]:.1f}"
          f"{'; panel ' + ' '.join(PANEL_ARGS) if PANEL_ARGS else ''}")
    if latencies:
        p95 = latencies[min(len(latencies) - 1, int(0.95 * len(latencies)))]
        print(f"state-to-browser latency: median {statistics.median(latencies):.1f} ms, p95 {p95:.1f} ms "
              f"over {len(latencies)} drawn states (goal: median < 50 ms)")
    print(f"states received by the page: {(states1 - states0) / wall:.1f} per s (asked 60)")
    print(f"page frame rate: {(frames1 - frames0) / wall:.1f} fps (goal >= 30); "
          f"3D renders {(drawn1 - drawn0) / wall:.1f} per s (0: a page without that counter)")
    print(f"sirupp-panel: {100 * (cpu1 - cpu0) / wall:.1f} % of one core (goal < 10 %), {rss:.1f} MiB resident")
    busiest = sorted(((threads1[k] - threads0.get(k, 0), k) for k in threads1), reverse=True)[:4]
    print("sirupp-panel threads (% of one core): " +
          ", ".join(f"{name} {100 * sec / wall:.1f}" for sec, name in busiest))
finally:
    rig.stop()

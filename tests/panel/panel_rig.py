"""A private rig for the panel's browser tests and benchmark: sirupp-sim + sirupp-control
(+ optionally the emulated real arm: sirupp-picservo-emu and sirupp-hardware) + sirupp-panel on
their own udpm port with ttl=0, and headless Chromium through Selenium. Every process started here
is ended by stop(). Uses Debian's python3-selenium (/usr/bin/python3)."""

import json
import os
import re
import signal
import shutil
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

from selenium import webdriver
from selenium.webdriver.chrome.options import Options
from selenium.webdriver.chrome.service import Service


def checker(failures):
    """check(name, fn) for the browser tests: runs fn, prints "ok   NAME (T s)" or "FAIL NAME: why",
    and appends NAME to `failures` when it raised (one failed check does not hide the others)."""
    def check(name, fn):
        t0 = time.time()
        try:
            fn()
            print(f"ok   {name} ({time.time() - t0:.1f} s)", flush=True)
        except Exception as error:
            failures.append(name)
            print(f"FAIL {name}: {error}", flush=True)
    return check


def wait_for(what, predicate, timeout=20.0, period=0.05):
    """Polls predicate() until it returns a true value (returned) or raises after timeout."""
    end = time.time() + timeout
    last = None
    while time.time() < end:
        try:
            last = predicate()
            if last:
                return last
        except Exception as error:  # the page may be mid-update
            last = error
        time.sleep(period)
    raise AssertionError(f"timed out after {timeout} s waiting for {what} (last: {last!r})")


class Rig:
    def __init__(self, bin_dir, source_dir, hardware=False, port=None, panel_args=(), logger=False,
                 sim_args=()):
        self.bin = os.path.abspath(bin_dir)  # the panel may run in another folder (logger=True)
        self.src = os.path.abspath(source_dir)
        self.port = port or 7800 + os.getpid() % 150
        self.url = f"udpm://239.255.76.67:{self.port}?ttl=0"
        self.work = tempfile.mkdtemp(prefix="sirupp-panel-test-")
        self.procs = []
        self.drivers = []
        self.hardware = hardware
        self.panel_args = list(panel_args)
        self.sim_args = list(sim_args)  # e.g. ["--environment", "config/environments/table.xml"]
        # With the logger: sirupp-logger writes into work/results, which the panel lists
        # (--results), and the panel runs in work/root holding a copy of config/, so a model the
        # page saves goes there, never into the source tree.
        self.logger = logger
        self.results = os.path.join(self.work, "results")
        self.root = os.path.join(self.work, "root")
        self.panel = None
        self.address = None

    def _start(self, name, args, cwd=None):
        log = open(os.path.join(self.work, name + ".log"), "w")
        p = subprocess.Popen([os.path.join(self.bin, args[0])] + args[1:], cwd=cwd or self.src,
                             stdout=subprocess.PIPE if name == "panel" else log, stderr=log,
                             text=True)
        self.procs.append((name, p))
        return p

    def start(self):
        pose = ["--pose", "ready"] if self.hardware else []
        if self.hardware:
            link = os.path.join(self.work, "puma-bus")
            self._start("emulator", ["sirupp-picservo-emu", "--socket", link, "--start-pose", "ready"])
            wait_for("the emulator's device", lambda: os.path.exists(link), 10)
        self._start("sim", ["sirupp-sim", "--lcm-url", self.url, "--mode", "realtime"] + pose +
                    self.sim_args)
        self._start("control", ["sirupp-control", "--lcm-url", self.url])
        if self.hardware:
            self._start("hardware", ["sirupp-hardware", "--lcm-url", self.url, "--port", link,
                                     "--emulated", "--calibrate", "--arm", "--link"])
        if self.logger:
            os.makedirs(self.results)
            shutil.copytree(os.path.join(self.src, "config"), os.path.join(self.root, "config"))
            self._start("logger", ["sirupp-logger", "--lcm-url", self.url, "--out", self.results,
                                   "--split", "none"])
            self.panel_args += ["--results", self.results]
        self.panel, self.address = self.start_panel(self.panel_args)
        return self

    def start_panel(self, extra):
        p = self._start("panel", ["sirupp-panel", "--lcm-url", self.url, "--port", "0"] + list(extra),
                        cwd=self.root if self.logger else None)
        line = p.stdout.readline()
        m = re.search(r"(http://\S+)", line)
        if not m:
            raise AssertionError("sirupp-panel printed no address: " + repr(line) + " " +
                                 open(os.path.join(self.work, "panel.log")).read())
        return p, m.group(1)

    def browser(self, width=1400, height=900):
        o = Options()
        for a in ("--headless=new", "--no-sandbox", "--enable-unsafe-swiftshader",
                  f"--window-size={width},{height}", "--disable-gpu-sandbox"):
            o.add_argument(a)
        o.set_capability("goog:loggingPrefs", {"browser": "ALL"})
        # Chromium puts its singleton folder (org.chromium.Chromium.*) in TMPDIR and leaves it
        # behind: in the test's own folder it goes with the test (stop()).
        tmp = os.path.join(self.work, "chromium")
        os.makedirs(tmp, exist_ok=True)
        service = Service("/usr/bin/chromedriver", env=dict(os.environ, TMPDIR=tmp))
        d = webdriver.Chrome(service=service, options=o)
        self.drivers.append(d)
        return d

    def stop(self):
        for d in self.drivers:
            try:
                d.quit()
            except Exception:
                pass
        shutil.rmtree(os.path.join(self.work, "chromium"), ignore_errors=True)
        for name, p in reversed(self.procs):
            if p.poll() is None:
                p.send_signal(signal.SIGTERM)
        for name, p in reversed(self.procs):
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()

    def log(self, name):
        with open(os.path.join(self.work, name + ".log")) as f:
            return f.read()


def report(test, failures, rig, logs):
    """After rig.stop(): a process log with a sanitizer report or a terminate is a failure too;
    prints the verdict and exits 1 on any failure."""
    for name in logs:
        log = rig.log(name)
        if "Sanitizer" in log or "terminate" in log:
            failures.append(name + " log")
            print(log)
    if failures:
        print(f"{test}: FAILED: " + ", ".join(failures))
        sys.exit(1)
    print(f"{test}: all checks passed")


def http(method, url, body=None, headers=None):
    """(status, parsed JSON body) of one request."""
    data = json.dumps(body).encode() if body is not None else None
    req = urllib.request.Request(url, data=data, method=method, headers=headers or {})
    try:
        with urllib.request.urlopen(req, timeout=5) as r:
            return r.status, json.loads(r.read() or b"{}")
    except urllib.error.HTTPError as e:
        return e.code, json.loads(e.read() or b"{}")


def open_panel(driver, address, hz=20):
    # 20 frames a second of state: enough for the checks, lighter on a loaded machine.
    driver.get(address + ("&" if "?" in address else "?") + f"hz={hz}")
    wait_for("the page's model and live state", lambda: driver.execute_script(
        "return window.panelReady && model !== null && document.getElementById('joint-2') !== null"
        " && window.panelStats.received > 5"), 30)


def severe_errors(driver):
    return [e for e in driver.get_log("browser") if e["level"] == "SEVERE"]

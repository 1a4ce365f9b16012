"""A class server for the class tests and benchmark: writes a class file into a temporary folder,
starts `sirupp class serve` on a free port of 127.0.0.1 (rigs on leased udpm ports, ttl=0), reads
the addresses with tokens it prints, and ends it (and so every rig) in stop(). Headless Chromium
through Selenium as the panel's tests do. Uses Debian's python3-selenium (/usr/bin/python3)."""

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "panel"))
from panel_rig import Rig, wait_for  # noqa: E402,F401  (wait_for re-exported for the tests)


class ClassRun:
    def __init__(self, bin_dir, source_dir, students, idle_timeout_s=900, max_rigs=None,
                 extra_limits="", extra_yaml="", server_yaml="{port: 0}"):
        self.bin = os.path.abspath(bin_dir)
        self.src = os.path.abspath(source_dir)
        self.work = tempfile.mkdtemp(prefix="sirupp-class-test-")
        self.students = list(students)
        self.addresses = {}
        self.base = None
        self.proc = None
        self.drivers = []
        max_rigs = max_rigs or len(self.students)
        self.class_file = os.path.join(self.work, "class.yaml")
        with open(self.class_file, "w") as f:
            f.write("class: test-class\n"
                    f"robot: {self.src}/config/robots/puma260.yaml\n"
                    f"students: [{', '.join(self.students)}]\n"
                    "data: data\n"
                    f"limits: {{max_rigs: {max_rigs}, idle_timeout_s: {idle_timeout_s}{extra_limits}}}\n"
                    f"server: {server_yaml}\n" + extra_yaml)

    def start(self):
        self.log_file = open(os.path.join(self.work, "server.log"), "w")
        self.proc = subprocess.Popen([os.path.join(self.bin, "sirupp"), "class", "serve",
                                      self.class_file], cwd=self.src, stdout=subprocess.PIPE,
                                     stderr=self.log_file, text=True)
        end = time.time() + 30
        while time.time() < end:
            line = self.proc.stdout.readline()
            if not line:
                raise AssertionError("sirupp class serve ended: " + self.server_log())
            m = re.match(r"new token: ([^,]+),(\S+)", line)
            if m:
                self.addresses[m.group(1)] = m.group(2)
            m = re.match(r"sirupp class: \S+ at (http://\S+?)/ ", line)
            if m:
                self.base = m.group(1)
                return self
        raise AssertionError("sirupp class serve printed no address")

    def token(self, name):
        return self.addresses[name].split("token=")[1]

    def data(self, *parts):
        return os.path.join(self.work, "data", *parts)

    def server_log(self):
        self.log_file.flush()
        with open(os.path.join(self.work, "server.log")) as f:
            return f.read()

    def http(self, method, path, token=None, body=None):
        """(status, parsed JSON body) of one request to the server."""
        headers = {"X-Sirupp-Client": "test"}
        if token:
            headers["X-Sirupp-Token"] = token
        data = json.dumps(body).encode() if body is not None else (b"{}" if method == "POST" else None)
        req = urllib.request.Request(self.base + path, data=data, method=method, headers=headers)
        try:
            with urllib.request.urlopen(req, timeout=30) as r:
                text = r.read()
                return r.status, (json.loads(text) if r.headers.get_content_type() == "application/json" else text)
        except urllib.error.HTTPError as e:
            text = e.read()
            try:
                return e.code, json.loads(text)
            except ValueError:
                return e.code, text

    def rig_pids(self):
        """pids of the server's children (the rigs' processes)."""
        out = []
        for entry in os.listdir("/proc"):
            if not entry.isdigit():
                continue
            try:
                with open(f"/proc/{entry}/stat") as f:
                    fields = f.read().rsplit(")", 1)[1].split()
            except OSError:
                continue
            if int(fields[1]) == self.proc.pid:
                out.append(int(entry))
        return out

    def browser(self, width=1400, height=900):
        """Headless Chromium as the panel's tests start it; ended by stop()."""
        return Rig.browser(self, width, height)  # it only keeps the driver in self.drivers

    def stop(self):
        for d in self.drivers:
            try:
                d.quit()
            except Exception:
                pass
        if self.proc and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()

    def clean(self):
        shutil.rmtree(self.work, ignore_errors=True)


def alive(pid):
    """True while pid runs (a zombie counts as ended)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False

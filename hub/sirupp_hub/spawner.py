"""SiruppSpawner: each student's notebook server and its kernels in a sandbox (sirupp_hub.sandbox),
wired to the student's own rig (JupyterHub 3.0's Spawner interface).

start  asks the class server for the student's rig (started as a page visit would, its LCM URL;
       a rig job that has not reported yet is asked for again), copies the class's notebooks into
       the student's folder (never over a file there), and starts the supervisor
       (sirupp_hub.supervise) in a session of its own where the class server's answer says:
       - on this machine: the hub's proxy reaches the server on 127.0.0.1:PORT, a forwarder to
         its Unix socket;
       - inside the rig's job (the answer names one): `srun --jobid=JOB --overlap` runs the
         supervisor as a step of that job on its node; it listens on the node's address (the one
         the job reported) on a port it picks there and writes to RUN/port.json, which start
         waits for
poll   by pid (the supervisor's, or srun's; and the process's start time, so a reused pid is not
       taken for it): None while it runs, else its exit status; while it runs the rig is touched
       (each poll, at most every 30 s) so the class server does not stop it as idle, and a local
       rig started again on another bus is followed (the supervisor moves the outer bridge,
       SIGHUP); a server in a job ends with the job (scancel, time limit: Slurm ends the step,
       then srun)
stop   SIGTERM to the process group (srun forwards it to the step), SIGKILL after 8 s (and then
       scancel of the step, which srun's end alone does not stop)
state  pid, port, start time, address, job and step: JupyterHub keeps them in its database, so a
       restarted hub finds running servers again (neither depends on the hub's process)
"""

import asyncio
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import time

from jupyterhub.spawner import Spawner
from tornado import web
from traitlets import Unicode

from . import sandbox
from .classapi import ClassApi, ClassApiError

NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]{0,31}$")
INNER_LCM_URL = "udpm://239.255.76.67:7667?ttl=0"  # the sandbox's own bus (its own `lo`)
COPIED_LIST = ".sirupp-copied.json"
TOUCH_EVERY_S = 30
PORT_FILE = "port.json"  # a server in a job: the port it picked on its node (supervise.py)
PORT_WAIT_S = 30  # how long start waits for it
JOB = re.compile(r"^[0-9]+(_[0-9]+)?$")  # a Slurm job id as the class server names it
SRUN = "/usr/bin/srun"


def process_start(pid):
    """The process's start time in clock ticks (field 22 of /proc/PID/stat), or None when there is
    no such process or it is a zombie."""
    try:
        with open(f"/proc/{pid}/stat", encoding="utf-8") as source:
            text = source.read()
    except OSError:
        return None
    fields = text[text.rfind(")") + 2:].split()
    if fields[0] in ("Z", "X"):
        return None
    return int(fields[19])


def free_port():
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def copy_notebooks(source, target):
    """Copies the class's notebooks into the student's folder: each file once (the list of files
    copied so far is kept there), never over a file that is there, so a student's edits and
    deletions stay. Returns the files copied now."""
    if not source or not os.path.isdir(source):
        return []
    os.makedirs(target, exist_ok=True)
    listing = os.path.join(target, COPIED_LIST)
    try:
        with open(listing, encoding="utf-8") as old:
            copied = set(json.load(old))
    except (OSError, ValueError):
        copied = set()
    now = []
    for folder, _, files in os.walk(source):
        for name in sorted(files):
            if name.startswith(".") or "__pycache__" in folder:
                continue
            relative = os.path.relpath(os.path.join(folder, name), source)
            destination = os.path.join(target, relative)
            if relative in copied or os.path.exists(destination):
                copied.add(relative)
                continue
            os.makedirs(os.path.dirname(destination), exist_ok=True)
            shutil.copyfile(os.path.join(folder, name), destination)
            copied.add(relative)
            now.append(relative)
    with open(listing, "w", encoding="utf-8") as out:
        json.dump(sorted(copied), out)
    return now


def on_node(path, data_here, data_there):
    """`path` (under the class's data folder as this machine sees it) as the node sees it."""
    if not data_there or data_there == data_here:
        return path
    relative = os.path.relpath(path, data_here)
    if relative == ".." or relative.startswith("../"):
        return path
    return os.path.normpath(os.path.join(data_there, relative))


def srun_command(job, name, run_dir_there, launch_there):
    """The supervisor as one step of the rig's job, on its node, sharing the job's resources."""
    return [SRUN, f"--jobid={job}", "--overlap", "--nodes=1", "--ntasks=1", "--quiet",
            f"--job-name=notebook-{name}", f"--chdir={run_dir_there}", "--kill-on-bad-exit=1",
            "/usr/bin/python3", "-m", "sirupp_hub.supervise", launch_there]


def read_port_file(path):
    """{port, host, job, step} the supervisor wrote, or None while it is not there (or half)."""
    try:
        with open(path, encoding="utf-8") as source:
            told = json.load(source)
    except (OSError, ValueError):
        return None
    if not isinstance(told, dict) or not isinstance(told.get("port"), int):
        return None
    return told


def load_settings(path):
    with open(path, encoding="utf-8") as source:
        return json.load(source)


def module_paths(python_dir):
    """BIN_DIR and SOURCE_DIR of the sirupp module (its _paths.py, written by CMake)."""
    values = {}
    with open(os.path.join(python_dir, "sirupp", "_paths.py"), encoding="utf-8") as source:
        for line in source:
            match = re.match(r"^(BIN_DIR|SOURCE_DIR) = '(.*)'$", line.strip())
            if match:
                values[match.group(1)] = match.group(2)
    return values


class SiruppSpawner(Spawner):
    settings_file = Unicode(config=True, help="DATA/hub/hub.json, written by sirupp class notebooks")

    def __init__(self, *args, **kwargs):
        super().__init__(*args, **kwargs)
        self.pid = 0
        self.start_ticks = None
        self.proc = None
        self.last_touch = 0.0
        self.lcm_url = ""
        self.job = ""  # the rig's job the server runs in ("" = this machine)
        self.step = ""  # its step there, as the supervisor told it

    # --- state: JupyterHub's database keeps it across hub restarts ---------------------------

    def load_state(self, state):
        super().load_state(state)
        self.pid = state.get("pid", 0)
        self.start_ticks = state.get("start_ticks")
        self.lcm_url = state.get("lcm_url", "")
        self.job = state.get("job", "")
        self.step = state.get("step", "")
        if state.get("port"):
            self.port = state["port"]
        if state.get("ip"):
            self.ip = state["ip"]

    def get_state(self):
        state = super().get_state()
        if self.pid:
            state.update(pid=self.pid, start_ticks=self.start_ticks, port=self.port,
                         lcm_url=self.lcm_url, ip=self.ip, job=self.job, step=self.step)
        return state

    def clear_state(self):
        super().clear_state()
        self.pid = 0
        self.start_ticks = None
        self.proc = None
        self.job = ""
        self.step = ""

    # --- start, poll, stop ------------------------------------------------------------------

    def _api(self, settings):
        return ClassApi(settings["class_url"], settings["hub_secret_file"])

    async def start(self):
        settings = load_settings(self.settings_file)
        name = self.user.name
        if not NAME.match(name):
            raise web.HTTPError(403, "%s", f"'{name}' is not a student name of this class")
        rig = await self._ensure_rig(settings, name)
        job = rig.get("job") or ""
        if job and (not isinstance(job, str) or not JOB.match(job) or
                    not isinstance(rig.get("host"), str) or not rig["host"]):
            raise web.HTTPError(500, "%s", f"the class server named a job {job!r} on host "
                                f"{rig.get('host')!r} for {name}'s rig: not a Slurm job and "
                                "address")
        data_here = settings["data_dir"]
        data_there = rig.get("node_data") or data_here
        home = os.path.join(settings["students_dir"], name)
        os.makedirs(home, exist_ok=True)
        copied = copy_notebooks(settings.get("notebooks_dir", ""), os.path.join(home, "notebooks"))
        if copied:
            self.log.info("%s: copied %d notebook file(s)", name, len(copied))
        run_dir = os.path.join(settings["run_dir"], name)
        os.makedirs(run_dir, mode=0o700, exist_ok=True)
        # On this machine the hub picks the port; on a node the supervisor does (the hub cannot
        # know one free there) and tells it in RUN/port.json.
        self.ip = rig["host"] if job else "127.0.0.1"
        self.port = 0 if job else free_port()
        env = self.get_env()
        paths = module_paths(settings["python_dir"])
        inner_env = dict(env)
        inner_env.update({
            "JUPYTERHUB_SINGLEUSER_APP": "notebook.notebookapp.NotebookApp",
            "LCM_DEFAULT_URL": INNER_LCM_URL,
            "PYTHONPATH": ":".join([settings["python_dir"], settings["hub_dir"]]),
            "PYTHONNOUSERSITE": "1",
            "HOME": sandbox.INSIDE_HOME, "USER": name, "LOGNAME": name,
            "PATH": "/usr/bin:/bin", "LANG": "C.UTF-8", "SHELL": "/bin/sh",
            "JUPYTERHUB_DISABLE_USER_CONFIG": "1",
        })
        timeout = int(settings["idle_timeout_s"])
        args = ["--port=8888", f"--sock={sandbox.INSIDE_RUN}/nb.sock",
                "--NotebookApp.terminals_enabled=False",
                f"--NotebookApp.notebook_dir={sandbox.INSIDE_HOME}",
                f"--NotebookApp.shutdown_no_activity_timeout={timeout}",
                f"--MappingKernelManager.cull_idle_timeout={timeout}",
                f"--MappingKernelManager.cull_interval={max(2, min(300, timeout // 4))}",
                "--MappingKernelManager.cull_connected=True"]
        read_only = sorted({settings["python_dir"], settings["hub_dir"], settings["bin_dir"],
                            paths.get("BIN_DIR", settings["bin_dir"]),
                            paths.get("SOURCE_DIR", settings["python_dir"])})
        data = os.path.realpath(settings["data_dir"])
        for folder in read_only:
            real = os.path.realpath(folder)
            if data == real or data.startswith(real + "/"):
                raise web.HTTPError(500, "%s", f"the class's data folder {data} is inside {real}, "
                                    "which the sandbox shows read-only: every student's folder "
                                    "would be visible; move data: out of it")
        run_there = on_node(run_dir, data_here, data_there)
        port_file = os.path.join(run_dir, PORT_FILE)
        try:
            os.unlink(port_file)
        except FileNotFoundError:
            pass
        plan = {"name": name, "home": on_node(home, data_here, data_there), "run_dir": run_there,
                "port": self.port, "listen_host": self.ip,
                "port_file": os.path.join(run_there, PORT_FILE) if job else "",
                "hub_api_host": settings["hub_api_host"], "hub_api_port": settings["hub_api_port"],
                "lcm_url": rig.get("lcm_url", ""), "inner_lcm_url": INNER_LCM_URL,
                "bin_dir": settings["bin_dir"], "read_only": read_only,
                "inner_pythonpath": [settings["python_dir"], settings["hub_dir"]],
                "memory_mb": int(settings["memory_mb"]), "processes": int(settings["processes"]),
                "inner_env": inner_env, "args": args}
        launch = os.path.join(run_dir, "launch.json")
        with open(os.open(launch, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o600), "w") as out:
            json.dump(plan, out)
        log_file = open(os.path.join(run_dir, "server.log"), "ab")
        supervisor_env = {"PATH": "/usr/bin:/bin", "PYTHONPATH": settings["hub_dir"],
                          "LANG": "C.UTF-8"}
        if job:
            # srun finds the cluster as the class server's sbatch does; the step gets this
            # environment (srun's default --export=ALL) and Slurm's own variables.
            for key in ("SLURM_CONF",):
                if os.environ.get(key):
                    supervisor_env[key] = os.environ[key]
            command = srun_command(job, name, run_there, on_node(launch, data_here, data_there))
        else:
            command = [sys.executable, "-m", "sirupp_hub.supervise", launch]
        try:
            self.proc = subprocess.Popen(
                command, cwd=run_dir, stdin=subprocess.DEVNULL, stdout=log_file, stderr=log_file,
                env=supervisor_env, start_new_session=True)
        except OSError as error:
            raise web.HTTPError(500, "%s", f"{command[0]} could not be started for {name}: "
                                f"{error.strerror}")
        finally:
            log_file.close()
        self.pid = self.proc.pid
        self.start_ticks = process_start(self.pid)
        self.lcm_url = plan["lcm_url"]
        self.job = job
        self.step = ""
        if job:
            await self._wait_port(name, job, rig, port_file, os.path.join(run_dir, "server.log"))
        self.log.info("%s: notebook server supervisor pid %d on %s:%d (rig bus %s%s)", name,
                      self.pid, self.ip, self.port, plan["lcm_url"] or "none",
                      f", srun into Slurm job {job} on {rig.get('node') or self.ip}" if job else "")
        return (self.ip, self.port)

    async def _ensure_rig(self, settings, name):
        """The class server's answer for the student's rig; a rig job that has not reported yet
        (503 with starting) is asked for again, each second, for most of the start timeout."""
        loop = asyncio.get_running_loop()
        deadline = time.monotonic() + max(10, self.start_timeout - PORT_WAIT_S)
        waited = False
        while True:
            try:
                return await loop.run_in_executor(None, self._api(settings).ensure_rig, name)
            except ClassApiError as error:
                if error.status == 503 and error.starting and time.monotonic() < deadline:
                    if not waited:
                        self.log.info("%s: waiting for the rig: %s", name, error.message)
                        waited = True
                    await asyncio.sleep(1)
                    continue
                raise web.HTTPError(503, "%s", f"your rig could not be started: {error.message}")

    async def _wait_port(self, name, job, rig, port_file, log_path):
        """Waits for the port the supervisor picked on the node (RUN/port.json); stops the step
        and raises with why when srun ends first or the file does not come in time."""
        deadline = time.monotonic() + PORT_WAIT_S
        while True:
            told = read_port_file(port_file)
            if told is not None:
                self.port = told["port"]
                self.step = str(told.get("step", ""))
                return
            running, code = self._running()
            if not running or time.monotonic() >= deadline:
                if running:
                    await self.stop(now=True)
                try:
                    with open(log_path, errors="replace") as source:
                        tail = source.read()[-1500:].strip()
                except OSError:
                    tail = ""
                why = (f"srun ended with {code}" if not running
                       else f"it did not write {port_file} within {PORT_WAIT_S} s")
                self.pid = 0
                self.proc = None
                raise web.HTTPError(500, "%s", f"{name}'s notebook server in Slurm job {job} on "
                                    f"{rig.get('node') or rig.get('host')} did not start: {why}"
                                    + (f"; its log ends: {tail}" if tail else ""))
            await asyncio.sleep(0.1)

    def _running(self):
        if not self.pid:
            return False, 0
        if self.proc is not None:
            code = self.proc.poll()
            return (code is None), (code or 0)
        ticks = process_start(self.pid)
        return (ticks is not None and ticks == self.start_ticks), 0

    async def poll(self):
        running, code = self._running()
        if not running:
            return code if self.pid else 0
        if time.monotonic() - self.last_touch >= min(TOUCH_EVERY_S, self.poll_interval):
            self.last_touch = time.monotonic()
            settings = load_settings(self.settings_file)
            try:
                answer = await asyncio.get_running_loop().run_in_executor(
                    None, self._api(settings).touch_rig, self.user.name)
            except ClassApiError as error:
                self.log.warning("%s: the rig could not be touched: %s", self.user.name,
                                 error.message)
                return None
            if not self.job:  # a server in a job ends with it; a new job is a new server
                self._follow_rig(settings, answer.get("lcm_url", ""))
        return None

    def _follow_rig(self, settings, url):
        """The rig runs on another bus (the teacher restarted it, or it was started again from the
        page): the supervisor moves the outer bridge there (SIGHUP with RUN/rig.url)."""
        if not url or url == self.lcm_url:
            return
        path = os.path.join(settings["run_dir"], self.user.name, "rig.url")
        with open(path, "w", encoding="utf-8") as out:
            out.write(url + "\n")
        try:
            os.kill(self.pid, signal.SIGHUP)
        except ProcessLookupError:
            return
        self.log.info("%s: the rig moved from %s to %s", self.user.name, self.lcm_url, url)
        self.lcm_url = url

    async def stop(self, now=False):
        if not self.pid:
            return
        for sig, wait_s in ((signal.SIGTERM, 8), (signal.SIGKILL, 3)):
            running, _ = self._running()
            if not running:
                break
            try:
                os.killpg(self.pid, sig)
            except ProcessLookupError:
                break
            deadline = time.monotonic() + wait_s
            while time.monotonic() < deadline and self._running()[0]:
                await asyncio.sleep(0.1)
            if sig == signal.SIGKILL and self.job and self.step:
                # srun killed does not end its step: Slurm does, by its id.
                await self._scancel_step()
        self.log.info("%s: notebook server stopped", self.user.name)
        self.pid = 0
        self.proc = None
        self.job = ""
        self.step = ""

    async def _scancel_step(self):
        step = f"{self.job}.{self.step}"
        try:
            process = await asyncio.create_subprocess_exec(
                "/usr/bin/scancel", "--quiet", step, stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
            _, error = await asyncio.wait_for(process.communicate(), 15)
        except (OSError, asyncio.TimeoutError) as error:
            self.log.warning("%s: scancel %s: %s", self.user.name, step, error)
            return
        if process.returncode:
            self.log.warning("%s: scancel %s: %s", self.user.name, step,
                             error.decode(errors="replace").strip())

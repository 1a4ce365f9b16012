"""Driving a rig from Python: sirupp.connect() to a running one, sirupp.start_rig() for a private
one (sirupp-sim + sirupp-control on a udpm port of its own, ttl=0, stopped with the Rig)."""
import atexit
import os
import socket
import tempfile
import time
import weakref

import numpy as np

from . import _paths
from ._sirupp import (Model, RigError, _Child, _Client, _PortLease, _Recorder,
                      _path_to_plan_text, _pose_parts, _rig_processes, _rig_url)

# How long a private rig's logger may take to write what it received when the rig is closed.
_LOGGER_GRACE_S = 30.0

DEFAULT_MODEL = os.path.join(_paths.SOURCE_DIR, "config/robots/puma260.yaml")
# Private rigs take their port from the range `sirupp grade` uses, with the same lock files
# (grade/port_lease.hpp), so rigs and grading tasks never share a port.
_PORT_BASE, _PORT_COUNT = 20000, 10000


def _sender():
    return "python-%d@%s" % (os.getpid(), socket.gethostname())


def _config_flags(config):
    """'left-up-noflip' (any part may be '*' or missing) -> (shoulder_left, elbow_up, wrist_flip)."""
    if config is None:
        return None, None, None
    words = config.split("-")
    choices = [("left", "right"), ("up", "down"), ("noflip", "flip")]
    if len(words) != 3 or any(w not in c + ("*",) for w, c in zip(words, choices)):
        raise ValueError("config: %r; expected shoulder-elbow-wrist like 'left-up-noflip' "
                         "(left|right|*, up|down|*, noflip|flip|*)" % config)
    return tuple(None if w == "*" else w == c[0] if i < 2 else w == "flip"
                 for i, (w, c) in enumerate(zip(words, choices)))


class Recording:
    """What Rig.record() collected: numpy arrays, one row per servo tick of the virtual arm.

    t (s of sim time), tick, q (virtual arm), qd, effort, q_setpoint, qd_setpoint (NaN on ticks
    without a set-point), and the real arm's own samples: t_real (wall clock s from the first
    virtual sample), q_real (empty without a bridge)."""

    def __init__(self, raw, servo_tick_s):
        sim, sp, real = raw["sim"], raw["setpoint"], raw["real"]
        # One row per tick: in lockstep the sim sends a state again while a participant is late;
        # the last copy is kept.
        ticks = sim["tick"]
        _, last_from_end = np.unique(ticks[::-1], return_index=True)
        order = len(ticks) - 1 - last_from_end
        self.tick = sim["tick"][order]
        self.t = self.tick * servo_tick_s
        self.q, self.qd, self.effort = sim["q"][order], sim["qd"][order], sim["effort"][order]
        n = self.q.shape[1] if self.q.ndim == 2 and self.q.shape[0] else (
            sp["q"].shape[1] if sp["q"].shape[0] else 0)
        self.q_setpoint = np.full((len(self.tick), n), np.nan)
        self.qd_setpoint = np.full((len(self.tick), n), np.nan)
        if len(sp["tick"]) and len(self.tick):
            index = {int(k): i for i, k in enumerate(sp["tick"])}
            for row, k in enumerate(self.tick):
                i = index.get(int(k))
                if i is not None:
                    self.q_setpoint[row] = sp["q"][i]
                    self.qd_setpoint[row] = sp["qd"][i]
        start = sim["utime"][order][0] if len(self.tick) else 0
        self.t_real = (real["utime"] - start) * 1e-6
        self.q_real = real["q"]

    def __len__(self):
        return len(self.t)

    def __repr__(self):
        return "<Recording %d ticks, %d real samples>" % (len(self.t), len(self.t_real))


class _RecordContext:
    def __init__(self, rig):
        self._rig = rig
        self._recorder = None
        self.data = None

    def __enter__(self):
        self._recorder = _Recorder(self._rig.lcm_url, self._rig.prefix)
        return self

    def __exit__(self, *exc):
        self._rig._client.listen(0.05)  # the last ticks in flight
        self._recorder.stop()
        self.data = Recording(self._recorder.take(), self._rig.model.servo_tick_s)
        self._recorder = None
        return False

    def __getattr__(self, name):  # r.t, r.q ... after the block
        if name.startswith("_") or self.data is None:
            raise AttributeError("%s: the recording is read after its 'with' block" % name)
        return getattr(self.data, name)


_ANSWER_TIMEOUT_S = 5.0  # how long a command waits for sirupp-control's reply (none: RigError)

class Rig:
    """A running rig: its sirupp-control and sirupp-sim, reached over LCM (client/client.hpp).

    Waits release the GIL and check for Ctrl-C (or a notebook's interrupt): an interrupted move
    or plan is stopped (the stop button: a smooth stop) before KeyboardInterrupt is raised."""

    def __init__(self, lcm_url=None, prefix="", model=None, timeout=5.0, _processes=None,
                 _lease=None, _logger=None):
        self.lcm_url = lcm_url if lcm_url is not None else os.environ.get("LCM_DEFAULT_URL", "")
        self.prefix = prefix
        self._processes = _processes or []
        self._logger = _logger  # one of _processes: stopped last, given time to write
        self._lease = _lease
        self._closed = False
        self.model = model if isinstance(model, Model) else Model(model or DEFAULT_MODEL)
        try:
            # A command's reply may wait: sirupp-control answers from its loop, which a loaded
            # laptop (a build, a browser beside it) can hold up for seconds; a reply that comes
            # is matched to its request however late, so this bounds only the wait for none.
            self._client = _Client(self.lcm_url, prefix, _sender(), _ANSWER_TIMEOUT_S)
            self._client.watch_joints(True)
            # Status, gains and state are all there before the rig is handed out, so state(),
            # gains() and status() never answer None (sirupp-control sends its gains once a
            # second: a fresh client waits up to that long for them).
            missing = self._client.wait_for_rig(timeout)
            if missing:
                where = self.lcm_url or "LCM's default URL"
                raise RigError("no %s on %s within %g s: %s" % (
                    ", ".join(missing), where, timeout, _why_missing(missing)) +
                    self._process_logs())
        except BaseException:
            self.close()
            raise

    # --- reading (connect() and start_rig() return only once status, gains and state came)
    def state(self):
        """The newest state: dict with tick, q, qd, effort (virtual arm) and q_setpoint,
        qd_setpoint, goal when the controller sends set-points."""
        self._client.listen(0.02)
        return self._client.arm_state()

    @property
    def q(self):
        """The virtual arm's joint positions (rad or m)."""
        return self.state()["q"]

    def status(self):
        """sirupp-control's status (mode, state, move_id, plan_name, plan_step, last_error...),
        the sim's (time, real-time factor) and the processes heard."""
        self._client.listen(0.02)
        return self._client.status()

    def gains(self, real=False):
        """The servo gains in the chip's units: dict of arrays (kp, kd, ki, integration_limit,
        output_limit, ...). real=True: the real boards' (None without a bridge)."""
        self._client.listen(0.02)
        return self._client.gains(real)

    def set_gains(self, **gains):
        """set_gains(kp=[...], kd=[...]): changes the named gains (one value per joint, chip
        units); the others stay. Waits, as `sirupp gains` does, until the rig shows the new
        gains. RigError when the controller (or a bridge) refuses, with its reason, or when the
        new gains do not show within 2.5 s."""
        return self._check(self._client.set_gains(gains), "set_gains")

    # --- moving
    def move_joints(self, q, wait=True, timeout=60.0, qd_max=None, qdd_max=None):
        """Every joint to q (rad or m) with the PIC-SERVO trapezoid (the joints' default speed and
        acceleration unless qd_max / qdd_max are given); waits for the end unless wait=False.
        Returns the move id."""
        q = np.asarray(q, dtype=float)
        if q.ndim != 1 or q.shape[0] != self.model.n:
            raise ValueError("q: shape %s; expected %d values (%s has %d joints)" % (
                q.shape, self.model.n, self.model.name, self.model.n))
        answer = self._check(self._client.move_joints(q, qd_max, qdd_max), "move_joints")
        if wait:
            self._wait_move(answer, timeout)
        return answer["move_id"]

    def move_pose(self, T, config=None, wait=True, timeout=60.0, position_only=False,
                  speed_scale=1.0):
        """The tool to pose T (4x4, world frame), the controller solving the IK; config like
        'left-up-noflip' ('*' leaves a part free; None: the solution nearest the present joints)."""
        position, quaternion = _pose_parts(T)
        shoulder, elbow, wrist = _config_flags(config)
        answer = self._check(self._client.move_pose(position, quaternion, position_only, shoulder,
                                                    elbow, wrist, speed_scale), "move_pose")
        if wait:
            self._wait_move(answer, timeout)
        return answer["move_id"]

    def run_plan(self, plan, wait=True, timeout=600.0):
        """Runs a movement plan: a file (config/plans/set7.plan) or the plan's text. Waits for its
        end unless wait=False. RigError naming NAME:LINE when the controller refuses it."""
        if "\n" not in plan and os.path.isfile(plan):
            name = plan
            with open(plan, encoding="utf-8", errors="replace") as f:
                text = f.read()
        elif "\n" not in plan and plan.endswith(".plan"):
            raise RigError("%s: no such plan file" % plan)
        else:
            name, text = "python.plan", plan
        answer = self._check(self._client.run_plan(name, text), "run_plan")
        if wait:
            steps = (self._client.status() or {}).get("plan_steps", 0)
            end, detail = self._client.wait_plan(name, steps, timeout, answer["status_seq"])
            if end != "done":
                raise RigError("run_plan %s: %s" % (name, detail))
        return name

    def run_path(self, path, speed_fraction=1.0, accel_fraction=1.0, wait=True, timeout=600.0):
        """Runs a k x n joint path (e.g. Scene.plan's) as a movement plan: first a move to the
        path's start, then each segment as one synchronized trapezoid, so the set-points stay on
        the straight segments Scene.edge_free checked. speed_fraction (0, 1] of the joints'
        default speeds. Returns the plan's text (what ran)."""
        text = _path_to_plan_text(self.model, path, speed_fraction, accel_fraction, True,
                                  ["run_path: %d waypoints" % len(path)])
        self.run_plan(text, wait=wait, timeout=timeout)
        return text

    def stop(self):
        """The stop button: the arm decelerates smoothly to rest and a running plan ends."""
        return self._client.plan_command("abort")

    def clear_fault(self):
        """After a trip or a failing controller: servos on where the arm is."""
        return self._check(self._client.plan_command("clear-fault"), "clear_fault")

    def estop(self, release=False, reason="python"):
        """The emergency stop (every process obeys it): motors stop and go off. release=True
        releases it."""
        self._client.estop(not release, reason)

    def record(self):
        """with rig.record() as r: ...  then r.t, r.q, r.q_setpoint, r.qd, r.effort, r.q_real
        (numpy arrays, one row per servo tick of the virtual arm)."""
        return _RecordContext(self)

    def wait(self, seconds):
        """Lets the rig run for `seconds` (Ctrl-C interrupts)."""
        self._client.listen(seconds)

    def panel_url(self):
        """The lab panel of a private rig started with panel=True (None otherwise)."""
        return getattr(self, "_panel_url", None)

    # --- life
    def close(self):
        """Stops the rig's own processes (a private rig); leaves a connected rig running."""
        if self._closed:
            return
        self._closed = True
        # The logger last, once nothing sends any more, with time to write what it has: a lockstep
        # sim runs ahead of it (100 times real time and more), and its rows must not be lost.
        for child in reversed(self._processes):
            if child is not self._logger:
                child.stop(1.0)
        if self._logger is not None:
            self._logger.stop(_LOGGER_GRACE_S)
        self._processes = []
        self._logger = None
        if self._lease is not None:
            self._lease.release()
            self._lease = None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()
        return False

    def __repr__(self):
        where = self.lcm_url or "LCM's default URL"
        return "<sirupp.Rig %s%s%s>" % (where, " prefix " + self.prefix if self.prefix else "",
                                        " (closed)" if self._closed else "")

    # --- inside
    def _check(self, answer, what):
        if not answer["accepted"]:
            raise RigError("%s: %s: %s" % (what, answer["result"], answer["error"]))
        return answer

    def _wait_move(self, answer, timeout):
        end, detail = self._client.wait_move(answer["move_id"], timeout, answer["status_seq"])
        if end != "done":
            raise RigError("move %d: %s" % (answer["move_id"], detail))

    def _process_logs(self):
        text = ""
        for child in self._processes:
            if not child.running():
                text += "; %s" % child.log_tail(3)
        return text


def _why_missing(channels):
    """What to check when the rig did not send these channels (full names)."""
    if any(c.endswith("CONTROLLER_STATUS") for c in channels):
        return ("is sirupp-control running on this bus? (sirupp.start_rig() starts a private "
                "rig)")
    if any(c.endswith("SIM_ARM_STATE") for c in channels):
        return "is sirupp-sim running on this bus?"
    return "sirupp-control sends its gains once a second: is it stuck?"


def connect(lcm_url=None, prefix="", model=None, timeout=5.0):
    """A running rig (sirupp launch, a lab PC, a class server's rig): its bus URL (None: the
    LCM_DEFAULT_URL environment variable, else LCM's default) and channel prefix."""
    return Rig(lcm_url, prefix, model, timeout)


_live_rigs = weakref.WeakSet()


@atexit.register
def _close_all():
    for rig in list(_live_rigs):
        rig.close()


def start_rig(model=None, mode="realtime", environment=None, panel=False, logger=False,
              friction=True, controller=None, controller_args=None, log_dir=None, timeout=15.0,
              sim_timeout=5.0):
    """A private rig for a notebook or a script: sirupp-sim (mode 'realtime' or 'lockstep') and
    sirupp-control on a udpm port of its own (ttl=0, leased like `sirupp grade` does), and with
    panel=True the browser panel, with logger=True sirupp-logger writing the paper's data files
    into rig.data_dir (LOG_DIR/data; `sirupp report` makes Table II of them). The processes end when the Rig is closed (use `with`), when
    Python exits, and if Python is killed (parent-death signal). Logs go to log_dir (default: a
    new temporary folder, rig.log_dir)."""
    if mode not in ("realtime", "lockstep"):
        raise ValueError("mode: %r; expected 'realtime' or 'lockstep'" % (mode,))
    model_file = model or DEFAULT_MODEL
    m = Model(model_file)  # a bad model fails here, with its file:line, before anything starts
    if controller and not os.path.isfile(controller):
        raise ValueError("controller: %s: no such file" % controller)
    control_args = ["--sim-timeout", "%g" % sim_timeout]
    if controller and controller_args:
        control_args += ["--controller-args", controller_args]
    sim_args = (["--environment", environment] if environment else []) + \
        ([] if friction else ["--no-friction"])
    log_dir = log_dir or tempfile.mkdtemp(prefix="sirupp-rig-")
    os.makedirs(log_dir, exist_ok=True)
    lease = _PortLease.acquire(_PORT_BASE, _PORT_COUNT, os.getpid())
    url = _rig_url(lease.port)
    try:
        # The rig as proc::RigProcesses describes it: sirupp-sim, sirupp-control, sirupp-logger.
        commands = [(argv, log) for _, argv, log in _rig_processes(
            port=lease.port, bin_dir=_paths.BIN_DIR, model=model_file, mode=mode,
            participants=["sirupp-control"], sim_args=sim_args,
            controller=os.path.abspath(controller) if controller else "",
            control_args=control_args,
            results_dir=os.path.join(log_dir, "data") if logger else "", log_dir=log_dir)]
    except BaseException:
        lease.release()
        raise
    panel_port = None
    if panel:
        with socket.socket() as s:  # a free TCP port for the panel's web server
            s.bind(("127.0.0.1", 0))
            panel_port = s.getsockname()[1]
        commands.append(([os.path.join(_paths.BIN_DIR, "sirupp-panel"), "--lcm-url", url,
                          "--port", str(panel_port)], os.path.join(log_dir, "sirupp-panel.log")))
    children = []
    try:
        for argv, log in commands:
            child = _Child()
            child.start(argv, log)
            children.append(child)
            time.sleep(0.05)
            if not child.running():
                raise RigError("%s %s: %s" % (os.path.basename(argv[0]), child.how_ended(),
                                              child.log_tail(3)))
    except BaseException:
        for child in reversed(children):
            child.stop(1.0)
        lease.release()
        raise
    loggers = [child for child, (argv, _) in zip(children, commands)
               if os.path.basename(argv[0]) == "sirupp-logger"]
    rig = Rig(url, "", m, timeout, _processes=children, _lease=lease,
              _logger=loggers[0] if loggers else None)
    # Ready when sirupp-control (on the bus: its status was heard) has a state of the sim: a state
    # newer than the first one seen now (in lockstep the sim steps only once the controller
    # answered). A controller file may take seconds to import before sirupp-control joins.
    deadline = time.monotonic() + timeout
    first = None
    while True:
        state = rig._client.arm_state()
        if state is not None and first is None:
            first = state["tick"]
        if state is not None and state["tick"] > first:
            break
        if time.monotonic() > deadline:
            rig.close()
            raise RigError("the private rig sent no SIM_ARM_STATE within %g s%s" % (
                timeout, rig._process_logs() or " (logs in %s)" % log_dir))
        rig._client.listen(0.05)
    rig._client.listen(0.1)
    rig.log_dir = log_dir
    rig.data_dir = os.path.join(log_dir, "data") if logger else None
    rig.mode = mode
    if panel_port:
        rig._panel_url = "http://127.0.0.1:%d/" % panel_port
    _live_rigs.add(rig)
    return rig

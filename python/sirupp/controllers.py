"""Controllers written in Python (docs/python.md, "Your own controller").

A controller is a file (or module, class or function) with

    def update(state):            # every servo tick (0.512 ms on the PUMA 260)
        return efforts            # one per joint, N*m (N for prismatic joints)

and optionally `def reset(arm, state)`, called once before the first update; or a class
`Controller` with `__init__(self, args)` (the --controller-args text, "" if none), `reset(self,
arm, state)` and `update(self, state)`, like include/sirupp/controller.h. It runs two ways:

- in place of the PID inside sirupp-control: `sirupp-control --controller my_controller.py`
  (hosted in a process of its own, sirupp-python-controller-host; a fault brakes the arm);
- as a process controller answering sirupp-sim in lockstep, like examples 04 and 05:
  `sirupp.run_process_controller("my_controller.py")`.
"""
import importlib.util
import inspect
import os
import sys
import traceback

import numpy as np


class ArmInfo:
    """The arm, fixed for the run: n, name, dt (the servo tick, s), effort_max, qlim (2 x n)."""

    __slots__ = ("n", "name", "dt", "effort_max", "qlim")

    def __init__(self, n, name, dt, effort_max, qlim):
        self.n, self.name, self.dt = n, name, dt
        self.effort_max, self.qlim = effort_max, qlim

    def __repr__(self):
        return "<ArmInfo %s, %d joints, dt %g s>" % (self.name, self.n, self.dt)


class State:
    """One servo tick, numpy arrays of n values (rad, rad/s, N*m; m, m/s, N for prismatic):

    t, tick; q, qd (measured), effort (applied last tick); q_setpoint, qd_setpoint, qdd_setpoint
    and goal (the PIC-SERVO trapezoid's, or the reference file's in a process controller);
    gravity = G(q), bias = C(q, qd) qd + G(q), M = M(q) (n x n) at the measured state."""

    __slots__ = ("t", "tick", "q", "qd", "effort", "q_setpoint", "qd_setpoint", "qdd_setpoint",
                 "goal", "gravity", "bias", "M")

    def __init__(self, t, tick, q, qd, effort, q_setpoint, qd_setpoint, qdd_setpoint, goal,
                 gravity, bias, M):
        self.t, self.tick, self.q, self.qd, self.effort = t, tick, q, qd, effort
        self.q_setpoint, self.qd_setpoint, self.qdd_setpoint = q_setpoint, qd_setpoint, qdd_setpoint
        self.goal, self.gravity, self.bias, self.M = goal, gravity, bias, M

    def __repr__(self):
        return "<State tick %d, t %.4f s, q %s>" % (self.tick, self.t, np.array2string(self.q, precision=4))


def load_file(path):
    """Imports a controller file as a module of its own (its folder on sys.path, so it may import
    its neighbours)."""
    path = os.path.abspath(path)
    if not os.path.isfile(path):
        raise FileNotFoundError("%s: no such controller file" % path)
    name = "sirupp_controller_" + os.path.splitext(os.path.basename(path))[0].replace("-", "_")
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    folder = os.path.dirname(path)
    if folder not in sys.path:
        sys.path.insert(0, folder)
    spec.loader.exec_module(module)
    return module


def _takes_argument(function):
    try:
        parameters = inspect.signature(function).parameters.values()
    except (TypeError, ValueError):
        return True
    return any(p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD, p.VAR_POSITIONAL)
               for p in parameters)


def make_controller(controller, args=""):
    """(reset, update) from a file path, module, class, object or function (see the module's
    doc). TypeError naming what is missing."""
    where = controller
    if isinstance(controller, str):
        controller = load_file(controller)
    if inspect.ismodule(controller):
        if hasattr(controller, "Controller"):
            controller = controller.Controller
        elif not callable(getattr(controller, "update", None)):
            raise TypeError("%s: defines neither update(state) nor a class Controller" % where)
    if inspect.isclass(controller):
        init = controller.__init__
        has_args = init is not object.__init__ and len(inspect.signature(init).parameters) > 1
        controller = controller(args) if has_args else controller()
    elif args:
        raise TypeError("controller arguments %r given, but %s has no class Controller to take "
                        "them" % (args, where))
    if inspect.isfunction(controller) or inspect.isbuiltin(controller):
        update, reset = controller, None
    else:
        update = getattr(controller, "update", None)
        reset = getattr(controller, "reset", None)
    if not callable(update):
        raise TypeError("%s: no update(state) to call" % where)
    if reset is not None and not callable(reset):
        reset = None
    return reset, update


def fault_text(error):
    """The last line of a traceback, with where it was raised in the controller's own code:
    'ZeroDivisionError: division by zero (my_controller.py:12 in update)'."""
    last = traceback.format_exception_only(type(error), error)[-1].strip()
    if isinstance(error, SyntaxError) and error.filename:
        return "%s (%s:%s)" % (last, os.path.basename(error.filename), error.lineno)
    here = os.path.dirname(os.path.abspath(__file__))
    frames = [f for f in traceback.extract_tb(error.__traceback__)
              if not f.filename.startswith("<frozen") and
              os.path.dirname(os.path.abspath(f.filename)) != here]
    if frames:
        f = frames[-1]
        last += " (%s:%d in %s)" % (os.path.basename(f.filename), f.lineno, f.name)
    return last


class ControllerFault(Exception):
    """A controller raised, returned a bad effort, or took too long; str() is the reason."""


def effort_array(value, n):
    e = np.asarray(value, dtype=float).reshape(-1)
    if e.shape[0] != n:
        raise ControllerFault("update returned %d efforts; expected %d (one per joint)" % (e.shape[0], n))
    bad = np.flatnonzero(~np.isfinite(e))
    if bad.size:
        raise ControllerFault("update returned %r for joint %d (efforts must be finite)" % (
            float(e[bad[0]]), bad[0] + 1))
    return e


class Runner:
    """Calls a controller tick by tick for a host (sirupp-python-controller-host or
    run_process_controller): builds State, turns every exception into ControllerFault with the
    traceback's last line, checks the efforts."""

    def __init__(self, controller, args, arm):
        self.arm = arm
        self.reset_fn, self.update_fn = make_controller(controller, args)
        self._reset_done = False

    def call(self, op_reset, state):
        try:
            if op_reset:
                self._reset_done = True
                if self.reset_fn is not None:
                    self.reset_fn(self.arm, state)
                return None
            return effort_array(self.update_fn(state), self.arm.n)
        except ControllerFault:
            raise
        except BaseException as error:  # noqa: B902 (SystemExit, KeyboardInterrupt too)
            raise ControllerFault(fault_text(error)) from None


def run_process_controller(controller, args="", lcm_url=None, prefix="", name="python",
                           reference=None, stale_s=1.0):
    """Runs `controller` as a process controller: answers every SIM_ARM_STATE with an effort
    command for the same tick, as participant `name`, so sirupp-sim can run in lockstep with it
    (`sirupp-sim --participants python`). The arm is learnt from ROBOT_MODEL. reference: a
    reference file (`sirupp grade`'s {reference_csv}) whose row per tick gives q_setpoint and
    qd_setpoint; without it the set-points hold the first measured position. Returns when the
    states stop (the sim ended) for stale_s: {"ticks": N, "q": final positions}. A fault raises
    ControllerFault after answering HOLD (the sim brakes the arm)."""
    from ._sirupp import _run_process_controller
    from .data import read_reference

    ref = read_reference(reference) if isinstance(reference, str) else reference
    holder = {}

    def make(model):
        n = model["n"]
        arm = ArmInfo(n, model["name"], model["servo_tick_s"], model["effort_max"], model["qlim"])
        runner = Runner(controller, args, arm)
        zeros = np.zeros(n)

        def step(tick, t, q, qd, effort, gravity, bias, mass):
            if ref is not None:
                k = min(max(int(tick), 0), len(ref["q"]) - 1)
                qs, qds, qdds = ref["q"][k], ref["qd"][k], ref["qdd"][k]
                goal = ref["q"][-1]
            else:
                if "hold" not in holder:
                    holder["hold"] = q.copy()
                qs, qds, qdds, goal = holder["hold"], zeros, zeros, holder["hold"]
            state = State(t, tick, q, qd, effort, qs, qds, qdds, goal, gravity, bias, mass)
            if not runner._reset_done:
                runner.call(True, state)
            return runner.call(False, state)

        return step

    url = lcm_url if lcm_url is not None else os.environ.get("LCM_DEFAULT_URL", "")
    return _run_process_controller(make, name, url, prefix, stale_s)

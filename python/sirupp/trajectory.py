"""Joint-space trajectories: jtraj (quintic, like the Robotics Toolbox's) and the PIC-SERVO's
trapezoid (constant acceleration, slew, constant deceleration), as numpy arrays."""
import numpy as np


class Trajectory:
    """t (s), q, qd, qdd: arrays of len(t) rows and one column per joint."""

    def __init__(self, t, q, qd, qdd):
        self.t, self.q, self.qd, self.qdd = t, q, qd, qdd

    def __len__(self):
        return len(self.t)

    def __repr__(self):
        return "<Trajectory %d points x %d joints over %.3g s>" % (
            len(self.t), self.q.shape[1], self.t[-1] if len(self.t) else 0.0)


def _joints(value, name, n=None):
    a = np.asarray(value, dtype=float)
    if a.ndim != 1 or (n is not None and a.shape[0] != n):
        raise ValueError("%s: shape %s; expected %s values" % (
            name, a.shape, n if n is not None else "a 1-D array of"))
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        raise ValueError("%s[%d]: %r is not a finite number" % (name, bad[0], a[bad[0]]))
    return a


def jtraj(q0, q1, t, qd0=None, qd1=None):
    """Quintic joint trajectory from q0 to q1 (zero or given end velocities).

    t: a number of points (int >= 2; the time unit is then one step, as in the Robotics
    Toolbox) or an increasing array of times (s).
    Returns a Trajectory with .t, .q, .qd, .qdd (rows: points)."""
    q0 = _joints(q0, "q0")
    q1 = _joints(q1, "q1", q0.shape[0])
    if isinstance(t, (int, np.integer)):
        if t < 2:
            raise ValueError("t: %d points; expected at least 2" % t)
        tv = np.arange(t, dtype=float)
    else:
        tv = np.asarray(t, dtype=float)
        if tv.ndim != 1 or tv.shape[0] < 2 or not np.all(np.isfinite(tv)) or np.any(np.diff(tv) <= 0):
            raise ValueError("t: expected an increasing 1-D array of at least 2 finite times")
    duration = tv[-1] - tv[0]
    s = ((tv - tv[0]) / duration)[:, None]
    v0 = np.zeros_like(q0) if qd0 is None else _joints(qd0, "qd0", q0.shape[0]) * duration
    v1 = np.zeros_like(q0) if qd1 is None else _joints(qd1, "qd1", q0.shape[0]) * duration
    # q(s) = A s^5 + B s^4 + C s^3 + E s + F with q(0)=q0, q(1)=q1, q'(0)=v0, q'(1)=v1, q''=0 at ends.
    a = 6 * (q1 - q0) - 3 * (v1 + v0)
    b = -15 * (q1 - q0) + 8 * v0 + 7 * v1
    c = 10 * (q1 - q0) - 6 * v0 - 4 * v1
    e, f = v0, q0
    q = a * s**5 + b * s**4 + c * s**3 + e * s + f
    qd = (5 * a * s**4 + 4 * b * s**3 + 3 * c * s**2 + e) / duration
    qdd = (20 * a * s**3 + 12 * b * s**2 + 6 * c * s) / duration**2
    return Trajectory(tv, q, qd, qdd)


def trapezoid(q0, q1, v_max, a_max, dt=0.000512):
    """The PIC-SERVO's trapezoidal profile from q0 to q1 for every joint, each with its own speed
    limit v_max and acceleration a_max (> 0), all joints starting together at time 0; sampled
    every dt (the servo tick). Returns a Trajectory."""
    q0 = _joints(q0, "q0")
    n = q0.shape[0]
    q1 = _joints(q1, "q1", n)
    v = np.broadcast_to(np.asarray(v_max, dtype=float), (n,))
    acc = np.broadcast_to(np.asarray(a_max, dtype=float), (n,))
    if np.any(~(v > 0)) or np.any(~(acc > 0)) or not dt > 0:
        raise ValueError("v_max, a_max and dt must be > 0")
    dist = np.abs(q1 - q0)
    sign = np.sign(q1 - q0)
    # Triangle when the distance is too short to reach v_max.
    vpeak = np.minimum(v, np.sqrt(dist * acc))
    ta = vpeak / acc
    tc = np.where(vpeak > 0, (dist - vpeak * ta) / np.where(vpeak > 0, vpeak, 1), 0)
    total = 2 * ta + tc
    t = np.arange(0, total.max() + dt, dt)
    tt = t[:, None]
    pos = np.where(tt < ta, 0.5 * acc * tt**2,
                   np.where(tt < ta + tc, 0.5 * acc * ta**2 + vpeak * (tt - ta),
                            dist - 0.5 * acc * np.clip(total - tt, 0, None)**2))
    vel = np.where(tt < ta, acc * tt, np.where(tt < ta + tc, vpeak, acc * np.clip(total - tt, 0, None)))
    accel = np.where(tt < ta, acc, np.where(tt < ta + tc, 0.0, np.where(tt < total, -acc, 0.0)))
    pos = np.where(tt >= total, dist, pos)
    return Trajectory(t, q0 + sign * pos, sign * vel, sign * accel)

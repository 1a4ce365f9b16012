"""Example 7: a controller written in Python, in place of the PIC-SERVO PID inside sirupp-control.

    a      = qdd_set + Kd (qd_set - qd) + Kp (q_set - q) + Ki * integral(q_set - q)
    effort = M(q) a + C(q, qd) qd + G(q)

Computed torque (example 3) with an integral term for the joint friction the model leaves out:
the arm's dynamics cancel, and every joint's error obeys the same third-order law, whose three
poles sit at -wn (Kd = 3 wn, Kp = 3 wn^2, Ki = wn^3). The host hands over M (state.M) and
C qd + G (state.bias) at the measured state each tick.

Run it (sirupp-sim and sirupp-control on one bus):
    build/bin/sirupp-sim &
    build/bin/sirupp-control --controller examples/07_python_controller/computed_torque_pid.py &
    build/bin/sirupp plan run config/plans/set7.plan --wait
Grade it:
    build/bin/sirupp grade examples/07_python_controller/computed_torque_pid.py \
        --suite examples/07_python_controller/set7.yaml
Arguments (--controller-args): "wn=60" (rad/s, the default).
"""
import numpy as np


class Controller:
    def __init__(self, args=""):
        self.wn = 60.0
        for word in args.split():
            key, _, value = word.partition("=")
            if key != "wn" or not value:
                raise ValueError("argument %r: expected wn=NUMBER" % word)
            self.wn = float(value)
        if not self.wn > 0:
            raise ValueError("wn must be > 0")

    def reset(self, arm, state):
        self.dt = arm.dt
        self.effort_max = arm.effort_max
        self.integral = np.zeros(arm.n)

    def update(self, state):
        wn = self.wn
        error = state.q_setpoint - state.q
        self.integral += error * self.dt
        a = (state.qdd_setpoint + 3 * wn * (state.qd_setpoint - state.qd) + 3 * wn**2 * error
             + wn**3 * self.integral)
        effort = state.M @ a + state.bias
        return np.clip(effort, -self.effort_max, self.effort_max)

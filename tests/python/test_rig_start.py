"""A rig is all there when sirupp.start_rig() returns (issue 41, defect 6: notebook 05's
`gains = rig.gains()` right after the start once met None). Fifty private rigs, each asked for its
gains, state and status at once; and connect() to a bus without a rig raising with the reason."""
import os

import pytest

import sirupp

STARTS = 50


def problems_right_after_a_start():
    with sirupp.start_rig(mode="lockstep") as rig:
        gains, state, status = rig.gains(), rig.state(), rig.status()
    problems = []
    if gains is None:
        problems.append("gains() None")
    elif gains["kp"].shape != (rig.model.n,):
        problems.append("gains()['kp'] shape %s" % (gains["kp"].shape,))
    if state is None:
        problems.append("state() None")
    if status is None:
        problems.append("status() None")
    return problems


def test_gains_state_and_status_right_after_each_of_50_starts():
    failed = {}
    for start in range(STARTS):
        problems = problems_right_after_a_start()
        if problems:
            failed[start] = problems
    assert not failed, "%d of %d starts: %s" % (len(failed), STARTS, failed)


def test_connect_names_what_the_bus_did_not_send():
    lease = sirupp._sirupp._PortLease.acquire(20000, 10000, os.getpid())
    try:
        with pytest.raises(sirupp.RigError,
                           match="no CONTROLLER_STATUS, CONTROLLER_GAINS, SIM_ARM_STATE on "
                                 "udpm://.* within 0.3 s: is sirupp-control running"):
            sirupp.connect("udpm://239.255.76.67:%d?ttl=0" % lease.port, timeout=0.3)
    finally:
        lease.release()

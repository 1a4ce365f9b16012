"""SIRUPP-LCM for Python: the robot model, kinematics and dynamics, a rig to drive, controllers.

    import sirupp
    m = sirupp.Model("config/robots/puma260.yaml")
    T = m.fkine([0, -0.5, 1, 0, 0.5, 0])          # 4x4 numpy array, metres
    for s in m.ikine(T): print(s["config"], s["q"])  # every closed-form solution
    with sirupp.start_rig() as rig:                # a private sim + controller, stopped at the end
        rig.move_joints(m.pose("ready"))
        rig.run_plan("config/plans/set7.plan")

Units are SI (rad, m, s, N*m); joint vectors are 1-D numpy arrays. Guide: docs/python.md.
"""
from ._sirupp import IKError, Model, ModelError, RigError  # noqa: F401
from .trajectory import Trajectory, jtraj, trapezoid  # noqa: F401
from .rig import Rig, connect, start_rig  # noqa: F401
from .data import read_data, read_reference, read_report  # noqa: F401
from .controllers import ArmInfo, State, run_process_controller  # noqa: F401

__all__ = [
    "Model", "ModelError", "IKError", "RigError", "jtraj", "trapezoid", "Trajectory", "connect",
    "start_rig", "Rig", "read_data", "read_reference", "read_report", "State", "ArmInfo",
    "run_process_controller", "data_path",
]


def data_path(relative):
    """A file of this project (e.g. 'config/robots/puma260.yaml'), wherever Python runs from."""
    import os
    from . import _paths
    if os.path.exists(relative):
        return relative
    return os.path.join(_paths.SOURCE_DIR, relative)

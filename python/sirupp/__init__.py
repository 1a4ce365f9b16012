"""SIRUPP-LCM for Python: the robot model, kinematics and dynamics, a rig to drive, controllers.

    import sirupp
    m = sirupp.Model("config/robots/puma260.yaml")
    T = m.fkine([0, -0.5, 1, 0, 0.5, 0])          # 4x4 numpy array, metres
    for s in m.ikine(T): print(s["config"], s["q"])  # every closed-form solution
    with sirupp.start_rig() as rig:                # a private sim + controller, stopped at the end
        rig.move_joints(m.pose("ready"))
        rig.run_plan("config/plans/set7.plan")
    scene = sirupp.Scene(m, "config/environments/table.xml")  # collision checks, planning
    path = scene.plan(m.pose("ready"), q_goal)     # k x n array; rig.run_path(path) runs it

Units are SI (rad, m, s, N*m); joint vectors are 1-D numpy arrays. Guide: docs/python.md.
"""
import importlib

from ._paths import VERSION as __version__  # written by CMake from the project's version

__license__ = "Apache-2.0"

# Names load their module on first use (PEP 562), so that `import sirupp.controllers` (what the
# controller host does, on every start) costs numpy alone.
_WHERE = {
    "Model": "._sirupp", "ModelError": "._sirupp", "IKError": "._sirupp", "RigError": "._sirupp",
    "jtraj": ".trajectory", "trapezoid": ".trajectory", "Trajectory": ".trajectory",
    "connect": ".rig", "start_rig": ".rig", "Rig": ".rig",
    "read_data": ".data", "read_reference": ".data", "read_report": ".data",
    "State": ".controllers", "ArmInfo": ".controllers",
    "run_process_controller": ".controllers", "ControllerFault": ".controllers",
    "Scene": ".planning", "PlanError": ".planning", "path_length": ".planning",
}


_SUBMODULES = ("_sirupp", "_paths", "trajectory", "rig", "data", "controllers", "plot", "notebook",
               "planning")


def __getattr__(name):
    if name in _WHERE:
        value = getattr(importlib.import_module(_WHERE[name], __name__), name)
        globals()[name] = value
        return value
    if name in _SUBMODULES:
        return importlib.import_module("." + name, __name__)
    raise AttributeError("module 'sirupp' has no attribute %r" % name)


def __dir__():
    return sorted(set(globals()) | set(_WHERE))


__all__ = [
    "Model", "ModelError", "IKError", "RigError", "jtraj", "trapezoid", "Trajectory", "connect",
    "start_rig", "Rig", "read_data", "read_reference", "read_report", "State", "ArmInfo",
    "run_process_controller", "ControllerFault", "Scene", "PlanError", "path_length", "data_path",
]


def data_path(relative):
    """A file of this project (e.g. 'config/robots/puma260.yaml'), wherever Python runs from."""
    import os
    from . import _paths
    if os.path.exists(relative):
        return relative
    return os.path.join(_paths.SOURCE_DIR, relative)

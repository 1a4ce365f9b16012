"""Motion planning for students: the arm in its world (planning/ in C++, docs/planning.md).

    scene = sirupp.Scene("config/robots/puma260.yaml", "config/environments/table.xml")
    scene.is_free(q)                      # True / False
    scene.contacts(q)                     # [{'kind': 'static object', 'link_name': ..., 'depth_m': ...}]
    scene.edge_free(q0, q1, step=0.01)    # the straight segment, every 0.01 rad
    path = scene.plan(q0, q1)             # k x n numpy array, q0 first, q1 last (OMPL's RRTConnect)
    scene.last_plan["tree_vertices"]      # with tree=True: the planner's tree, for drawing
    qa, qb, cells = scene.cspace(1, 2, q) # a C-space slice for plt.pcolormesh(qa, qb, cells)
    rig.run_path(path)                    # the path as a movement plan, run on a rig

Joint vectors are in rad (m for prismatic joints). Bad input raises ValueError naming the argument,
the value and what is allowed.
"""
import numpy as np

from ._sirupp import Scene as _Scene

#: cspace() cell values
FREE, STATIC_OBJECT, FREE_OBJECT, SELF = 0, 1, 2, 3


class PlanError(RuntimeError):
    """The planner found no path within its budget: the message says what was tried."""


class Scene(_Scene):
    __doc__ = _Scene.__doc__

    last_plan = None

    def plan(self, start, goal, planner="RRTConnect", seed=1, time=1.0, iterations=0,
             simplify=True, step=0.01, free_objects=True, tree=False):
        """A collision-free joint path from start to goal (OMPL): a k x n numpy array, start first
        and goal last, every straight segment checked every `step` rad.

        planner: RRTConnect (default), RRT, PRM, RRT*, BIT*, KPIECE, SBL; seed: the same request gives
        the same path (with iterations=N, or a planner stopping at its first solution); time: the
        budget in s; simplify: OMPL's shortcutting; free_objects=False lets the path push table.xml's
        blocks; tree=True keeps the planner's tree in scene.last_plan (tree_vertices, m x n;
        tree_edges, e x 2 indices). scene.last_plan also holds message, solve_s, simplify_s,
        states_checked, length_rad. ValueError for a bad argument or a start or goal that touches
        something (naming the link and the object); PlanError when no path was found."""
        result = _Scene.plan(self, start, goal, planner=planner, seed=seed, time=time,
                             iterations=iterations, simplify=simplify, step=step,
                             free_objects=free_objects, tree=tree)
        self.last_plan = result
        if not result["solved"]:
            raise PlanError(result["message"])
        return result["path"]

    def path_free(self, path, step=0.01, free_objects=True):
        """True when every segment of a k x n path is free at `step` rad."""
        path = np.asarray(path, dtype=float)
        if path.ndim != 2 or path.shape[0] < 1:
            raise ValueError("path: shape %s; expected k x %d joint vectors" % (path.shape, self.n))
        if path.shape[0] == 1:
            return self.is_free(path[0], free_objects)
        return all(self.edge_free(a, b, step, free_objects) for a, b in zip(path[:-1], path[1:]))


def path_length(path):
    """Joint-space length of a k x n path (sum of the segments' Euclidean lengths, rad)."""
    path = np.asarray(path, dtype=float)
    if path.ndim != 2:
        raise ValueError("path: shape %s; expected k x n joint vectors" % (path.shape,))
    return float(np.sum(np.linalg.norm(np.diff(path, axis=0), axis=1)))

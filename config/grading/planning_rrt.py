"""A good solution of the planning assignment (config/grading/planning.yaml): RRT-Connect
(Kuffner and LaValle, 2000) in joint space with shortcutting, over sirupp.Scene's checks.

    sirupp grade config/grading/planning_rrt.py --suite config/grading/planning.yaml

plan(start, goal, scene) -> a k x n array from start to goal. The scene is padded (1 cm), so a
path free here keeps that margin when the grader checks it unpadded at a finer resolution.
"""
import numpy as np

STEP = 0.3    # rad: the longest tree edge
CHECK = 0.01  # rad: edge resolution of every check


class Tree:
    def __init__(self, root, capacity):
        self.nodes = np.empty((capacity, len(root)))
        self.nodes[0] = root
        self.parent = np.full(capacity, -1)
        self.size = 1

    def nearest(self, q):
        return int(np.argmin(np.sum((self.nodes[:self.size] - q) ** 2, axis=1)))

    def add(self, q, parent):
        self.nodes[self.size] = q
        self.parent[self.size] = parent
        self.size += 1
        return self.size - 1

    def branch(self, k):  # root .. node k
        out = []
        while k >= 0:
            out.append(self.nodes[k])
            k = self.parent[k]
        return out[::-1]


def extend(scene, tree, target):
    """One step from the node nearest `target` towards it; the new node's index or None."""
    near = tree.nearest(target)
    delta = target - tree.nodes[near]
    distance = np.linalg.norm(delta)
    new = target if distance <= STEP else tree.nodes[near] + delta * (STEP / distance)
    if not scene.edge_free(tree.nodes[near], new, CHECK):
        return None
    return tree.add(new, near)


def connect(scene, tree, target):
    """Steps towards `target` until it is reached (the node's index) or blocked (None)."""
    while True:
        k = extend(scene, tree, target)
        if k is None:
            return None
        if np.allclose(tree.nodes[k], target):
            return k


def shortcut(scene, path):
    out, i = [path[0]], 0
    while i < len(path) - 1:
        j = len(path) - 1
        while j > i + 1 and not scene.edge_free(path[i], path[j], CHECK):
            j -= 1
        out.append(path[j])
        i = j
    return out


def plan(start, goal, scene, seed=1, max_nodes=20000):
    if scene.edge_free(start, goal, CHECK):
        return np.array([start, goal])
    rng = np.random.default_rng(seed)
    lo, hi = scene.qlim
    a, b = Tree(start, max_nodes + 2), Tree(goal, max_nodes + 2)
    for i in range(max_nodes):
        k = extend(scene, a, rng.uniform(lo, hi))
        if k is not None:
            m = connect(scene, b, a.nodes[k])
            if m is not None:
                path = a.branch(k) + b.branch(m)[::-1][1:]
                if i % 2:  # the trees were swapped: a grew from the goal
                    path = path[::-1]
                return np.array(shortcut(scene, path))
        a, b = b, a
    raise RuntimeError("no path within %d nodes" % max_nodes)

"""Runs a student's planning function for `sirupp grade` (grade/planning_assignment.hpp), inside
the sandbox, under Debian's python3 started with -I (no PYTHONPATH, no user site):

    python3 -I plan_host.py STUDENT.py MODEL ENVIRONMENT PADDING_M OUT START... GOAL...

STUDENT.py defines plan(start, goal, scene) -> path: start and goal are joint vectors (numpy, rad),
scene a sirupp.Scene of MODEL in ENVIRONMENT padded by PADDING_M, path a k x n array-like from
start to goal. OUT gets "# seconds S" (the function's own time) and one line of n numbers per
waypoint. A missing function, an exception or a path of the wrong shape: one line on stderr, exit 1.
"""
import importlib.util
import os
import sys
import time


def main(argv):
    if len(argv) < 7:
        print("usage: plan_host.py STUDENT.py MODEL ENVIRONMENT PADDING_M OUT START... GOAL...",
              file=sys.stderr)
        return 2
    student, model, environment, padding, out = argv[1:6]
    values = [float(v) for v in argv[6:]]
    # This build's module (build/python) is the folder above this file's.
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    import numpy as np
    import sirupp

    n = len(values) // 2
    start, goal = np.array(values[:n]), np.array(values[n:])
    scene = sirupp.Scene(model, environment, padding=float(padding))
    spec = importlib.util.spec_from_file_location("student_planner", student)
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except Exception as error:  # the student's file: its own error, one line
        print("%s: %s: %s" % (os.path.basename(student), type(error).__name__, error),
              file=sys.stderr)
        return 1
    function = getattr(module, "plan", None)
    if not callable(function):
        print("%s: no function plan(start, goal, scene)" % os.path.basename(student),
              file=sys.stderr)
        return 1
    began = time.perf_counter()
    try:
        path = function(start.copy(), goal.copy(), scene)
    except Exception as error:
        print("plan(): %s: %s" % (type(error).__name__, error), file=sys.stderr)
        return 1
    seconds = time.perf_counter() - began
    try:
        path = np.asarray(path, dtype=float)
    except (TypeError, ValueError) as error:
        print("plan() returned no array of numbers: %s" % error, file=sys.stderr)
        return 1
    if path.ndim != 2 or path.shape[1] != n or path.shape[0] < 1:
        print("plan() returned shape %s; expected k x %d joint vectors" % (path.shape, n),
              file=sys.stderr)
        return 1
    with open(out, "w") as f:
        f.write("# seconds %r\n" % seconds)
        for q in path:
            f.write(" ".join(repr(float(v)) for v in q) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

"""The fk3 assignment's notebook with the student's cell filled in, for the notebook grading
tests (test_grade_notebook.py, tests/class/class_notebook_test.py): a right answer, one with a bug
the visible tests miss, and hostile ones. Each is the shipped notebook with the cell tagged
"your-code" replaced, so the tests follow the notebook the course ships."""
import os

import nbformat

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.normpath(os.path.join(HERE, "..", ".."))
ASSIGNMENT = os.path.join(SOURCE, "notebooks", "assignments", "fk3_forward_kinematics.ipynb")
HIDDEN = os.path.join(SOURCE, "config", "grading", "notebooks", "fk3_hidden.py")

RIGHT = '''def fk(dh, q):
    T = np.eye(4)
    for (a, alpha, d, theta), qi in zip(dh, q):
        th = qi + theta
        ct, st, ca, sa = np.cos(th), np.sin(th), np.cos(alpha), np.sin(alpha)
        T = T @ np.array([[ct, -st * ca, st * sa, a * ct],
                          [st, ct * ca, -ct * sa, a * st],
                          [0.0, sa, ca, d],
                          [0.0, 0.0, 0.0, 1.0]])
    return T
'''

# The offset column ignored: the notebook's table has no offsets, so its visible tests pass.
NO_OFFSET = RIGHT.replace("th = qi + theta", "th = qi")

LOOP = RIGHT + "\nwhile True:\n    pass\n"

NETWORK = '''import socket
reached = []
for address in [("1.1.1.1", 80), ("127.0.0.1", 22)]:
    try:
        socket.create_connection(address, timeout=3).close()
        reached.append(address)
    except OSError as error:
        print("network", address, "refused:", type(error).__name__, error)
assert not reached, "reached %s" % reached
''' + RIGHT + '''
import urllib.request
urllib.request.urlopen("http://example.com", timeout=3)
'''



def mess(sentinel):
    """Megabytes of output, its own folder emptied, a file of the test's outside the sandbox
    (`sentinel`, a path only the test made) removed if it can be reached, then the right answer.
    Only ever graded in the sandbox: it deletes what it can reach."""
    return ('''import os
for i in range(200000):
    print("x" * 100)
for name in os.listdir("."):
    os.remove(name)
print("left in my folder:", os.listdir("."))
try:
    os.remove(%r)
    print("removed the sentinel")
except OSError as error:
    print("sentinel:", type(error).__name__)
''' % sentinel) + RIGHT


def write(answer, path):
    """The assignment's notebook with `answer` as its student cell, written to `path`."""
    nb = nbformat.read(ASSIGNMENT, as_version=4)
    cells = [c for c in nb.cells if "your-code" in c.metadata.get("tags", [])]
    assert len(cells) == 1, "the assignment has %d cells tagged your-code" % len(cells)
    cells[0].source = "# YOUR CODE: fk(dh, q) -> 4x4 numpy array (frame 3 in frame 0)\n" + answer
    nbformat.write(nb, path)
    return path

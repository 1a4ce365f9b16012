"""python3 -m sirupp.notebook [NOTEBOOK_DIR]: the classic Jupyter notebook with this build's
module on its path (PYTHONPATH), Debian's kernel, in notebooks/ by default."""
import os
import sys

from . import _paths


def main(argv=None):
    argv = sys.argv[1:] if argv is None else argv
    folder = argv[0] if argv else os.path.join(_paths.SOURCE_DIR, "notebooks")
    python_dir = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    env = dict(os.environ)
    env["PYTHONPATH"] = python_dir + (os.pathsep + env["PYTHONPATH"] if env.get("PYTHONPATH") else "")
    env["PATH"] = "/usr/bin" + os.pathsep + env.get("PATH", "")  # Debian's python3 and jupyter first
    command = ["/usr/bin/jupyter", "notebook", "--notebook-dir", folder] + argv[1:]
    print("sirupp: " + " ".join(command) + "  (PYTHONPATH=" + python_dir + ")", flush=True)
    os.execve(command[0], command, env)


if __name__ == "__main__":
    main()

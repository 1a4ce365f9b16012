"""The python3 kernel of a graded notebook (notebook_grade_host.py starts it), Debian's ipykernel
with one change: no IOPub pipe for forked subprocesses. ipykernel binds that pipe to
tcp://127.0.0.1, and in the grading sandbox, whose socket filter allows Unix sockets only, libzmq
aborts the kernel on the refused socket() (an assertion, not an error ipykernel could catch).
Output of a forked child of the notebook's code is then lost; everything else is the same kernel.

    python3 -s notebook_grade_kernel.py -f CONNECTION_FILE
"""
import sys

from ipykernel import iostream

_init = iostream.IOPubThread.__init__


def _without_pipe(self, socket, pipe=False):
    _init(self, socket, pipe=False)


iostream.IOPubThread.__init__ = _without_pipe

if __name__ == "__main__":
    if sys.path and sys.path[0].endswith("sirupp"):  # not this folder first: `import sirupp` works
        sys.path.pop(0)
    from ipykernel import kernelapp

    kernelapp.launch_new_instance()

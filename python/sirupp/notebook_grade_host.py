"""Grades a student's notebook for `sirupp grade notebook` (grade/notebook_assignment.hpp), inside
the sandbox, under Debian's python3 started with -I:

    python3 -I notebook_grade_host.py NOTEBOOK.ipynb TIMEOUT_S OUTPUT_LIMIT_BYTES < HIDDEN.py

The teacher's hidden tests come on stdin, so they are never a file inside the sandbox. The host
runs every cell of NOTEBOOK (a scratch copy) in a fresh python3 kernel (nbclient; the kernel's
channels on Unix sockets: the sandbox allows no other), errors and all, then the hidden tests in
the same kernel: each function named test_* of HIDDEN.py, in its order, with the notebook's names
in reach and `points(N)` as a decorator giving its points (default 1). A test passes when it
returns without raising; its message is the AssertionError's text, or the exception's type and
text. The whole run has TIMEOUT_S; a cell still running then is interrupted and the hidden tests
are not run.

Writes one JSON object on stdout, and nothing else: {"format": "sirupp-notebook-result-1",
"tests": [{name, points, max_points, passed, message}], "cells": N, "cell_errors": [...],
"problem": "" or why the tests did not all run, "output": the notebook's output as text, cut at
OUTPUT_LIMIT_BYTES}. The kernel gets /dev/null as stdin, stdout and stderr, and the host makes
itself undumpable, so the student's code cannot write on the host's stdout, nor read its memory.
"""
import ctypes
import json
import math
import os
import secrets
import sys
import tempfile
import time

FORMAT = "sirupp-notebook-result-1"
MESSAGE_LIMIT = 300

# Runs in the kernel after the notebook: the tests' source and the nonce are literals in this
# cell's text (never on disk); one line "NONCE JSON" on the kernel's own stdout carries the scores.
HARNESS = r'''
def __sirupp_grade(source, nonce):
    import json as _json, sys as _sys
    # The kernel's own stdout stream (ipykernel's OutStream): its flush returns once the line is
    # on IOPub, before the cell's end. A notebook that replaced sys.stdout leaves the file
    # descriptor, whose capture is forwarded later (the host waits for it).
    try:
        from ipykernel.iostream import OutStream as _OutStream
        out = _sys.stdout if isinstance(_sys.stdout, _OutStream) else _sys.__stdout__
    except ImportError:
        out = _sys.__stdout__
    def points(n):
        def mark(function):
            function.__sirupp_points__ = n
            return function
        return mark
    names = dict(globals())
    names.pop("__sirupp_grade", None)
    names["points"] = points
    names["__name__"] = "sirupp_hidden_tests"
    results = []
    try:
        exec(compile(source, "hidden tests", "exec"), names)
    except BaseException as error:
        print(nonce + " " + _json.dumps({"load_error": type(error).__name__ + ": " + str(error)}),
              file=out, flush=True)
        return
    for name, value in list(names.items()):
        # Only the teacher's tests: a test_* the notebook defined itself is not run.
        code = getattr(value, "__code__", None)
        if not name.startswith("test_") or code is None or code.co_filename != "hidden tests":
            continue
        worth = getattr(value, "__sirupp_points__", 1)
        try:
            value()
            results.append({"name": name, "max_points": worth, "passed": True, "message": ""})
        except AssertionError as error:
            results.append({"name": name, "max_points": worth, "passed": False,
                            "message": str(error) or "assertion failed"})
        except BaseException as error:
            results.append({"name": name, "max_points": worth, "passed": False,
                            "message": type(error).__name__ + ": " + str(error)})
    print(nonce + " " + _json.dumps({"tests": results}), file=out, flush=True)
__sirupp_grade(%r, %r)
del __sirupp_grade
'''


def undumpable():
    """PR_SET_DUMPABLE 0: /proc/PID/mem, fd and environ of this process are no longer the uid's."""
    try:
        ctypes.CDLL(None, use_errno=True).prctl(4, 0, 0, 0, 0)
    except OSError:
        pass


def cut(text, limit):
    data = text.encode("utf-8", "replace")
    if len(data) <= limit:
        return text
    return data[:limit].decode("utf-8", "ignore") + "\n[output cut at %d bytes]\n" % limit


def cell_text(outputs):
    parts = []
    for out in outputs:
        kind = out.get("output_type")
        if kind == "stream":
            parts.append(out.get("text", ""))
        elif kind in ("execute_result", "display_data"):
            data = out.get("data", {})
            if "text/plain" in data:
                parts.append(data["text/plain"] + "\n")
            elif data:
                parts.append("[%s]\n" % ", ".join(sorted(data)))
        elif kind == "error":
            parts.append("%s: %s\n" % (out.get("ename", "Error"), out.get("evalue", "")))
    return "".join(parts)


def grade(notebook_file, timeout_s, output_limit, source):
    import nbformat
    from jupyter_client.manager import KernelManager
    from nbclient import NotebookClient
    from nbclient.exceptions import CellTimeoutError, DeadKernelError

    result = {"format": FORMAT, "tests": [], "cells": 0, "cell_errors": [], "problem": "",
              "output": ""}
    try:
        nb = nbformat.read(notebook_file, as_version=4)
    except Exception as error:
        result["problem"] = "not a notebook: %s: %s" % (type(error).__name__, str(error)[:200])
        return result
    deadline = time.monotonic() + timeout_s
    kept = [0]  # bytes of output kept, over the whole notebook

    class Client(NotebookClient):
        # Output past the limit is dropped as it comes: a cell printing megabytes costs no memory.
        def output(self, outs, msg, display_id, cell_index):
            content = msg.get("content", {})
            stream = msg.get("msg_type") == "stream"
            size = len(content.get("text", "")) if stream else len(json.dumps(content))
            left = output_limit - kept[0]
            if size > left and stream and left > 200:
                # The start of a long stream is kept, up to the limit.
                content["text"] = content.get("text", "")[:left - 200]
                size = len(content["text"])
            if size > left:
                if not getattr(self, "_sirupp_cut", False):
                    self._sirupp_cut = True
                    outs.append(nbformat.v4.new_output(
                        "stream", name="stderr",
                        text="\n[output past %d bytes dropped]\n" % output_limit))
                return None
            kept[0] += size
            return super().output(outs, msg, display_id, cell_index)

    here = os.path.dirname(os.path.abspath(notebook_file))
    # The channels' sockets in a folder of their own under /tmp (the sandbox's private /tmp): a
    # socket's path must stay under 108 bytes, which a deep scratch folder may not.
    sockets = tempfile.mkdtemp(prefix="sirupp-kernel-")
    # The kernel: Debian's python3 ipykernel through notebook_grade_kernel.py (no TCP pipe), as a
    # kernel spec of its own in a folder on JUPYTER_PATH.
    specs = os.path.join(sockets, "kernels", "sirupp-grade")
    os.makedirs(specs)
    with open(os.path.join(specs, "kernel.json"), "w") as spec:
        json.dump({"argv": [sys.executable, "-s",
                            os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                         "notebook_grade_kernel.py"),
                            "-f", "{connection_file}", "--HistoryManager.enabled=False"],
                   "display_name": "Python 3 (graded)", "language": "python"}, spec)
    os.environ["JUPYTER_PATH"] = sockets
    km = KernelManager(kernel_name="sirupp-grade", transport="ipc", ip=os.path.join(sockets, "k"))
    client = Client(nb, km=km, timeout=max(1, int(math.ceil(timeout_s))), allow_errors=True, kernel_name="sirupp-grade",
                    resources={"metadata": {"path": here}}, startup_timeout=60)
    code_cells = [(i, c) for i, c in enumerate(nb.cells) if c.cell_type == "code"]
    result["cells"] = len(code_cells)
    lines = []
    current = [0]  # the code cell running, from 1; 0: the hidden tests
    try:
        with client.setup_kernel(stdin=open(os.devnull), stdout=open(os.devnull, "w"),
                                 stderr=open(os.devnull, "w")):
            for number, (index, cell) in enumerate(code_cells, 1):
                current[0] = number
                left = deadline - time.monotonic()
                if left <= 0.5:
                    result["problem"] = ("the notebook did not finish within %g s (code cell %d "
                                         "of %d had not started)" % (timeout_s, number,
                                                                    len(code_cells)))
                    break
                client.timeout = max(1, int(math.ceil(left)))
                try:
                    client.execute_cell(cell, index)
                except CellTimeoutError:
                    result["problem"] = ("code cell %d of %d was still running after the %g s "
                                         "the whole notebook may take" % (number, len(code_cells),
                                                                           timeout_s))
                    break
                errors = [o for o in cell.get("outputs", []) if o.get("output_type") == "error"]
                if errors:
                    result["cell_errors"].append({
                        "cell": number,
                        "error": cut("%s: %s" % (errors[0].get("ename", ""),
                                                 errors[0].get("evalue", "")), MESSAGE_LIMIT)})
            current[0] = 0
            if not result["problem"]:
                nonce = secrets.token_hex(16)
                left = deadline - time.monotonic()
                if left <= 0.5:
                    result["problem"] = ("no time was left for the hidden tests (the run may "
                                         "take %g s)" % timeout_s)
                else:
                    found = []

                    def hook(msg):
                        if msg.get("msg_type") == "stream":
                            for line in msg["content"].get("text", "").splitlines():
                                if line.startswith(nonce + " "):
                                    found.append(line[len(nonce) + 1:])

                    try:
                        client.kc.execute_interactive(HARNESS % (source, nonce), timeout=left,
                                                      output_hook=hook, store_history=False,
                                                      allow_stdin=False)
                    except TimeoutError:
                        result["problem"] = ("the hidden tests were still running after the %g "
                                             "s the whole run may take" % timeout_s)
                    # Output captured from the file descriptor comes after the cell's end: up to
                    # 5 s more for the scores' line.
                    until = time.monotonic() + 5
                    while not result["problem"] and not found and time.monotonic() < until:
                        try:
                            hook(client.kc.get_iopub_msg(timeout=0.2))
                        except Exception:  # queue.Empty: nothing yet
                            pass
                    if not result["problem"]:
                        if not found:
                            result["problem"] = ("the hidden tests gave no scores (the kernel "
                                                 "ended, or the notebook replaced its output)")
                        else:
                            try:
                                scores = json.loads(found[-1])
                            except ValueError:
                                scores = {"load_error": "unreadable scores"}
                            if "load_error" in scores:
                                result["problem"] = ("the teacher's hidden tests could not be "
                                                     "loaded: " + str(scores["load_error"])[:200])
                            else:
                                result["tests"] = scores.get("tests", [])
    except DeadKernelError:
        result["problem"] = ("the kernel died in code cell %d of %d (a crash, a signal, or past the "
                             "memory limit)" % (current[0], len(code_cells)) if current[0]
                             else "the kernel died while the hidden tests ran")
    except Exception as error:  # a kernel that would not start, a broken channel
        result["problem"] = "the notebook could not be run: %s: %s" % (type(error).__name__,
                                                                      str(error)[:200])
    for number, (index, cell) in enumerate(code_cells, 1):
        text = cell_text(cell.get("outputs", []))
        if text:
            lines.append("[cell %d]\n%s" % (number, text if text.endswith("\n") else text + "\n"))
    result["output"] = cut("".join(lines), output_limit)
    return result


def main(argv):
    if len(argv) != 4:
        print("usage: notebook_grade_host.py NOTEBOOK.ipynb TIMEOUT_S OUTPUT_LIMIT_BYTES < TESTS",
              file=sys.stderr)
        return 2
    source = sys.stdin.read()
    out = os.fdopen(os.dup(1), "w")  # not inheritable: the kernel never has it
    null = os.open(os.devnull, os.O_RDWR)
    for fd in (0, 1):
        os.dup2(null, fd)
    undumpable()
    # This build's module (build/python) is the folder above this file's; the kernel gets it too.
    module_dir = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    sys.path.insert(0, module_dir)
    os.environ["PYTHONPATH"] = module_dir
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    os.environ.setdefault("MPLBACKEND", "Agg")
    os.environ["PYDEVD_DISABLE_FILE_VALIDATION"] = "1"
    os.environ["JUPYTER_RUNTIME_DIR"] = os.path.join(os.path.dirname(os.path.abspath(argv[1])),
                                                     "runtime")
    try:
        result = grade(argv[1], float(argv[2]), int(argv[3]), source)
    except Exception as error:
        result = {"format": FORMAT, "tests": [], "cells": 0, "cell_errors": [],
                  "problem": "the grader failed: %s: %s" % (type(error).__name__, error),
                  "output": ""}
    out.write(json.dumps(result) + "\n")
    out.flush()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))

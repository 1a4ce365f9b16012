#!/usr/bin/python3
"""The course's notebooks (notebooks/0*.ipynb) run inside a student's notebook sandbox through the
hub (docs/notebooks.md): each executed with nbconvert from a kernel of alice's server, in her
folder's copies; private rigs (04 to 08), the sirupp command (06) and the project's controller
sandbox nested inside (07) included. About a minute on 2 idle cores.
Usage: hub_course_test.py BIN_DIR SOURCE_DIR"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from hub_run import HubRun, run_code  # noqa: E402

CODE = r"""
import glob, os, subprocess, time
os.chdir("/home/student/notebooks")
for nb in sorted(glob.glob("0*.ipynb")):
    t = time.time()
    p = subprocess.run(["jupyter", "nbconvert", "--to", "notebook", "--execute", "--output-dir",
                        "/tmp/out", "--ExecutePreprocessor.timeout=300", nb],
                       capture_output=True, text=True)
    last = p.stderr.strip().splitlines()[-1][:300] if p.returncode and p.stderr.strip() else ""
    print("NB", nb, p.returncode, round(time.time() - t, 1), last, flush=True)
"""


def main(bin_dir, source_dir):
    hub = HubRun(bin_dir, source_dir, ["alice"])
    ok = False
    try:
        hub.start()
        alice = hub.front("alice")
        hub.sign_in(alice)
        hub.wait_server(alice, "alice")
        token = hub.user_token(alice, "alice")
        reply, out, error = run_code(hub, "alice", token, CODE, timeout=500)
        rows = [line.split(" ", 4)[1:] for line in out.splitlines() if line.startswith("NB ")]
        expected = sorted(n for n in os.listdir(os.path.join(source_dir, "notebooks"))
                          if n.startswith("0") and n.endswith(".ipynb"))
        for row in rows:
            print(("ok: " if row[1] == "0" else "FAIL: ") + " ".join(row))
        ok = (reply == "ok" and [r[0] for r in rows] == expected and
              all(r[1] == "0" for r in rows))
        if not ok:
            print(f"reply {reply}; ran {[r[0] for r in rows]} of {expected}; {error[-800:]}")
    finally:
        if not ok:
            print("alice's server:\n" + hub.server_log("alice")[-3000:])
        left = hub.stop()
        if left:
            print("left running (killed):", left)
            ok = False
        if ok:
            hub.clean()
    print("ok" if ok else "FAIL")
    return 0 if ok else 1


if __name__ == "__main__":
    if not os.access("/usr/bin/jupyterhub", os.X_OK):
        print("skipped: /usr/bin/jupyterhub is not installed (scripts/install-deps.sh --services)")
        sys.exit(77)
    sys.exit(main(sys.argv[1], sys.argv[2]))

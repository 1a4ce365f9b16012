#!/usr/bin/python3
"""`sirupp class notebooks` refuses with one clear line and a non-zero exit (docs/notebooks.md):
a class file without notebooks:, one without notebooks.hub_url, server.port 0, a missing
jupyterhub, the hub's ports in use. Nothing is started. Usage: hub_cli_test.py BIN_DIR SOURCE_DIR"""

import os
import shutil
import socket
import subprocess
import sys
import tempfile


def main(bin_dir, source_dir):
    sirupp = os.path.join(os.path.abspath(bin_dir), "sirupp")
    work = tempfile.mkdtemp(prefix="sirupp-hub-cli-")
    failures = []

    def class_file(name, server, notebooks):
        path = os.path.join(work, name)
        with open(path, "w") as out:
            out.write("class: c\n"
                      f"robot: {os.path.abspath(source_dir)}/config/robots/puma260.yaml\n"
                      "students: [alice]\ndata: data\n"
                      f"server: {server}\n" + notebooks)
        return path

    def expect(what, args, needles):
        p = subprocess.run([sirupp, "class", "notebooks"] + args, capture_output=True, text=True,
                           timeout=30)
        text = p.stdout + p.stderr
        good = p.returncode != 0 and all(n in text for n in needles) and len(text.strip().splitlines()) == 1
        print(("ok: " if good else "FAIL: ") + f"{what}: exit {p.returncode}: {text.strip()[:200]}")
        if not good:
            failures.append(what)

    try:
        with socket.socket() as probe:
            probe.bind(("127.0.0.1", 0))
            busy_port = probe.getsockname()[1]
            probe.listen(1)
            none = class_file("none.yaml", "{port: 8800}", "")
            expect("no notebooks: key", [none], [none, "no notebooks: key"])
            no_url = class_file("no_url.yaml", "{port: 8800}", "notebooks: {hub_port: 8810}\n")
            expect("no hub_url", [no_url], ["notebooks.hub_url is not set"])
            good = "notebooks: {hub_url: 'https://nb.example.edu', hub_port: %d}\n"
            any_port = class_file("any.yaml", "{port: 0}", good % 8810)
            expect("server.port 0", [any_port], ["server.port is 0"])
            missing = class_file("ok.yaml", "{port: 8800}", good % 8810)
            expect("jupyterhub missing", [missing, "--jupyterhub", os.path.join(work, "nowhere")],
                   ["nowhere: not installed", "apt-get install jupyterhub"])
            if os.access("/usr/bin/jupyterhub", os.X_OK) and os.access(
                    "/usr/bin/configurable-http-proxy", os.X_OK):
                busy = class_file("busy.yaml", "{port: 8800}", good % busy_port)
                expect("the hub's port in use", [busy],
                       [f"port {busy_port} (the hub's proxy) is in use on 127.0.0.1"])
            else:
                print("not checked: the port in use (needs jupyterhub installed)")
        expect("no class file", [os.path.join(work, "missing.yaml")], ["missing.yaml"])
    finally:
        shutil.rmtree(work, ignore_errors=True)
    print("ok" if not failures else f"FAIL: {failures}")
    return 0 if not failures else 1


if __name__ == "__main__":
    sys.exit(main(sys.argv[1], sys.argv[2]))

#!/usr/bin/python3
"""The hub behind Apache on a hostname of its own, as docs/install.md ("Notebooks on their own
hostname") sets it up: Debian's apache2 in the foreground with a configuration of this test's own
on a free port of 127.0.0.1, mod_auth_basic standing in for mod_auth_openidc (both hand Apache a
REMOTE_USER), the user header and the front's secret set by Apache, the kernels' WebSockets by
the RewriteRule recipe (mod_proxy_wstunnel), in front of the hub (tests/hub/hub_run.py).

Two students sign in through Apache and each runs a kernel through it (REST and WebSocket); a
client's own X-Remote-User does not get through; without a password Apache refuses; the front's
header sent straight to the hub's port without the secret is refused. Everything is stopped at the
end, also after a failure. Usage: hub_front_test.py BIN_DIR SOURCE_DIR"""

import base64
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import hub_run  # noqa: E402
from hub_run import FRONT_SECRET, HubRun, Session  # noqa: E402

MODULES = "/usr/lib/apache2/modules"
PASSWORDS = {"alice": "alice-pw-1", "bob": "bob-pw-2"}


def free_port():
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def check(condition, what):
    if not condition:
        raise AssertionError(what)
    print("ok:", what[:160])


class Apache:
    def __init__(self, hub_port):
        self.root = tempfile.mkdtemp(prefix="sirupp-hub-apache-")
        os.chmod(self.root, 0o755)
        self.port = free_port()
        self.proc = None
        secret_conf = os.path.join(self.root, "front-secret.conf")
        with open(os.open(secret_conf, os.O_WRONLY | os.O_CREAT, 0o600), "w") as out:
            out.write(f"Define SIRUPP_FRONT_SECRET {FRONT_SECRET}\n")
        htpasswd = os.path.join(self.root, "htpasswd")
        for i, (user, password) in enumerate(PASSWORDS.items()):
            subprocess.run(["htpasswd", "-b" + ("c" if i == 0 else "") + "B", htpasswd, user,
                            password], check=True, capture_output=True)
        os.chmod(htpasswd, 0o644)
        modules = ["mpm_event", "authz_core", "authn_core", "authn_file", "auth_basic",
                   "authz_user", "headers", "proxy", "proxy_http", "proxy_wstunnel", "rewrite"]
        self.conf = os.path.join(self.root, "apache2.conf")
        backend = f"127.0.0.1:{hub_port}"
        with open(self.conf, "w") as out:
            out.write(f'ServerRoot "{self.root}"\nServerName 127.0.0.1\n'
                      f"Listen 127.0.0.1:{self.port}\n"
                      f'PidFile "{self.root}/apache2.pid"\nDefaultRuntimeDir "{self.root}"\n'
                      f'Mutex file:{self.root} default\n'
                      f'ErrorLog "{self.root}/error.log"\nLogLevel warn\n'
                      'User www-data\nGroup www-data\n'
                      + "".join(f"LoadModule {m}_module {MODULES}/mod_{m}.so\n" for m in modules)
                      + f'Include "{secret_conf}"\n'
                      f"""<VirtualHost 127.0.0.1:{self.port}>
  <Location "/">
    AuthType Basic
    AuthName "University sign-in (test: mod_auth_basic for mod_auth_openidc)"
    AuthBasicProvider file
    AuthUserFile "{htpasswd}"
    Require valid-user
    RequestHeader unset Authorization
    RequestHeader unset X-Remote-User
    RequestHeader set X-Remote-User "expr=%{{REMOTE_USER}}"
    RequestHeader set X-Sirupp-Front-Secret "${{SIRUPP_FRONT_SECRET}}"
    RequestHeader set X-Forwarded-Proto "http"
  </Location>
  RewriteEngine On
  RewriteCond %{{HTTP:Connection}} Upgrade [NC]
  RewriteCond %{{HTTP:Upgrade}} websocket [NC]
  RewriteRule /(.*) ws://{backend}/$1 [P,L]
  RewriteRule /(.*) http://{backend}/$1 [P,L]
  ProxyPreserveHost On
  ProxyPassReverse / http://{backend}/
</VirtualHost>
""")
        self.base = f"http://127.0.0.1:{self.port}"

    def start(self):
        test = subprocess.run(["/usr/sbin/apache2", "-f", self.conf, "-t"], capture_output=True,
                              text=True)
        assert test.returncode == 0, "apache2 -t: " + test.stdout + test.stderr
        self.proc = subprocess.Popen(["/usr/sbin/apache2", "-f", self.conf, "-DFOREGROUND"],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT,
                                     start_new_session=True)
        end = time.time() + 20
        while time.time() < end:
            assert self.proc.poll() is None, "apache2 ended: " + self.error_log()
            try:
                with socket.create_connection(("127.0.0.1", self.port), timeout=1):
                    return self
            except OSError:
                time.sleep(0.1)
        raise AssertionError("apache2 did not listen: " + self.error_log())

    def error_log(self):
        try:
            with open(os.path.join(self.root, "error.log")) as source:
                return source.read()[-3000:]
        except OSError:
            return ""

    def stop(self):
        if self.proc and self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGTERM)
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
        subprocess.run(["rm", "-rf", self.root])


def basic(user):
    return "Basic " + base64.b64encode(f"{user}:{PASSWORDS[user]}".encode()).decode()


class Through:
    """hub_run's HubRun seen through Apache: the same calls, the front's address as the base."""

    def __init__(self, hub, apache):
        self.hub, self.hub_base, self.hub_port = hub, apache.base, apache.port

    def server_log(self, name):
        return self.hub.server_log(name)


def main(bin_dir, source_dir):
    hub = HubRun(bin_dir, source_dir, ["alice", "bob"])
    apache = None
    ok = False
    try:
        hub.start()
        apache = Apache(hub.hub_port).start()
        front = Through(hub, apache)
        for name in ("alice", "bob"):
            # A client's own X-Remote-User is replaced by the name Apache signed in.
            session = Session(front, {"Authorization": basic(name), "X-Remote-User": "mallory"})
            status, url, _ = session.get("/hub/login")
            check(status == 200, f"{name} signs in through Apache: {status} {url}")
            HubRun.wait_server(front, session, name)
            token = HubRun.user_token(front, session, name)
            # Through Apache the token rides in the query (Apache takes Authorization).
            reply, out, error = run_code_through(front, name, token, basic(name))
            check(reply == "ok" and out.strip() == name,
                  f"{name}'s kernel answers through Apache's WebSocket: {reply} {out!r} {error[-300:]}")
        status, _, _ = Session(front).get("/hub/login")
        check(status == 401, f"no password: Apache refuses: {status}")
        forged = Session(hub, {"X-Remote-User": "alice"})
        status, _, _ = forged.get("/hub/login")
        check(status == 403, f"the user header straight to the hub without the secret: {status}")
        ok = True
    finally:
        if not ok:
            print(hub.hub_log()[-6000:])
            if apache:
                print("apache:\n" + apache.error_log())
        if apache:
            apache.stop()
        left = hub.stop()
        if left:
            print("left running (killed):", left)
            ok = False
        else:
            print("ok: nothing of the test is left running")
        if ok:
            hub.clean()
    print("ok" if ok else "FAIL")
    return 0 if ok else 1


def run_code_through(front, name, token, authorization):
    """hub_run.run_code through Apache: Apache's password in Authorization, the hub's token in
    the query."""
    return hub_run.run_code(front, name, token, "import os; print(os.environ['JUPYTERHUB_USER'])",
                            authorization=authorization)


if __name__ == "__main__":
    for tool in ("/usr/bin/jupyterhub", "/usr/sbin/apache2", "/usr/bin/htpasswd"):
        if not os.access(tool, os.X_OK):
            print(f"skipped: {tool} is not installed (scripts/install-deps.sh --services)")
            sys.exit(77)
    sys.exit(main(sys.argv[1], sys.argv[2]))

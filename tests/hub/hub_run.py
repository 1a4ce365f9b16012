"""A class server and its notebooks hub for the hub's tests and benchmark (docs/notebooks.md):
writes a class file with a front (trusted_proxy 127.0.0.1 and its secret) and notebooks: into a
temporary folder, starts `sirupp class serve` on a free port and `sirupp class notebooks` (JupyterHub
and its proxy on 127.0.0.1, free ports), signs students in over HTTP (cookies) and talks to their
kernels over the hub's WebSocket (tornado, Debian's python3-tornado). stop() ends the hub, every
notebook server it started (their process groups) and the class server, also after a failure."""

import asyncio
import http.cookiejar
import json
import os
import re
import signal
import socket
import subprocess
import sys
import time
import urllib.error
import urllib.request
import uuid

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "class"))
from class_run import ClassRun, alive  # noqa: E402

FRONT_SECRET = "front-secret-for-the-hub-test-0123456789"


def free_port_block(count):
    """A port p with p .. p+count-1 all free on 127.0.0.1."""
    for _ in range(200):
        with socket.socket() as probe:
            probe.bind(("127.0.0.1", 0))
            base = probe.getsockname()[1]
        if base + count > 65535:
            continue
        ok = True
        for p in range(base, base + count):
            with socket.socket() as probe:
                try:
                    probe.bind(("127.0.0.1", p))
                except OSError:
                    ok = False
                    break
        if ok:
            return base
    raise AssertionError("no block of free ports")


class Session:
    """One browser's cookies on the hub."""

    def __init__(self, hub, headers=None):
        self.hub = hub
        self.jar = http.cookiejar.CookieJar()
        self.opener = urllib.request.build_opener(urllib.request.HTTPCookieProcessor(self.jar))
        self.headers = dict(headers or {})

    def get(self, path, headers=None, timeout=60):
        """(status, final URL, body text); redirects followed."""
        request = urllib.request.Request(self.hub.hub_base + path,
                                         headers={"Accept": "text/html", **self.headers,
                                                  **(headers or {})})
        try:
            with self.opener.open(request, timeout=timeout) as answer:
                return answer.status, answer.geturl(), answer.read().decode(errors="replace")
        except urllib.error.HTTPError as error:
            return error.code, error.geturl(), error.read().decode(errors="replace")

    def api(self, method, path, body=None, token=None):
        """(status, JSON or text) of a hub or server API call with this session's cookies (and the
        Referer JupyterHub wants of cookie-authenticated API calls) or a token."""
        headers = {"Referer": self.hub.hub_base + "/hub/", "Accept": "application/json",
                   **self.headers}
        if token and "Authorization" in headers:  # a front's password: the token in the query
            path += ("&" if "?" in path else "?") + "token=" + token
        elif token:
            headers["Authorization"] = f"token {token}"
        data = json.dumps(body).encode() if body is not None else None
        if data is not None:
            headers["Content-Type"] = "application/json"
        request = urllib.request.Request(self.hub.hub_base + path, data=data, method=method,
                                         headers=headers)
        try:
            with self.opener.open(request, timeout=60) as answer:
                text = answer.read().decode(errors="replace")
                status = answer.status
        except urllib.error.HTTPError as error:
            text = error.read().decode(errors="replace")
            status = error.code
        try:
            return status, json.loads(text)
        except ValueError:
            return status, text


class HubRun:
    def __init__(self, bin_dir, source_dir, students, idle_timeout_s=900, poll_interval_s=None,
                 notebooks_folder=None, extra_yaml=""):
        self.bin = os.path.abspath(bin_dir)
        self.src = os.path.abspath(source_dir)
        self.hub_port = free_port_block(3)
        with socket.socket() as probe:
            probe.bind(("127.0.0.1", 0))
            class_port = probe.getsockname()[1]
        folder = f", folder: {notebooks_folder}" if notebooks_folder else ""
        self.cls = ClassRun(
            bin_dir, source_dir, students,
            server_yaml=(f"{{port: {class_port}, trusted_proxy: 127.0.0.1, "
                         "proxy_secret_file: front.secret, proxy_teachers: [jsmith]}"),
            extra_yaml=(f"notebooks: {{hub_url: 'http://127.0.0.1:{self.hub_port}', "
                        f"hub_port: {self.hub_port}, idle_timeout_s: {max(60, idle_timeout_s)}"
                        f"{folder}}}\n" + extra_yaml))
        secret = os.path.join(self.cls.work, "front.secret")
        with open(os.open(secret, os.O_WRONLY | os.O_CREAT, 0o600), "w") as out:
            out.write(FRONT_SECRET + "\n")
        self.work = self.cls.work
        self.poll_interval_s = poll_interval_s
        self.idle_timeout_s = idle_timeout_s
        self.hub_base = f"http://127.0.0.1:{self.hub_port}"
        self.hub = None
        self.hub_logs = []

    def data(self, *parts):
        return self.cls.data(*parts)

    def start(self):
        self.cls.start()
        self.start_hub()
        return self

    def start_hub(self):
        log = os.path.join(self.work, f"hub-{len(self.hub_logs)}.log")
        self.hub_logs.append(log)
        command = [os.path.join(self.bin, "sirupp"), "class", "notebooks", self.cls.class_file]
        if self.poll_interval_s:
            command += ["--poll-interval", str(self.poll_interval_s)]
        if self.idle_timeout_s < 60:  # below the class file's minimum: the test's override
            command += ["--idle-timeout", str(self.idle_timeout_s)]
        with open(log, "w") as out:
            self.hub = subprocess.Popen(command, stdout=out, stderr=subprocess.STDOUT,
                                        stdin=subprocess.DEVNULL, start_new_session=True)
        deadline = time.time() + 40
        while time.time() < deadline:
            if self.hub.poll() is not None:
                raise AssertionError(f"the hub ended ({self.hub.returncode}): {self.hub_log()}")
            try:
                with urllib.request.urlopen(self.hub_base + "/hub/api", timeout=2) as answer:
                    if answer.status == 200:
                        return
            except (urllib.error.URLError, OSError):
                pass
            time.sleep(0.2)
        raise AssertionError("the hub did not answer within 40 s: " + self.hub_log())

    def hub_log(self):
        text = ""
        for log in self.hub_logs:
            with open(log, errors="replace") as source:
                text += f"--- {log}\n" + source.read()[-20000:]
        return text

    def server_log(self, name):
        try:
            with open(self.data("hub", "run", name, "server.log"), errors="replace") as source:
                text = source.read()[-8000:]
            with open(self.data("hub", "run", name, "sock", "inner.log"), errors="replace") as s:
                text += "\n--- inner.log\n" + s.read()[-4000:]
            return text
        except OSError as error:
            return str(error)

    def front(self, name):
        """A session signed in by the front as `name`."""
        return Session(self, {"X-Remote-User": name, "X-Sirupp-Front-Secret": FRONT_SECRET})

    def sign_in(self, session, query=""):
        return session.get("/hub/login" + query)

    def wait_server(self, session, name, timeout=60):
        """Waits until name's server answers its own API through the hub; the API's status."""
        deadline = time.time() + timeout
        last = None
        while time.time() < deadline:
            # The page first: the hub's OAuth gives this session the server's own cookie.
            status, url, body = session.get(f"/user/{name}/tree")
            if status == 200 and f"/user/{name}/tree" in url:
                status, body = session.api("GET", f"/user/{name}/api/status")
                if status == 200 and isinstance(body, dict):
                    return body
            last = (status, str(body)[:200])
            if status == 500:
                break
            time.sleep(0.5)
        raise AssertionError(f"{name}'s server did not answer in {timeout} s: {last}\n" +
                             self.server_log(name))

    def user_token(self, session, name):
        status, body = session.api("POST", f"/hub/api/users/{name}/tokens",
                                   {"note": "test", "expires_in": 3600})
        assert status in (200, 201), f"token for {name}: {status} {body}"
        return body["token"]

    def supervisors(self):
        """pids of the notebook servers' supervisors of this run (by their launch file's folder)."""
        pids = []
        marker = os.path.join(self.work, "data", "hub", "run")
        for entry in os.listdir("/proc"):
            if not entry.isdigit():
                continue
            try:
                with open(f"/proc/{entry}/cmdline", "rb") as source:
                    words = source.read().split(b"\0")
            except OSError:
                continue
            text = b" ".join(words).decode(errors="replace")
            if "sirupp_hub.supervise" in text and marker in text:
                pids.append(int(entry))
        return pids

    def ours(self):
        """Every process whose command line names this run's folder (what must be gone)."""
        found = []
        for entry in os.listdir("/proc"):
            if not entry.isdigit() or int(entry) == os.getpid():
                continue
            try:
                with open(f"/proc/{entry}/cmdline", "rb") as source:
                    text = source.read().replace(b"\0", b" ").decode(errors="replace")
            except OSError:
                continue
            if self.work in text and alive(int(entry)):
                found.append((int(entry), text[:160]))
        return found

    def stop_hub(self, keep_servers=False):
        if self.hub and self.hub.poll() is None:
            os.killpg(self.hub.pid, signal.SIGTERM)
            try:
                self.hub.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(self.hub.pid, signal.SIGKILL)
                self.hub.wait()
        if self.hub:
            try:
                os.killpg(self.hub.pid, signal.SIGKILL)  # the proxy, if it stayed
            except ProcessLookupError:
                pass
        if not keep_servers:
            for pid in self.supervisors():
                try:
                    os.killpg(pid, signal.SIGTERM)
                except ProcessLookupError:
                    pass
            deadline = time.time() + 10
            while time.time() < deadline and self.supervisors():
                time.sleep(0.1)
            for pid in self.supervisors():
                try:  # a supervisor in a Slurm step may lead no process group of its own
                    os.killpg(pid, signal.SIGKILL)
                except ProcessLookupError:
                    try:
                        os.kill(pid, signal.SIGKILL)
                    except ProcessLookupError:
                        pass

    def stop(self):
        self.stop_hub()
        self.cls.stop()
        deadline = time.time() + 10
        while time.time() < deadline and self.ours():
            time.sleep(0.2)
        left = self.ours()
        for pid, _ in left:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
        return left

    def clean(self):
        self.cls.clean()


def run_code(hub, name, token, code, timeout=60, authorization=None):
    """Runs `code` in a new kernel of name's server over the hub's WebSocket; returns (status of
    the reply, the text printed, the error's text). The kernel is shut down after. With
    `authorization` (a front's password) that is the Authorization header and the token goes in
    the query."""
    from tornado.httpclient import HTTPRequest
    from tornado.websocket import websocket_connect

    def session():
        return Session(hub, {"Authorization": authorization} if authorization else None)

    status, kernel = session().api("POST", f"/user/{name}/api/kernels", {"name": "python3"},
                                   token=token)
    assert status in (200, 201), f"kernel for {name}: {status} {kernel}"

    async def talk():
        url = f"ws://127.0.0.1:{hub.hub_port}/user/{name}/api/kernels/{kernel['id']}/channels"
        if authorization:
            url += "?token=" + token
        ws = await websocket_connect(HTTPRequest(url, headers={
            "Authorization": authorization or f"token {token}"}))
        session = uuid.uuid4().hex

        def send(kind, content):
            msg_id = uuid.uuid4().hex
            ws.write_message(json.dumps({
                "header": {"msg_id": msg_id, "username": name, "session": session,
                           "msg_type": kind, "version": "5.3"},
                "parent_header": {}, "metadata": {}, "channel": "shell", "content": content}))
            return msg_id

        # A message sent while the kernel is still starting may be lost: ask for kernel_info
        # until it answers, then run the code.
        deadline = time.time() + timeout
        ready = False
        while not ready and time.time() < deadline:
            info = send("kernel_info_request", {})
            until = time.time() + 2
            while time.time() < until:
                try:
                    text = await asyncio.wait_for(ws.read_message(), until - time.time())
                except asyncio.TimeoutError:
                    break
                if text is None:
                    raise AssertionError("the kernel's WebSocket closed")
                message = json.loads(text)
                if (message.get("parent_header", {}).get("msg_id") == info and
                        message["msg_type"] == "kernel_info_reply"):
                    ready = True
                    break
        assert ready, f"{name}'s kernel did not answer kernel_info in {timeout} s"
        msg_id = send("execute_request", {"code": code, "silent": False, "store_history": False,
                                          "user_expressions": {}, "allow_stdin": False,
                                          "stop_on_error": True})
        out, error, reply, idle = [], [], None, False
        while time.time() < deadline:
            try:
                text = await asyncio.wait_for(ws.read_message(), max(0.1, deadline - time.time()))
            except asyncio.TimeoutError:
                error.append(f"no reply within {timeout} s")
                break
            if text is None:
                break
            message = json.loads(text)
            if message.get("parent_header", {}).get("msg_id") != msg_id:
                continue
            kind = message["msg_type"]
            if kind == "stream":
                out.append(message["content"]["text"])
            elif kind == "error":
                error.append("\n".join(message["content"]["traceback"]))
            elif kind == "execute_reply":
                reply = message["content"]["status"]
            elif kind == "status" and message["content"]["execution_state"] == "idle":
                idle = True
            # The reply (shell) and the idle status (iopub) come in either order.
            if reply and idle:
                break
        ws.close()
        return reply, "".join(out), re.sub(r"\x1b\[[0-9;]*m", "", "\n".join(error))

    try:
        return asyncio.run(talk())
    finally:
        session().api("DELETE", f"/user/{name}/api/kernels/{kernel['id']}", token=token)

#!/usr/bin/python3
"""The class server holds against the machine's other users (issue 51), tried the way they would,
over real sockets against `sirupp class serve` with a front configured (server.trusted_proxy
127.0.0.1 and its secret), each test on a server of its own:

- X-Forwarded-For is believed only with the front's secret: wrong tokens from 127.0.0.1 (the
  front's own address) with another X-Forwarded-For each are throttled on 127.0.0.1 and logged
  from it; a student the front signs in from the spoofed address is not locked out;
- names, tokens and the secret are compared as sent: "%61lice" signed in by the front is not
  alice (403 naming "%61lice"), "%6Asmith" is not the teacher, alice's token with one digit
  %-encoded opens nothing, nor does the secret with one character %-encoded;
- 100 slow connections from one address (a byte every 2 s, never ending their headers) leave
  another student's request answered within a second, served directly and through the front's
  address; the connections over the cap are refused at once, the rest closed at the request
  deadline; an idle keep-alive connection is closed after keep_alive_s;
- a good token for one student does not clear the count of bad tokens for another from the same
  address, and the lock-out still doubles.

Usage: class_hold_test.py BIN_DIR SOURCE_DIR (ctest: class_hold), or with pytest.
"""

import http.client
import json
import os
import shutil
import socket
import subprocess
import sys
import tempfile
import threading
import time

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
SECRET = "f0e1d2c3b4a5968778695a4b3c2d1e0f"


class Server:
    """`sirupp class serve` on a free port of 127.0.0.1, a front at 127.0.0.1 with SECRET."""

    def __init__(self):
        BIN = os.environ.get("SIRUPP_BIN_DIR", os.path.join(HERE, "..", "..", "build", "bin"))
        SRC = os.environ.get("SIRUPP_SOURCE_DIR", os.path.abspath(os.path.join(HERE, "..", "..")))
        self.work = tempfile.mkdtemp(prefix="sirupp-class-hold-")
        secret = os.path.join(self.work, "front.secret")
        with open(secret, "w") as f:
            f.write(SECRET + "\n")
        os.chmod(secret, 0o600)
        self.class_file = os.path.join(self.work, "class.yaml")
        with open(self.class_file, "w") as f:
            f.write("class: hold\n"
                    f"robot: {SRC}/config/robots/puma260.yaml\n"
                    "students: [alice, bob, carol]\n"
                    "data: data\n"
                    "limits: {max_rigs: 2, idle_timeout_s: 600}\n"
                    "server: {port: 0, trusted_proxy: 127.0.0.1, proxy_secret_file: front.secret,"
                    " proxy_teachers: [jsmith]}\n")
        self.log = open(os.path.join(self.work, "server.log"), "w")
        self.proc = subprocess.Popen([os.path.join(BIN, "sirupp"), "class", "serve",
                                      self.class_file], cwd=SRC, stdout=subprocess.PIPE,
                                     stderr=self.log, text=True)
        self.tokens = {}
        self.port = None
        end = time.time() + 30
        while time.time() < end and self.port is None:
            line = self.proc.stdout.readline()
            if not line:
                raise AssertionError("sirupp class serve ended: " + self.server_log())
            if line.startswith("new token: "):
                name, address = line[len("new token: "):].strip().split(",", 1)
                self.tokens[name] = address.split("token=")[1]
            if " at http://" in line:
                self.port = int(line.split(" at http://")[1].split("/")[0].rsplit(":", 1)[1])
        assert self.port, "sirupp class serve printed no address"
        # The rest of its standard output, read so that it never blocks on a full pipe.
        threading.Thread(target=self.proc.stdout.read, daemon=True).start()

    def server_log(self):
        self.log.flush()
        with open(os.path.join(self.work, "server.log")) as f:
            return f.read()

    def request(self, path, headers=None, source="127.0.0.1", timeout=10, method="GET"):
        """(status, error or body text, headers) of one request from `source`."""
        c = http.client.HTTPConnection("127.0.0.1", self.port, timeout=timeout,
                                       source_address=(source, 0))
        try:
            h = {"X-Sirupp-Client": "hold-test"}
            h.update(headers or {})
            c.request(method, path, body=b"{}" if method == "POST" else None, headers=h)
            r = c.getresponse()
            text = r.read().decode(errors="replace")
            try:
                text = json.loads(text).get("error", text)
            except (ValueError, AttributeError):
                pass
            return r.status, text, dict(r.getheaders())
        finally:
            c.close()

    def front(self, user, forwarded_for="192.0.2.10", secret=SECRET):
        return {"X-Remote-User": user, "X-Sirupp-Front-Secret": secret,
                "X-Forwarded-For": forwarded_for}

    def stop(self):
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=30)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        self.log.close()
        shutil.rmtree(self.work, ignore_errors=True)


@pytest.fixture
def server():
    s = Server()
    try:
        yield s
    finally:
        s.stop()


def test_forwarded_for_is_believed_only_with_the_fronts_secret(server):
    statuses = []
    for i in range(10):
        # Wrong tokens from the front's own address, each "forwarded for" another address.
        status, text, _ = server.request("/s/bob/class/status",
                                         {"X-Sirupp-Token": "%032x" % i,
                                          "X-Forwarded-For": "198.51.100.%d" % (i + 1)})
        statuses.append(status)
    print("10 wrong tokens from 127.0.0.1, each with another X-Forwarded-For:", statuses)
    assert 429 in statuses, "never throttled: the spoofed X-Forwarded-For was believed"
    log = server.server_log()
    spoofed = [line for line in log.splitlines() if "198.51.100." in line]
    print("log lines naming a spoofed address:", len(spoofed))
    assert not spoofed, spoofed[:3]
    # Six wrong tokens "forwarded for" 127.0.0.2, then bob signed in by the front from there.
    for i in range(6):
        server.request("/s/bob/class/status", {"X-Sirupp-Token": "%032x" % (100 + i),
                                               "X-Forwarded-For": "127.0.0.2"})
    status, text, _ = server.request("/s/bob/class/status", server.front("bob", "127.0.0.2"))
    print("bob through the front from 127.0.0.2 after them:", status, text[:100])
    assert status == 200, (status, text)


def test_names_tokens_and_the_secret_are_compared_as_sent(server):
    status, text, _ = server.request("/s/alice/class/status", server.front("%61lice"))
    print("signed in by the front as %61lice, on alice's page:", status, text[:160])
    assert status == 403 and "%61lice" in text, (status, text)
    status, text, _ = server.request("/teacher/api/rigs", server.front("%6Asmith"))
    print("signed in by the front as %6Asmith, on the teacher's page:", status, text[:160])
    assert status == 403 and "%6Asmith" in text, (status, text)
    status, text, _ = server.request("/s/alice/class/status", server.front("alice"))
    assert status == 200, ("alice herself", status, text)
    token = server.tokens["alice"]
    encoded = "%%%02X" % ord(token[0]) + token[1:]
    status, text, _ = server.request("/s/alice/class/status", {"X-Sirupp-Token": encoded},
                                     source="127.0.0.5")
    print("alice's token with its first digit %-encoded:", status, text[:160])
    assert status == 403, (status, text)
    status, text, _ = server.request("/s/alice/class/status?token=" + encoded,
                                     source="127.0.0.5")
    print("the same in ?token=:", status, text[:160])
    assert status == 403, (status, text)
    secret = "%%%02X" % ord(SECRET[0]) + SECRET[1:]
    status, text, _ = server.request("/s/alice/class/status",
                                     server.front("alice", secret=secret))
    print("the front's secret with its first character %-encoded:", status, text[:160])
    assert status == 403, (status, text)


def slow_connections(port, count, source, stop):
    """`count` connections from `source` sending a request's head a byte every 2 s, never ending
    it. Returns (sockets, {index: (seconds until the server answered or closed, first bytes)})."""
    socks, closed = [], {}
    for _ in range(count):
        s = socket.socket()
        s.bind((source, 0))
        s.settimeout(5)
        s.connect(("127.0.0.1", port))
        socks.append(s)

    def trickle():
        head = b"GET /s/alice/class/status HTTP/1.1\r\nHost: x\r\nX-Pad: " + b"a" * 200
        for i in range(len(head)):
            for n, s in enumerate(socks):
                if n not in closed:
                    try:
                        s.send(head[i:i + 1])
                    except OSError:
                        pass  # its reader says what happened
            if stop.wait(2):
                return

    t0 = time.time()  # every connection is in

    def reader(n, s):
        try:
            s.settimeout(60)
            data = s.recv(200)
        except OSError:
            data = b"(reset)"
        closed.setdefault(n, (time.time() - t0, data[:60]))

    for n, s in enumerate(socks):
        threading.Thread(target=reader, args=(n, s), daemon=True).start()
    threading.Thread(target=trickle, daemon=True).start()
    return socks, closed


def answered_in(server, path, headers, source):
    t0 = time.time()
    try:
        status, text, _ = server.request(path, headers, source=source, timeout=15)
    except (OSError, http.client.HTTPException) as e:
        status, text = None, repr(e)
    return status, time.time() - t0, text


def test_slow_clients_leave_another_students_request_answered(server):
    stop = threading.Event()
    # 100 from an address of the machine, 100 from the front's own (any local user can).
    other, closed_other = slow_connections(server.port, 100, "127.0.0.4", stop)
    front, closed_front = slow_connections(server.port, 100, "127.0.0.1", stop)
    try:
        time.sleep(0.5)  # every connection has sent its first bytes
        status, took, text = answered_in(server, "/s/bob/class/status",
                                         {"X-Sirupp-Token": server.tokens["bob"]}, "127.0.0.2")
        print("100 slow connections from 127.0.0.4 and 100 from 127.0.0.1 (the front's address);"
              " bob directly from 127.0.0.2: %s in %.2f s" % (status, took))
        assert status == 200 and took < 1.0, (status, took, text)
        status, took, text = answered_in(server, "/s/bob/class/status",
                                         server.front("bob", "127.0.0.2"), "127.0.0.1")
        print("bob through the front (from its address 127.0.0.1): %s in %.2f s" % (status, took))
        assert status == 200 and took < 1.0, (status, took, text)
        end = time.time() + 15
        while time.time() < end and (len(closed_other) < 100 or len(closed_front) < 100):
            time.sleep(0.2)
        held = {}
        for name, closed in (("127.0.0.4", closed_other), ("127.0.0.1", closed_front)):
            at_once = [t for t, data in list(closed.values()) if t < 3]
            late = sorted(t for t, data in list(closed.values()) if t >= 3)
            held[name] = len(late)
            print("%s: %d connections closed at once (over the cap: an idle one making room, or "
                  "429), %d held until the request deadline and closed %.1f to %.1f s after "
                  "they were all in"
                  % (name, len(at_once), len(late), late[0] if late else -1,
                     late[-1] if late else -1))
        assert len(closed_other) == 100 and len(closed_front) == 100, \
            "slow connections still open after 15 s"
        assert held["127.0.0.4"] <= 64, "more than connections_per_address held from one address"
    finally:
        stop.set()
        for s in other + front:
            s.close()


def test_an_idle_keep_alive_connection_is_closed(server):
    c = http.client.HTTPConnection("127.0.0.1", server.port, timeout=20,
                                   source_address=("127.0.0.6", 0))
    c.request("GET", "/s/bob/class/status", headers={"X-Sirupp-Token": server.tokens["bob"]})
    r = c.getresponse()
    r.read()
    assert r.status == 200
    t0 = time.time()
    try:
        data = c.sock.recv(10)
    except OSError:
        data = b""
    took = time.time() - t0
    print("an idle keep-alive connection closed by the server after %.1f s" % took)
    assert data == b"" and took < 8, (data, took)
    c.close()


def test_a_good_token_for_another_student_does_not_clear_bad_tokens(server):
    statuses = []
    for i in range(40):
        if i % 5 == 4:
            status, _, _ = server.request("/s/alice/class/status",
                                          {"X-Sirupp-Token": server.tokens["alice"]},
                                          source="127.0.0.3")
        else:
            status, _, _ = server.request("/s/bob/class/status",
                                          {"X-Sirupp-Token": "%048x" % i}, source="127.0.0.3")
        statuses.append(status)
        if status == 429:
            break
    print("wrong guesses at bob's token, alice's good token after every fourth:", statuses)
    assert 429 in statuses, "never locked out"
    # The lock-out still doubles: the next wrong token after it locks for 2 s.
    time.sleep(1.2)
    status, _, _ = server.request("/s/bob/class/status", {"X-Sirupp-Token": "0" * 48},
                                  source="127.0.0.3")
    status, text, headers = server.request("/s/bob/class/status",
                                           {"X-Sirupp-Token": server.tokens["bob"]},
                                           source="127.0.0.3")
    print("after the next wrong one:", status, "Retry-After", headers.get("Retry-After"))
    assert status == 429 and headers.get("Retry-After") == "2", (status, text, headers)


if __name__ == "__main__":
    if len(sys.argv) >= 3:
        os.environ["SIRUPP_BIN_DIR"] = os.path.abspath(sys.argv[1])
        os.environ["SIRUPP_SOURCE_DIR"] = os.path.abspath(sys.argv[2])
    sys.exit(pytest.main(["-v", "-s", "-p", "no:cacheprovider", os.path.abspath(__file__)]))

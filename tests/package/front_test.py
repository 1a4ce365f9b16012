"""The installed class server behind Debian's Apache (docs/install.md "A front"): Apache on
127.0.0.1 in a ServerRoot of this test's own, mod_auth_basic standing in for mod_auth_openidc or
Shibboleth (all three give Apache a REMOTE_USER), mod_headers passing it in X-Remote-User with the
front's secret, mod_proxy_http in front of the class server run as its service user the way its
unit runs it (service_run.py). Checks: two students signed in through Apache reach their own pages
and not each other's; a signed-in name not in the class gets 403 naming it; the teacher's name
opens the teacher's page; a client's own X-Remote-User does not pass Apache; the live stream
arrives through the proxy at the rate it arrives directly; a forged user header sent straight to
the class server is refused, with and without a wrong secret; tokens still work; one student page
loads in headless Chromium through Apache; a name signed in as "%61lice" is not alice; 100 slow
connections to Apache and 100 straight to the class server leave other students answered within a
second (issue 51). Apache and everything it started end at the end, also on failure."""

import base64
import json
import os
import pwd
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import urllib.error
import urllib.request

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from service_run import ServiceRun  # noqa: E402

INSTANCE = "pkgfront"
CLASS_FILE = f"/etc/sirupp/classes/{INSTANCE}.yaml"
SECRET_FILE = f"/etc/sirupp/classes/{INSTANCE}.secret"
DATA = f"/var/lib/sirupp/{INSTANCE}"
MODULES = "/usr/lib/apache2/modules"
PASSWORDS = {"alice": "alice-pw", "bob": "bob-pw", "jsmith": "jsmith-pw", "mallory": "mallory-pw",
             "%61lice": "encoded-pw"}
failures = []


def expect(what, ok, detail=""):
    if not ok:
        failures.append(f"{what}: {detail}")


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def request(url, method="GET", user=None, headers=None, body=None, timeout=30):
    """(status, text) of one request; user signs in at Apache with Basic auth."""
    h = {"X-Sirupp-Client": "front-test"}
    if user:
        h["Authorization"] = "Basic " + base64.b64encode(
            f"{user}:{PASSWORDS[user]}".encode()).decode()
    h.update(headers or {})
    data = json.dumps(body).encode() if body is not None else (b"{}" if method == "POST" else None)
    req = urllib.request.Request(url, data=data, method=method, headers=h)
    try:
        with urllib.request.urlopen(req, timeout=timeout) as r:
            return r.status, r.read().decode(errors="replace")
    except urllib.error.HTTPError as e:
        return e.code, e.read().decode(errors="replace")


def count_events(url, seconds, headers):
    """Server-Sent Events frames received from url in `seconds` (after the first one)."""
    req = urllib.request.Request(url, headers=headers)
    frames = 0
    with urllib.request.urlopen(req, timeout=30) as r:
        start = None
        while True:
            line = r.readline()
            if not line:
                break
            if line.startswith(b"data:"):
                if start is None:
                    start = time.time()
                    continue
                frames += 1
                if time.time() - start >= seconds:
                    break
    return frames


class Apache:
    """apache2 in the foreground with a configuration and ServerRoot of this test's own."""

    def __init__(self, backend):
        self.root = tempfile.mkdtemp(prefix="sirupp-front-apache-")
        os.chmod(self.root, 0o755)
        self.port = free_port()
        self.proc = None
        with open(SECRET_FILE) as f:
            secret = f.read().strip()
        # The secret reaches Apache's configuration through a Define in a file only root reads
        # (Apache reads its configuration as root, before its children become www-data).
        secret_conf = os.path.join(self.root, "front-secret.conf")
        with open(os.open(secret_conf, os.O_WRONLY | os.O_CREAT, 0o600), "w") as f:
            f.write(f"Define SIRUPP_FRONT_SECRET {secret}\n")
        htpasswd = os.path.join(self.root, "htpasswd")
        for i, (user, password) in enumerate(PASSWORDS.items()):
            subprocess.run(["htpasswd", "-b" + ("c" if i == 0 else "") + "B", htpasswd, user,
                            password], check=True, capture_output=True)
        os.chmod(htpasswd, 0o644)
        modules = ["mpm_event", "authz_core", "authn_core", "authn_file", "auth_basic",
                   "authz_user", "headers", "proxy", "proxy_http"]
        self.conf = os.path.join(self.root, "apache2.conf")
        with open(self.conf, "w") as f:
            f.write(f'ServerRoot "{self.root}"\nServerName 127.0.0.1\n'
                    f"Listen 127.0.0.1:{self.port}\n"
                    f'PidFile "{self.root}/apache2.pid"\nDefaultRuntimeDir "{self.root}"\n'
                    f'Mutex file:{self.root} default\n'
                    f'ErrorLog "{self.root}/error.log"\nLogLevel warn\n'
                    'User www-data\nGroup www-data\n'
                    + "".join(f"LoadModule {m}_module {MODULES}/mod_{m}.so\n" for m in modules)
                    + f'Include "{secret_conf}"\n'
                    f"""<Location "/">
  AuthType Basic
  AuthName "University sign-in (test: mod_auth_basic for mod_auth_openidc)"
  AuthBasicProvider file
  AuthUserFile "{htpasswd}"
  Require valid-user
  RequestHeader unset Authorization
  RequestHeader set X-Remote-User "expr=%{{REMOTE_USER}}"
  RequestHeader set X-Sirupp-Front-Secret "${{SIRUPP_FRONT_SECRET}}"
  ProxyPass "{backend}/" flushpackets=on
  ProxyPassReverse "{backend}/"
</Location>
""")
        self.base = f"http://127.0.0.1:{self.port}"

    def start(self):
        check = subprocess.run(["/usr/sbin/apache2", "-f", self.conf, "-t"], capture_output=True,
                               text=True)
        assert check.returncode == 0, "apache2 -t: " + check.stdout + check.stderr
        self.proc = subprocess.Popen(["/usr/sbin/apache2", "-f", self.conf, "-DFOREGROUND"],
                                     stdout=subprocess.DEVNULL, stderr=subprocess.STDOUT)
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
            with open(os.path.join(self.root, "error.log")) as f:
                return f.read()[-3000:]
        except OSError:
            return ""

    def pids(self):
        """Every process started with this test's configuration (the parent and its children)."""
        out = []
        for entry in os.listdir("/proc"):
            if entry.isdigit():
                try:
                    with open(f"/proc/{entry}/cmdline", "rb") as f:
                        if self.conf.encode() in f.read():
                            out.append(int(entry))
                except OSError:
                    pass
        return out

    def stop(self):
        """SIGTERM to the parent (it ends its children), then SIGKILL to whatever is left."""
        if self.proc and self.proc.poll() is None:
            self.proc.send_signal(signal.SIGTERM)
            try:
                self.proc.wait(timeout=15)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        end = time.time() + 5
        while self.pids() and time.time() < end:
            time.sleep(0.1)
        left = self.pids()
        for pid in left:
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass
        shutil.rmtree(self.root, ignore_errors=True)
        return left


def write_class_files():
    group = pwd.getpwnam("sirupp").pw_gid
    with open(SECRET_FILE, "w") as f:
        f.write(secrets.token_hex(32) + "\n")
    with open(CLASS_FILE, "w") as f:
        f.write(f"class: {INSTANCE}\nrobot: config/robots/puma260.yaml\n"
                f"students: [alice, bob]\ndata: {DATA}\n"
                "limits: {max_rigs: 2, idle_timeout_s: 900}\n"
                f"server: {{port: 0, trusted_proxy: 127.0.0.1, "
                f"proxy_secret_file: {os.path.basename(SECRET_FILE)}, proxy_teachers: [jsmith]}}\n"
                "rigs: {first_port: 7680, port_count: 40}\n")
    for path in (CLASS_FILE, SECRET_FILE):
        os.chown(path, 0, group)
        os.chmod(path, 0o640)


def remove_class_files():
    for path in (CLASS_FILE, SECRET_FILE):
        if os.path.exists(path):
            os.remove(path)
    shutil.rmtree(DATA, ignore_errors=True)


def browser_check(apache_base, work):
    """The student page of alice through Apache in headless Chromium: live state arrives."""
    from selenium import webdriver
    from selenium.webdriver.chrome.options import Options
    from selenium.webdriver.chrome.service import Service
    o = Options()
    for a in ("--headless=new", "--no-sandbox", "--enable-unsafe-swiftshader",
              "--window-size=1200,800", "--disable-gpu-sandbox"):
        o.add_argument(a)
    o.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    tmp = os.path.join(work, "chromium")
    os.makedirs(tmp, exist_ok=True)
    d = webdriver.Chrome(service=Service("/usr/bin/chromedriver",
                                         env=dict(os.environ, TMPDIR=tmp)), options=o)
    try:
        # The sign-in for every request of the page (its scripts, API calls, event stream).
        auth = base64.b64encode(f"alice:{PASSWORDS['alice']}".encode()).decode()
        d.execute_cdp_cmd("Network.enable", {})
        d.execute_cdp_cmd("Network.setExtraHTTPHeaders", {"headers": {"Authorization": "Basic " + auth}})
        d.get(apache_base + "/s/alice/")
        end = time.time() + 60
        ready = False
        while time.time() < end and not ready:
            ready = d.execute_script(
                "return !!(window.panelReady && window.panelStats && window.panelStats.received > 5)")
            time.sleep(0.3)
        expect("the page through Apache got its live state", ready,
               d.execute_script("return document.body.innerText.slice(0, 300)"))
        status = d.find_element("id", "class-status").text
        expect("the class bar names alice", "alice" in status, status)
        severe = [e for e in d.get_log("browser") if e["level"] == "SEVERE"]
        expect("no severe console errors", not severe, severe)
    finally:
        d.quit()
        shutil.rmtree(tmp, ignore_errors=True)


def main():
    t0 = time.time()
    for tool in ("/usr/sbin/apache2", "/usr/bin/htpasswd", "/usr/bin/chromedriver"):
        if not os.path.exists(tool):
            print(f"FAIL {tool} is missing (scripts/install-deps.sh installs it)")
            return 1
    remove_class_files()
    write_class_files()
    service = ServiceRun(INSTANCE)
    apache = None
    work = tempfile.mkdtemp(prefix="sirupp-front-test-")
    timings = {}
    try:
        service.start()
        direct = service.base
        apache = Apache(direct).start()
        front = apache.base

        # Signed in through the front: one's own page, not another's.
        status, text = request(front + "/s/alice/class/status", user="alice")
        expect("alice's status through Apache", status == 200 and '"role":"student"' in
               text.replace(" ", ""), f"{status} {text[:200]}")
        status, text = request(front + "/s/bob/class/status", user="alice")
        expect("alice on bob's status", status == 403 and "signed in as 'alice'" in text,
               f"{status} {text[:200]}")
        status, text = request(front + "/s/bob/class/status", user="bob")
        expect("bob's status through Apache", status == 200, f"{status} {text[:200]}")
        status, text = request(front + "/s/alice/", user="bob")
        expect("bob on alice's page", status == 403 and "signed in as 'bob'" in text,
               f"{status} {text[:200]}")
        status, text = request(front + "/s/alice/class/status", user="mallory")
        expect("mallory (not in the class)", status == 403 and "signed in as 'mallory', who is "
               "not in the class" in text, f"{status} {text[:200]}")
        status, text = request(front + "/teacher/api/rigs", user="jsmith")
        expect("the teacher's page for jsmith", status == 200, f"{status} {text[:200]}")
        status, text = request(front + "/teacher/api/rigs", user="alice")
        expect("the teacher's page for alice", status == 403, f"{status} {text[:200]}")
        status, _ = request(front + "/s/alice/class/status")
        expect("no sign-in at Apache", status == 401, status)
        # A client's own user header does not pass the front.
        status, text = request(front + "/s/bob/class/status", user="alice",
                               headers={"X-Remote-User": "bob"})
        expect("alice claiming to be bob through Apache", status == 403 and
               "signed in as 'alice'" in text, f"{status} {text[:200]}")

        # Straight to the class server, from this machine (the front's own address): refused.
        status, text = request(direct + "/s/alice/class/status", headers={"X-Remote-User": "alice"})
        expect("a forged user header straight to the class server", status == 403 and
               "without the front's secret" in text, f"{status} {text[:200]}")
        status, text = request(direct + "/s/alice/class/status",
                               headers={"X-Remote-User": "alice",
                                        "X-Sirupp-Front-Secret": "0" * 64})
        expect("a forged user header with a guessed secret", status == 403 and
               "does not match" in text, f"{status} {text[:200]}")
        expect("the server logs the refusal", "refused a request from 127.0.0.1" in service.log(),
               service.log()[-500:])
        # A name signed in at the front is taken as sent: "%61lice" is not alice (issue 51).
        status, text = request(front + "/s/alice/class/status", user="%61lice")
        expect("%61lice signed in at Apache, on alice's page", status == 403 and
               "'%61lice'" in text, f"{status} {text[:200]}")
        # Slow clients (issue 51): 100 connections to Apache and 100 straight to the class server
        # from the front's own address, each sending a byte every 2 s; bob through Apache and
        # alice straight to the class server are still answered within a second.
        stop_slow = threading.Event()
        slow = []

        def trickle(port, count):
            socks = []
            for _ in range(count):
                sock = socket.create_connection(("127.0.0.1", port), timeout=10)
                socks.append(sock)
                slow.append(sock)
            head = b"GET /s/bob/class/status HTTP/1.1\r\nHost: x\r\nX-Pad: " + b"a" * 200
            for i in range(len(head)):
                for sock in socks:
                    try:
                        sock.send(head[i:i + 1])
                    except OSError:
                        pass
                if stop_slow.wait(2):
                    return
        slow_threads = [threading.Thread(target=trickle, args=(int(url.rsplit(":", 1)[1]), 100),
                                         daemon=True) for url in (front, direct)]
        for t in slow_threads:
            t.start()
        try:
            time.sleep(3)
            t0 = time.time()
            status, text = request(front + "/s/bob/class/status", user="bob", timeout=15)
            took_front = time.time() - t0
            t0 = time.time()
            status_direct, _ = request(direct + "/s/alice/class/status", timeout=15,
                                       headers={"X-Sirupp-Token": service.token("alice")})
            took_direct = time.time() - t0
        finally:
            stop_slow.set()
            for sock in slow:
                sock.close()
        timings["bob through Apache beside 200 slow connections s"] = round(took_front, 3)
        timings["alice direct beside them s"] = round(took_direct, 3)
        expect("bob through Apache beside 200 slow connections", status == 200 and
               took_front < 1.0, f"{status} in {took_front:.2f} s: {text[:200]}")
        expect("alice straight to the class server beside them", status_direct == 200 and
               took_direct < 1.0, f"{status_direct} in {took_direct:.2f} s")
        # Tokens still work beside the front.
        status, _ = request(direct + "/s/alice/class/status",
                            headers={"X-Sirupp-Token": service.token("alice")})
        expect("alice's token straight to the class server", status == 200, status)

        # The live stream through the proxy, at the rate it has straight from the server.
        status, text = request(front + "/s/alice/class/start", "POST", user="alice")
        expect("alice starts her rig through Apache", status == 200, f"{status} {text[:200]}")
        end = time.time() + 60
        while time.time() < end:
            if '"running"' in request(front + "/s/alice/class/status", user="alice")[1]:
                break
            time.sleep(0.5)
        auth = {"Authorization": "Basic " + base64.b64encode(b"alice:alice-pw").decode()}
        rates = {}

        def measure(name, url, headers):
            try:
                rates[name] = count_events(url, 3.0, headers) / 3.0
            except Exception as e:  # noqa: BLE001 - reported below
                rates[name] = f"{type(e).__name__}: {e}"
        threads = [threading.Thread(target=measure, args=(
                       "front", front + "/s/alice/api/events?hz=20", auth)),
                   threading.Thread(target=measure, args=(
                       "direct", direct + "/s/alice/api/events?hz=20",
                       {"X-Sirupp-Token": service.token("alice")}))]
        for t in threads:
            t.start()
        for t in threads:
            t.join(60)
        timings["events/s through Apache"] = rates.get("front")
        timings["events/s direct"] = rates.get("direct")
        ok = all(isinstance(rates.get(k), float) for k in ("front", "direct"))
        expect("the live stream through Apache at its rate",
               ok and rates["direct"] >= 5 and rates["front"] >= 0.8 * rates["direct"], rates)

        t1 = time.time()
        browser_check(front, work)
        timings["browser s"] = round(time.time() - t1, 1)
    except Exception as e:  # noqa: BLE001 - reported with the logs below
        failures.append(f"{type(e).__name__}: {e}")
    finally:
        if apache:
            left = apache.stop()
            expect("apache2 ended with everything it started", not left, left)
            if failures:
                print("apache error log:\n" + apache.error_log())
        left = service.stop()
        expect("nothing of the service user left", not left, left)
        log = service.log() if service.log_path else ""
        if service.log_path:
            os.remove(service.log_path)
        remove_class_files()
        shutil.rmtree(work, ignore_errors=True)
    if failures:
        print("class server log:\n" + log[-3000:])
        for f in failures:
            print("FAIL " + f)
        return 1
    print(f"ok front: Apache in front, {timings}, {time.time() - t0:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())

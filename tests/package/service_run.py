"""The installed package's class server run the way its systemd unit runs it, on a machine without
systemd as PID 1 (CI): the unit file /usr/lib/systemd/system/sirupp-class@.service is read, and
each of its [Service] settings is either carried out here or named in NOT_EMULATED; a setting this
file does not know fails the test, so the unit and this emulation cannot drift apart.

Carried out: User/Group (setpriv, with the user's groups), NoNewPrivileges (setpriv
--no-new-privs), UMask, StateDirectory/StateDirectoryMode (folders made for the user),
WorkingDirectory, ExecStart, PrivateTmp (a fresh /tmp and /var/tmp), ProtectSystem=full (/usr,
/boot, /efi and /etc read-only), ProtectHome=yes (/home, /root, /run/user empty and read-only),
KillSignal and TimeoutStopSec (stop()), and KillMode=control-group checked in stop(): once the
server ended, no process of the service user may be left."""

import configparser
import os
import pwd
import re
import shlex
import signal
import subprocess
import tempfile
import time

UNIT = "/usr/lib/systemd/system/sirupp-class@.service"

EMULATED = {"Type", "User", "Group", "StateDirectory", "StateDirectoryMode", "WorkingDirectory",
            "ExecStart", "UMask", "KillMode", "KillSignal", "TimeoutStopSec", "NoNewPrivileges",
            "ProtectSystem", "ProtectHome", "PrivateTmp"}
# Only systemd can give these (cgroups, restarts, kernel-level protections); systemd-analyze
# verify checks their syntax (tests/package/install.sh).
NOT_EMULATED = {"Restart", "RestartSec", "CPUQuota", "MemoryMax", "TasksMax",
                "ProtectKernelModules", "ProtectClock", "ProtectHostname", "RestrictRealtime",
                "LockPersonality"}


def read_unit(instance):
    """The [Service] settings of the installed unit with %i replaced by instance."""
    parser = configparser.ConfigParser(interpolation=None, strict=False, delimiters=("=",))
    parser.optionxform = str
    with open(UNIT) as f:
        parser.read_string(f.read())
    service = {k: v.replace("%i", instance) for k, v in parser["Service"].items()}
    unknown = set(service) - EMULATED - NOT_EMULATED
    assert not unknown, f"{UNIT}: settings this test does not emulate: {sorted(unknown)}"
    assert service["Type"] == "simple", service["Type"]
    assert service["KillMode"] == "control-group", service["KillMode"]
    assert service["ProtectSystem"] == "full" and service["ProtectHome"] == "yes"
    assert service["PrivateTmp"] == "yes" and service["NoNewPrivileges"] == "yes"
    return service


def seconds(text):
    m = re.fullmatch(r"(\d+)s?", text.strip())
    assert m, f"a time this test reads: '{text}'"
    return int(m.group(1))


class ServiceRun:
    """sirupp-class@INSTANCE as the unit starts it; stop() ends it as systemd would."""

    def __init__(self, instance):
        self.instance = instance
        self.unit = read_unit(instance)
        self.user = self.unit["User"]
        self.proc = None
        self.addresses = {}
        self.base = None
        self.log_path = None

    def start(self, timeout=60):
        u = self.unit
        entry = pwd.getpwnam(self.user)
        mode = int(u.get("StateDirectoryMode", "0755"), 8)
        for state in u.get("StateDirectory", "").split():
            path = "/var/lib/" + state
            os.makedirs(path, exist_ok=True)
            os.chown(path, entry.pw_uid, entry.pw_gid)
            os.chmod(path, mode)
        # The mount namespace: what PrivateTmp, ProtectSystem=full and ProtectHome=yes make.
        mounts = ["mount -t tmpfs -o mode=1777 sirupp-tmp /tmp",
                  "mount -t tmpfs -o mode=1777 sirupp-var-tmp /var/tmp"]
        for path in ("/usr", "/boot", "/efi", "/etc"):
            mounts.append(f"if [ -d {path} ]; then mount --bind {path} {path} && "
                          f"mount -o remount,bind,ro {path}; fi")
        for path in ("/home", "/root", "/run/user"):
            mounts.append(f"if [ -d {path} ]; then mount -t tmpfs -o ro,mode=0755 none {path}; fi")
        inner = (f"umask {u['UMask']} && cd {shlex.quote(u['WorkingDirectory'])} && "
                 f"exec {u['ExecStart']}")
        setpriv = ["setpriv", "--reuid", self.user, "--regid", u.get("Group", self.user),
                   "--init-groups", "--no-new-privs", "--", "/bin/sh", "-c", inner]
        script = " && ".join(mounts) + " && exec " + " ".join(shlex.quote(a) for a in setpriv)
        log = tempfile.NamedTemporaryFile(prefix="sirupp-service-", suffix=".log", delete=False)
        self.log_path = log.name
        # unshare, sh, setpriv and sh each exec the next: the pid is the class server's.
        self.proc = subprocess.Popen(
            ["unshare", "--mount", "--propagation", "private", "--", "/bin/sh", "-c", script],
            stdout=subprocess.PIPE, stderr=log, text=True, env={"PATH": "/usr/bin:/bin",
                                                                 "LANG": "C.UTF-8"})
        end = time.time() + timeout
        while time.time() < end:
            line = self.proc.stdout.readline()
            if not line:
                raise AssertionError("the class server ended: " + self.log())
            m = re.match(r"new token: ([^,]+),(\S+)", line)
            if m:
                self.addresses[m.group(1)] = m.group(2)
            m = re.match(r"sirupp class: \S+ at (https?://\S+?)/ ", line)
            if m:
                self.base = m.group(1)
                return self
        raise AssertionError("the class server printed no address: " + self.log())

    def token(self, name):
        return self.addresses[name].split("token=")[1]

    def log(self):
        with open(self.log_path) as f:
            return f.read()

    def user_pids(self):
        uid = pwd.getpwnam(self.user).pw_uid
        out = []
        for entry in os.listdir("/proc"):
            if entry.isdigit():
                try:
                    if os.stat("/proc/" + entry).st_uid == uid:
                        with open(f"/proc/{entry}/stat") as f:
                            if f.read().rsplit(")", 1)[1].split()[0] != "Z":
                                out.append(int(entry))
                except OSError:
                    pass
        return out

    def stop(self):
        """KillSignal to the server, then, as KillMode=control-group would, whatever of the service
        user is left after TimeoutStopSec gets SIGKILL. Returns the pids that were left (to fail
        the test on) once the server had ended."""
        if self.proc is None:
            return []
        if self.proc.poll() is None:
            self.proc.send_signal(getattr(signal, self.unit.get("KillSignal", "SIGTERM")))
            try:
                self.proc.wait(timeout=seconds(self.unit.get("TimeoutStopSec", "90")))
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        left = []
        end = time.time() + 5  # PR_SET_PDEATHSIG reaches the rigs' processes at once
        while time.time() < end:
            left = self.user_pids()
            if not left:
                break
            time.sleep(0.2)
        for pid in left:
            try:
                os.kill(pid, signal.SIGKILL)
            except OSError:
                pass
        self.proc = None
        return left

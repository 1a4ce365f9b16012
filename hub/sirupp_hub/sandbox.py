"""The notebook sandbox's command line: the project's sandbox family (docs/sandbox.md) for a
student's notebook server and its kernels (docs/notebooks.md "The sandbox").

Two stages, because inside a user namespace a process either may change routes (uid 0 with
CAP_NET_ADMIN) or may nest further sandboxes (uid not 0), not both:

1. `unshare --user --map-root-user --net --pid --fork --kill-child --mount --mount-proc`: a new
   network namespace with only `lo`, brought up with the multicast route (`ip route add
   224.0.0.0/4 dev lo`) so that LCM's udpm with ttl=0 works inside, and nothing reaches the
   host's network or its buses; a pid namespace of its own with a fresh /proc (ended whole when
   unshare ends);
2. `bwrap` as uid 1000 in a further user namespace with its own ipc and uts namespaces, no
   capabilities: /usr read-only (and the dynamic linker's cache), stage 1's /proc (bwrap's own
   --proc would cover parts of it, and a sandbox nested inside could then mount no /proc), the
   student's folder as HOME, one run folder for the sockets, the project's programs read-only, a
   private /tmp.

Limits (set on stage 1, inherited by every process inside): address space (memory_mb), processes,
CPU seconds, file size; niceness 5 like the class's rigs.
"""

import os
import resource

INSIDE_UID = 1000
INSIDE_HOME = "/home/student"
INSIDE_RUN = "/run/sirupp"
CPU_SECONDS = 4 * 3600  # per process: a kernel running for a whole lab
FILE_MB = 1024          # the largest file a student's process may write


def bwrap_arguments(home, run_dir, etc_dir, read_only, command):
    """bwrap's arguments for `command` (a list) with the student's `home`, the sockets' `run_dir`,
    the made-up /etc files in `etc_dir` (passwd, group) and the project's `read_only` folders."""
    args = ["/usr/bin/bwrap",
            "--unshare-user", "--uid", str(INSIDE_UID), "--gid", str(INSIDE_UID),
            "--unshare-ipc", "--unshare-uts",
            "--die-with-parent", "--new-session", "--cap-drop", "ALL",
            "--ro-bind", "/usr", "/usr",
            "--symlink", "usr/bin", "/bin", "--symlink", "usr/sbin", "/sbin",
            "--symlink", "usr/lib", "/lib", "--symlink", "usr/lib64", "/lib64",
            # Stage 1's /proc (its own pid namespace, no mount over it): a fresh --proc here would
            # cover parts of it, and a sandbox nested inside could then mount no /proc of its own.
            "--bind", "/proc", "/proc", "--dev", "/dev", "--tmpfs", "/tmp"]
    # What programs under /usr need of /etc: the linker's cache, Debian's alternatives, fonts,
    # the time zone, matplotlib's settings (Debian keeps them there).
    for name in ("ld.so.cache", "alternatives", "fonts", "localtime", "matplotlibrc"):
        path = os.path.join("/etc", name)
        if os.path.exists(path):
            args += ["--ro-bind", path, path]
    for name in ("passwd", "group"):
        args += ["--ro-bind", os.path.join(etc_dir, name), os.path.join("/etc", name)]
    for folder in read_only:
        args += ["--ro-bind", folder, folder]
    args += ["--bind", home, INSIDE_HOME, "--bind", run_dir, INSIDE_RUN,
             "--chdir", INSIDE_HOME, "--clearenv"]
    return args + ["--"] + list(command)


def full_command(bwrap_args):
    """Stage 1 around stage 2: the network namespace with `lo` and the multicast route."""
    setup = ("ip link set lo up && ip route add 224.0.0.0/4 dev lo && exec \"$@\"")
    return ["/usr/bin/unshare", "--user", "--map-root-user", "--net", "--pid", "--fork",
            "--kill-child", "--mount", "--mount-proc", "--",
            "/bin/sh", "-c", setup, "sirupp-notebook-sandbox"] + list(bwrap_args)


def write_etc(etc_dir, name):
    """passwd and group for the inside uid (Python and Jupyter look the user up)."""
    os.makedirs(etc_dir, exist_ok=True)
    with open(os.path.join(etc_dir, "passwd"), "w", encoding="utf-8") as out:
        out.write(f"{name}:x:{INSIDE_UID}:{INSIDE_UID}::{INSIDE_HOME}:/bin/sh\n"
                  "nobody:x:65534:65534::/nonexistent:/usr/sbin/nologin\n")
    with open(os.path.join(etc_dir, "group"), "w", encoding="utf-8") as out:
        out.write(f"{name}:x:{INSIDE_UID}:\nnogroup:x:65534:\n")


def limit_process(memory_mb, processes):
    """A preexec_fn: the sandbox's limits and niceness, set in the child before stage 1."""

    def apply():
        if memory_mb > 0:
            size = memory_mb * 1024 * 1024
            resource.setrlimit(resource.RLIMIT_AS, (size, size))
        if processes > 0:
            resource.setrlimit(resource.RLIMIT_NPROC, (processes, processes))
        resource.setrlimit(resource.RLIMIT_CPU, (CPU_SECONDS, CPU_SECONDS))
        size = FILE_MB * 1024 * 1024
        resource.setrlimit(resource.RLIMIT_FSIZE, (size, size))
        os.nice(5)

    return apply

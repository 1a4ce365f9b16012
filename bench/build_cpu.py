#!/usr/bin/python3
"""Where a clean build's CPU goes: every compile and link step's CPU seconds (user + system of
the compiler and what it ran), by folder, the ten costliest steps, and the total, for one or two
revisions of the tree built in the same run (no ccache), so an improvement is a ratio measured on
the same machine at the same time.

    bench/build_cpu.py                              # the working tree, every target
    bench/build_cpu.py --base 7ace7a9               # also that commit, and the ratio
    bench/build_cpu.py --target sirupp sirupp-sim   # only these targets (names as in CMake)

CPU seconds, not wall time: a step's CPU changes little when other work shares the machine, so a
figure taken beside other builds still compares (the wall time printed beside it does not).
Each revision is built from a copy in a temporary folder (`git archive`; the working tree with
its uncommitted changes for the default), with CMake's defaults as scripts/build.sh uses them.
"""
import argparse
import collections
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def launcher_main(argv):
    """The compiler/linker launcher: runs the step, appends "cpu_s<TAB>output" to the log."""
    log, command = argv[0], argv[1:]
    result = subprocess.run(command)
    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    output = command[command.index("-o") + 1] if "-o" in command else command[-1]
    with open(log, "a") as out:
        out.write("%.3f\t%s\n" % (usage.ru_utime + usage.ru_stime, output))
    return result.returncode


def copy_tree(revision, into):
    if revision is None:  # the working tree as it is, uncommitted changes included
        files = subprocess.run(["git", "-C", ROOT, "ls-files", "-co", "--exclude-standard", "-z"],
                               check=True, capture_output=True).stdout.split(b"\0")
        for name in filter(None, (f.decode() for f in files)):
            source = os.path.join(ROOT, name)
            if not os.path.isfile(source):
                continue  # deleted but not yet committed
            os.makedirs(os.path.dirname(os.path.join(into, name)), exist_ok=True)
            shutil.copy2(source, os.path.join(into, name))
        return
    archive = subprocess.run(["git", "-C", ROOT, "archive", revision], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", into], input=archive, check=True)


def folder_of(output):
    """The source folder a step belongs to: core/CMakeFiles/x.dir/a.cpp.o -> core."""
    parts = output.split("/")
    if "CMakeFiles" in parts:
        return "/".join(parts[:parts.index("CMakeFiles")]) or "(top)"
    return parts[0] if len(parts) > 1 else "(links in bin/, lib/)"


def build(revision, target, jobs, keep):
    label = revision or "working tree"
    work = tempfile.mkdtemp(prefix="sirupp-build-cpu-")
    try:
        source, binary, log = (os.path.join(work, n) for n in ("src", "build", "steps.tsv"))
        os.makedirs(source)
        copy_tree(revision, source)
        launcher = "/usr/bin/python3;%s;--launch;%s" % (os.path.abspath(__file__), log)
        configure = ["cmake", "-S", source, "-B", binary, "-G", "Ninja", "-DSIRUPP_CCACHE=OFF",
                     "-DCMAKE_C_COMPILER_LAUNCHER=" + launcher,
                     "-DCMAKE_CXX_COMPILER_LAUNCHER=" + launcher,
                     "-DCMAKE_CXX_LINKER_LAUNCHER=" + launcher]
        subprocess.run(configure, check=True, stdout=subprocess.DEVNULL)
        start = time.monotonic()
        command = ["cmake", "--build", binary, "-j", str(jobs)]
        if target:
            command += ["--target"] + target
        done = subprocess.run(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
        wall = time.monotonic() - start
        if done.returncode != 0:
            sys.stderr.write(done.stdout[-4000:])
            raise SystemExit("build_cpu: the build of %s failed" % label)
        steps = []
        with open(log) as lines:
            for line in lines:
                cpu, output = line.rstrip("\n").split("\t", 1)
                steps.append((float(cpu), os.path.relpath(output, binary)
                              if os.path.isabs(output) else output))
        return {"label": label, "wall": wall, "steps": steps}
    finally:
        if keep:
            print("build_cpu: kept %s" % work)
        else:
            shutil.rmtree(work, ignore_errors=True)


def report(result):
    steps = result["steps"]
    total = sum(cpu for cpu, _ in steps)
    print("== %s: %d steps, %.0f s of CPU, %.0f s wall (load average now %s)" % (
        result["label"], len(steps), total, result["wall"], open("/proc/loadavg").read().split()[0]))
    by_folder = collections.Counter()
    for cpu, output in steps:
        by_folder[folder_of(output)] += cpu
    print("   by folder: " + ", ".join("%s %.0f" % item for item in by_folder.most_common(12)))
    print("   the ten costliest steps (CPU s):")
    for cpu, output in sorted(steps, reverse=True)[:10]:
        print("   %7.1f  %s" % (cpu, output))
    return total


def main():
    if len(sys.argv) > 1 and sys.argv[1] == "--launch":
        return launcher_main(sys.argv[2:])
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--base", help="a commit to build too, for the ratio (e.g. main~3)")
    parser.add_argument("--target", nargs="+", help="build only these targets (default: all)")
    parser.add_argument("-j", "--jobs", type=int, default=os.cpu_count() or 2)
    parser.add_argument("--keep", action="store_true", help="keep the temporary build folders")
    options = parser.parse_args()
    if options.jobs < 1:
        parser.error("--jobs %d: expected 1 or more" % options.jobs)
    totals = []
    for revision in ([options.base] if options.base else []) + [None]:
        totals.append(report(build(revision, options.target, options.jobs, options.keep)))
    if len(totals) == 2:
        print("build_cpu: the working tree takes %.2f of %s's CPU (%.0f s against %.0f s)" % (
            totals[1] / totals[0], options.base, totals[1], totals[0]))
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/python3
"""README.md and docs/README.md name only what exists (the docs index test's idea, extended).

Checked, each failure naming the file and line:
  - every relative link names a file or folder that exists;
  - every path in backticks (`config/robots/puma260.yaml`, `scripts/test.sh`, `build/bin/sirupp`)
    exists in the source tree, or for build/bin/... and build/python/... in the build tree;
  - every command shown (`sirupp ...`, `build/bin/sirupp ...`, `build/bin/sirupp-NAME ...`,
    `scripts/NAME.sh ...`) exists: `sirupp A B` is a command (and subcommand) of `sirupp help`,
    a program is in the build's bin/, a script is in scripts/;
  - every --flag on such a command is one its --help (for a script: its text) names.
Placeholders in capitals (NAME, FILE, N) and paths under results/ or a user's folder are not
looked up. Needs $SIRUPP (the sirupp program) and $BIN (the folder of the sirupp-* programs).
Run by CTest from the source root.
"""
import os
import re
import subprocess
import sys

FILES = ("README.md", "docs/README.md")
BIN = os.environ["BIN"]
SIRUPP = os.environ["SIRUPP"]
BUILD = os.path.dirname(BIN)
failures = []
checked = {"links": 0, "paths": 0, "commands": 0, "flags": 0}
_help_cache = {}


def fail(where, text):
    failures.append("%s: %s" % (where, text))


def run_help(command):
    """(exit code, help text) of COMMAND --help, cached."""
    key = tuple(command)
    if key not in _help_cache:
        done = subprocess.run(list(command) + ["--help"], capture_output=True, text=True,
                              stdin=subprocess.DEVNULL, timeout=60)
        _help_cache[key] = (done.returncode, done.stdout + done.stderr)
    return _help_cache[key]


def subcommands(help_text):
    names, on = [], False
    for line in help_text.splitlines():
        if line.startswith("Commands:"):
            on = True
        elif on and re.match(r"^  [a-z]", line):
            names.append(line.split()[0])
        elif on and not line.strip():
            on = False
    return names


def placeholder(word):
    return bool(re.search(r"[A-Z]{2,}|\bN\b|\.\.\.|[*?<>{}]|YYYY", word))


# What running a command makes (a package, a recording, a results folder's files): not looked up.
OUTPUTS = (".deb", ".lcmlog", ".csv", ".png", ".avi", ".jpg", ".lcm", ".so")


def check_path(where, path, bases=()):
    """PATH exists from the source root, from the page's folder, or from a folder the same line
    names (`robots/` on the config/ row is config/robots); a module may omit .hpp/.cpp."""
    path = path.rstrip("/")
    if placeholder(path) or path.startswith(("results/", "runs/", "~", "$", "/")) or not path:
        return
    if path.endswith(OUTPUTS):
        return
    if path.startswith("build/"):
        rest = path[len("build/"):]
        if not rest.startswith(("bin/", "python/")):
            return  # other build outputs (packages, jars) are made by commands the tests do not run
        candidates = [os.path.join(BUILD, rest)]
    else:
        candidates = [os.path.join(base, path) for base in ("",) + tuple(bases)]
    checked["paths"] += 1
    for candidate in candidates:
        if any(os.path.exists(candidate + suffix) for suffix in ("", ".hpp", ".cpp")):
            return
    fail(where, "`%s` does not exist (looked in: %s)" % (
        path, ", ".join(os.path.dirname(c) or "." for c in candidates)))


def check_flags(where, shown, flags, text, what):
    for flag in flags:
        checked["flags"] += 1
        if not re.search(r"(?<![\w-])%s(?![\w-])" % re.escape(flag), text):
            fail(where, "`%s`: %s names no flag %s" % (shown, what, flag))


def check_command(where, line):
    """A command line as the reader would type it."""
    words = line.split()
    if not words:
        return
    first = words[0]
    flags = [w.split("=")[0] for w in words[1:] if w.startswith("--") and len(w) > 2]
    if first in ("sirupp", "build/bin/sirupp"):
        checked["commands"] += 1
        path = []
        for word in words[1:]:
            if not re.fullmatch(r"[a-z][a-z0-9-]*", word):
                break
            code, text = run_help([SIRUPP] + path)
            names = subcommands(text)
            if word not in names:
                if not path:
                    if word != "help":
                        fail(where, "`%s`: sirupp has no command '%s' (it has: %s)" % (
                            line, word, ", ".join(names)))
                    return
                if names:  # a group: the word must be one of its subcommands
                    fail(where, "`%s`: sirupp %s has no subcommand '%s' (it has: %s)" % (
                        line, " ".join(path), word, ", ".join(names)))
                    return
                break  # a positional argument of a command
            path.append(word)
        if path and path[0] == "panel":
            code, text = run_help([os.path.join(BIN, "sirupp-panel")])
        else:
            code, text = run_help([SIRUPP] + path)
        if code != 0:
            fail(where, "`%s`: sirupp %s --help exits %d" % (line, " ".join(path), code))
            return
        check_flags(where, line, flags, text, "sirupp " + " ".join(path))
    elif re.fullmatch(r"(build/bin/)?sirupp-[a-z-]+", first):
        checked["commands"] += 1
        program = os.path.join(BIN, os.path.basename(first))
        if not os.path.exists(program):
            fail(where, "`%s`: there is no program %s" % (line, program))
            return
        code, text = run_help([program])
        check_flags(where, line, flags, text, os.path.basename(first))
    elif re.fullmatch(r"scripts/[\w-]+\.(sh|py)", first):
        checked["commands"] += 1
        if not os.path.exists(first):
            fail(where, "`%s`: there is no script %s" % (line, first))
            return
        check_flags(where, line, flags, open(first).read(), first)


def strip_shell(line):
    """The command part of a shell line: no comment, no leading variable settings, no '&'."""
    line = re.sub(r"\s#.*$", "", line).strip().rstrip("&").strip()
    line = re.sub(r"^(sudo\s+)?((\w+=\S*)\s+)*", "", line)
    return line.split("&&")[0].split("|")[0].strip()


def check_file(name):
    text = open(name).read()
    base = os.path.dirname(name)
    in_block = False
    for number, line in enumerate(text.splitlines(), 1):
        where = "%s:%d" % (name, number)
        if line.startswith("```"):
            in_block = not in_block
            continue
        if in_block:
            check_command(where, strip_shell(line))
            for word in strip_shell(line).split():
                if "/" in word and re.fullmatch(r"[\w./-]+", word) and not word.startswith("-"):
                    check_path(where, word)
            continue
        for target in re.findall(r"\]\(([^)\s]+)\)", line):
            if re.match(r"[a-z]+:", target) or target.startswith("#"):
                continue
            checked["links"] += 1
            path = os.path.normpath(os.path.join(base, target.split("#")[0]))
            if not os.path.exists(path):
                fail(where, "links %s, which does not exist" % target)
        # Folders the line names (a link to folder/README.md, `folder/`): bases for its paths.
        links = [t for t in re.findall(r"\]\(([\w./-]+)\)", line) if not re.match(r"[a-z]+:", t)]
        bases = [base] + [os.path.dirname(t) for t in links] + [t.split("/")[0] for t in links]
        bases += [d.rstrip("/") for d in re.findall(r"`([\w./-]+/)`", line)
                  if os.path.isdir(d.rstrip("/"))]
        for span in re.findall(r"`([^`]+)`", line):
            command = strip_shell(span)
            check_command(where, command)
            if re.fullmatch(r"[\w./-]+", span) and ("/" in span or re.search(
                    r"\.(md|yaml|xml|plan|py|sh|cpp|hpp|h|lcm|txt|json)$", span)):
                if not span.startswith("-") and not re.fullmatch(r"\.?\w+", span):
                    check_path(where, span, [b for b in bases if b])


for name in FILES:
    check_file(name)
for failure in failures:
    print("FAIL " + failure)
summary = ", ".join("%d %s" % (count, kind) for kind, count in checked.items())
if failures:
    print("readme_names: FAILED (%d problems; checked %s)" % (len(failures), summary))
    sys.exit(1)
print("readme_names: all checks passed (%s in %s)" % (summary, " and ".join(FILES)))

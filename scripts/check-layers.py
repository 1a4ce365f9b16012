#!/usr/bin/python3
"""Checks every #include "folder/..." in the tree against the layer table in docs/developing.md.

Usage: scripts/check-layers.py [ROOT]   (ROOT: the project root, default: this script's parent's)

The table sits between <!-- layers:begin --> and <!-- layers:end -->, one row per top-level folder:
| `folder/` | what it is | may use |, where "may use" is "nothing", a comma-separated list of
folders, "every library folder above" (the rows above this one) or "every folder". A folder may
always include its own headers; generated messages (<sirupp/...>) are open to all.

Prints one line per include that goes against the table (file:line: the include, what the folder
may use) and one per folder with a CMakeLists.txt that the table lacks; exit 1 if any, else 0 with a
summary line.
"""
import os
import re
import sys

SOURCE_SUFFIXES = (".cpp", ".hpp", ".h", ".cc")
INCLUDE = re.compile(r'^\s*#\s*include\s+"([A-Za-z0-9_]+)/')


def read_table(doc_path):
    with open(doc_path, encoding="utf-8") as f:
        lines = f.read().splitlines()
    try:
        begin = next(i for i, l in enumerate(lines) if "<!-- layers:begin -->" in l)
        end = next(i for i, l in enumerate(lines) if "<!-- layers:end -->" in l)
    except StopIteration:
        raise SystemExit(f"{doc_path}: no <!-- layers:begin --> ... <!-- layers:end --> table")
    order, rules = [], {}
    for number in range(begin + 1, end):
        cells = [c.strip() for c in lines[number].strip().strip("|").split("|")]
        if len(cells) != 3 or not cells[0].startswith("`"):
            continue  # the header and the separator row
        folder = cells[0].strip("`").rstrip("/")
        allowed = cells[2]
        where = f"{doc_path}:{number + 1}"
        if allowed == "nothing":
            rules[folder] = set()
        elif allowed == "every folder":
            rules[folder] = None  # anything
        elif allowed == "every library folder above":
            rules[folder] = set(order)
        else:
            names = {n.strip().strip("`").rstrip("/") for n in allowed.split(",")}
            unknown = sorted(n for n in names if n not in order)
            if unknown:
                raise SystemExit(f"{where}: {folder} may use {', '.join(unknown)}, which is not a "
                                 "row above it (a layer uses only the layers above it)")
            rules[folder] = names
        order.append(folder)
    return order, rules


def main():
    root = os.path.abspath(sys.argv[1] if len(sys.argv) > 1 else
                           os.path.join(os.path.dirname(__file__), ".."))
    doc = os.path.join(root, "docs", "developing.md")
    order, rules = read_table(doc)
    problems = []
    folders = sorted(d for d in os.listdir(root)
                     if os.path.isfile(os.path.join(root, d, "CMakeLists.txt")))
    for folder in folders:
        if folder not in rules:
            problems.append(f"{folder}/: not in the layer table of docs/developing.md "
                            "(add a row saying what it may use)")
    checked = 0
    for folder in folders:
        allowed = rules.get(folder, set())
        for dirpath, dirnames, filenames in os.walk(os.path.join(root, folder)):
            dirnames[:] = sorted(d for d in dirnames if d not in ("__pycache__", "node_modules"))
            for name in sorted(filenames):
                if not name.endswith(SOURCE_SUFFIXES):
                    continue
                path = os.path.join(dirpath, name)
                with open(path, encoding="utf-8", errors="replace") as f:
                    for number, line in enumerate(f, 1):
                        match = INCLUDE.match(line)
                        if not match:
                            continue
                        checked += 1
                        target = match.group(1)
                        if target == folder or allowed is None or target in allowed:
                            continue
                        if target not in rules and not os.path.isdir(os.path.join(root, target)):
                            continue  # not a folder of ours (a third-party "x/y.h")
                        may = ", ".join(sorted(allowed)) if allowed else "nothing"
                        problems.append(
                            f"{os.path.relpath(path, root)}:{number}: includes \"{target}/...\"; "
                            f"{folder}/ may use only: {may} (docs/developing.md, layer table)")
    for problem in problems:
        print(problem)
    if problems:
        print(f"check-layers: {len(problems)} problem(s)")
        return 1
    print(f"check-layers: {checked} includes in {len(folders)} folders follow the table of "
          f"{len(order)} rows")
    return 0


if __name__ == "__main__":
    sys.exit(main())

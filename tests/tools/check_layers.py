#!/usr/bin/env python3
"""Checks that the code's layers include only their own layer or layers below (docs/ARCHITECTURE.md).

Exit 0 when every #include "..." of a non-test source file points to its own layer or one below;
else prints each include that runs back up (file:line: include) and exits 1.
Test files (*_test.cc, tests/, */tests/, fuzz/) may include any layer.
"""
import os
import re
import sys

# From the bottom up; folders on one line form one layer.
LAYERS = [
    ["core/base"],
    ["core/io", "core/eval"],
    ["core/place"],
    ["core/slam", "core/dynamic"],
    ["core/system"],
    ["core/config"],
    ["mapping"],
    ["run"],
    ["idl", "components"],
    ["bridge"],
    ["tools"],
    ["apps"],
]


def layer_of(path):
    best = None
    for rank, folders in enumerate(LAYERS):
        for folder in folders:
            if path == folder or path.startswith(folder + "/"):
                if best is None or len(folder) > best[1]:
                    best = (rank, len(folder))
    return None if best is None else best[0]


def is_test(path):
    name = os.path.basename(path)
    return (name.endswith("_test.cc") or name.endswith("_benchmark.cc") or "/tests/" in "/" + path
            or path.startswith("fuzz/") or "/testing/" in "/" + path)


def main():
    root = sys.argv[1] if len(sys.argv) > 1 else "."
    include = re.compile(r'^\s*#\s*include\s+"([^"]+)"')
    problems = []
    checked = 0
    for top in sorted({f for layer in LAYERS for f in layer}):
        for dirpath, _, files in os.walk(os.path.join(root, top)):
            for name in sorted(files):
                if not name.endswith((".h", ".cc")):
                    continue
                path = os.path.relpath(os.path.join(dirpath, name), root)
                if is_test(path):
                    continue
                own = layer_of(path)
                checked += 1
                with open(os.path.join(root, path), encoding="utf-8", errors="replace") as f:
                    for number, line in enumerate(f, 1):
                        m = include.match(line)
                        if not m:
                            continue
                        target = layer_of(m.group(1))
                        if target is not None and own is not None and target > own:
                            problems.append(f"{path}:{number}: includes {m.group(1)} (a layer above)")
    for p in problems:
        print(p)
    print(f"{checked} files checked, {len(problems)} includes run back up")
    return 1 if problems else 0


if __name__ == "__main__":
    sys.exit(main())

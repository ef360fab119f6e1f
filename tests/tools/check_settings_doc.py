#!/usr/bin/env python3
"""ctest docs/SettingsDocumentIsCurrent: the generated block of docs/settings.md (between
<!-- settings:begin --> and <!-- settings:end -->) equals `dygslam settings --markdown`.

  check_settings_doc.py --dygslam BIN --doc docs/settings.md [--update]

--update rewrites the block from the binary instead (after a settings key or a default changed).
"""
import argparse
import subprocess
import sys

BEGIN = "<!-- settings:begin -->"
END = "<!-- settings:end -->"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--dygslam", required=True)
    ap.add_argument("--doc", required=True)
    ap.add_argument("--update", action="store_true")
    a = ap.parse_args()
    generated = subprocess.run([a.dygslam, "settings", "--markdown"], check=True,
                               capture_output=True, text=True).stdout
    with open(a.doc, encoding="utf-8") as f:
        text = f.read()
    if text.count(BEGIN) != 1 or text.count(END) != 1 or text.index(BEGIN) > text.index(END):
        print(f"{a.doc}: expected one {BEGIN} ... {END} block", file=sys.stderr)
        return 1
    head, rest = text.split(BEGIN, 1)
    current, tail = rest.split(END, 1)
    wanted = "\n" + generated
    if current == wanted:
        print(f"{a.doc}: the settings block is current ({generated.count(chr(10))} lines)")
        return 0
    if a.update:
        with open(a.doc, "w", encoding="utf-8") as f:
            f.write(head + BEGIN + wanted + END + tail)
        print(f"{a.doc}: settings block rewritten")
        return 0
    old, new = current.splitlines(), wanted.splitlines()
    for i in range(max(len(old), len(new))):
        o = old[i] if i < len(old) else "<missing>"
        n = new[i] if i < len(new) else "<missing>"
        if o != n:
            print(f"{a.doc}: settings block differs from `dygslam settings --markdown` at its "
                  f"line {i}:\n  document:  {o}\n  generated: {n}\n"
                  f"Regenerate: {sys.argv[0]} --dygslam {a.dygslam} --doc {a.doc} --update",
                  file=sys.stderr)
            break
    return 1


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""set_key.py SETTINGS KEY VALUE: writes SETTINGS with KEY set to VALUE (text as given) into the
current folder and prints the new file's name. A flat key ("Camera.fx: ...") has its line
replaced; a section key ("OctoMap.resolution") is replaced inside its section, or added to the
section, or appended as a new section."""
import hashlib
import re
import sys

path, key, value = sys.argv[1], sys.argv[2], sys.argv[3]
lines = open(path, encoding="utf-8").read().split("\n")
flat = re.compile(r"^" + re.escape(key) + r"\s*:")
done = False
for i, line in enumerate(lines):
    if flat.match(line):
        lines[i] = key + ": " + value
        done = True
        break
if not done and "." in key:
    section, sub = key.split(".", 1)
    for i, line in enumerate(lines):
        if re.match(r"^" + re.escape(section) + r"\s*:\s*(#.*)?$", line):
            j = i + 1
            while j < len(lines) and (lines[j].startswith(" ") or not lines[j].strip()):
                if re.match(r"^\s+" + re.escape(sub) + r"\s*:", lines[j]):
                    lines[j] = "  " + sub + ": " + value
                    done = True
                    break
                j += 1
            if not done:
                lines.insert(i + 1, "  " + sub + ": " + value)
                done = True
            break
    if not done:
        lines += [section + ":", "  " + sub + ": " + value]
        done = True
if not done:
    lines.append(key + ": " + value)
name = "k_" + hashlib.sha1((key + "\0" + value).encode()).hexdigest()[:10] + ".yaml"
open(name, "w", encoding="utf-8").write("\n".join(lines) + "\n")
print(name)

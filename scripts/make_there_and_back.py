#!/usr/bin/env python3
"""Makes the "there and back" evaluation sequence (loop closing on a revisit) from a TUM/Bonn dataset folder.

All frames forward, then the same frames in reverse order, so the camera returns to where it
started. Timestamps continue: reverse entry k is stamped t_last + (t_last - t_k) + 1/30 s (t_last =
the last colour stamp), for rgb.txt, depth.txt and groundtruth.txt alike. No image is copied: the
new folder's rgb/ and depth/ are symbolic links to the original folders and the lists point into
them (the same file appears twice, with two stamps).

usage: make_there_and_back.py SOURCE_DIR OUT_DIR
"""
import os
import sys


def read_list(path):
    header, rows = [], []
    with open(path) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                header.append(line.rstrip("\n"))
                continue
            stamp, rest = line.split(None, 1)
            rows.append((stamp, rest.rstrip("\n")))
    return header, rows


def restamp(t, t_last):
    return t_last + (t_last - t) + 1.0 / 30.0


def write_list(path, header, rows):
    with open(path, "w") as f:
        for h in header:
            f.write(h + "\n")
        for stamp, rest in rows:
            f.write(f"{stamp:.6f} {rest}\n")


def main():
    if len(sys.argv) != 3:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    src, out = os.path.abspath(sys.argv[1]), sys.argv[2]
    for name in ("rgb.txt", "depth.txt", "rgb", "depth"):
        if not os.path.exists(os.path.join(src, name)):
            print(f"make_there_and_back: {os.path.join(src, name)}: missing", file=sys.stderr)
            return 1
    os.makedirs(out, exist_ok=True)
    for folder in ("rgb", "depth"):
        link = os.path.join(out, folder)
        if os.path.islink(link):
            os.unlink(link)
        os.symlink(os.path.join(src, folder), link)
    rgb_header, rgb = read_list(os.path.join(src, "rgb.txt"))
    t_last = max(float(s) for s, _ in rgb)
    for name in ("rgb.txt", "depth.txt", "groundtruth.txt"):
        path = os.path.join(src, name)
        if not os.path.exists(path):
            continue
        header, rows = read_list(path)
        forward = [(float(s), rest) for s, rest in rows]
        # Entries after the last colour frame would land before the turn: left out of the way back.
        back = [(restamp(t, t_last), rest) for t, rest in reversed(forward) if t <= t_last]
        write_list(os.path.join(out, name), header, forward + back)
    print(f"wrote {out}: {len(rgb)} frames forward + {len(rgb)} back (links to {src})")
    return 0


if __name__ == "__main__":
    sys.exit(main())

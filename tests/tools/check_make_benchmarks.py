#!/usr/bin/env python3
"""`make bench`'s generator end to end on a short frame range of bonn_crowd_part (--quick):
BENCHMARKS.md written from scratch with every section, its header (commit, machine, runs, load),
the command lines, final and online ATE with the frames that have a pose, pictures linked inside
the repository's figure folder; the README's figures block rewritten between its markers and
nothing else of the README changed; a run stopped by SIGTERM leaves both files as they were.
Fails (never skips) when the data or the binary is missing."""
import argparse
import os
import re
import signal
import shutil
import subprocess
import sys
import time

SECTIONS = [
    "## Accuracy and ablation (bonn_crowd_part)",
    "## Schedule: the default command (live)",
    "## Speed and CPU per stage (direct loop)",
    "## DDS pipeline against the direct loop",
    "## Memory over a longer run",
    "## Loop closing on generated loops",
    "## Map reuse: save, then localize",
    "## Where nobody is in view, and the start-frame spread",
    "## A person filling the view (generated)",
    "## Map quality: ghost voxels",
    "## Published figures (context, not measured by us)",
]
FRAMES = "40:130"  # people enter from ~ entry 110; the map-quality reference uses entries < 100
NUM_FRAMES = 90

failures = []


def check(condition, what):
    print(("ok    " if condition else "FAIL  ") + what)
    if not condition:
        failures.append(what)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--source", required=True)
    p.add_argument("--build", required=True)
    p.add_argument("--tmp", required=True)
    a = p.parse_args()
    data_root = os.environ.get("DYGSLAM_DATA_DIR") or os.environ.get("DYGSLAM_DEFAULT_DATA_DIR", "")
    data = os.path.join(data_root, "bonn_crowd_part")
    if not os.path.exists(os.path.join(data, "groundtruth.txt")):
        print(f"FAIL  bonn_crowd_part not found at {data} (set DYGSLAM_DATA_DIR)")
        return 1
    if not os.access(os.path.join(a.build, "apps", "dygslam"), os.X_OK):
        print(f"FAIL  {a.build}/apps/dygslam not built")
        return 1
    shutil.rmtree(a.tmp, ignore_errors=True)
    os.makedirs(a.tmp)
    out = os.path.join(a.tmp, "BENCHMARKS.md")
    readme = os.path.join(a.tmp, "README.md")
    figures = os.path.join(a.tmp, "docs", "benchmarks")
    readme_text = ("# product\n\nintro line\n\n<!-- figures:begin -->\nold figures\n<!-- figures:end -->\n\n"
                   "## after the block\nkept\n")
    with open(readme, "w") as f:
        f.write(readme_text)
    with open(out, "w") as f:
        f.write("previous benchmarks\n")
    script = os.path.join(a.source, "scripts", "make_benchmarks.py")
    cmd = [sys.executable, script, "--quick", "--build", a.build, "--data", data, "--frames", FRAMES,
           "--out", out, "--readme", readme, "--figures", figures, "--work",
           os.path.join(a.tmp, "work")]

    # 1. A stopped run leaves the previous files untouched: SIGTERM while the first run goes on.
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    for line in proc.stdout:
        print(line, end="")
        if "ablation none run 1/1" in line:
            break
    time.sleep(2)
    proc.send_signal(signal.SIGTERM)
    log, _ = proc.communicate(timeout=120)
    print(log)
    check(proc.returncode == 128 + signal.SIGTERM,
          f"SIGTERM: exit code {proc.returncode} (expected {128 + signal.SIGTERM})")
    check(open(out).read() == "previous benchmarks\n", "SIGTERM: BENCHMARKS.md untouched")
    check(open(readme).read() == readme_text, "SIGTERM: README untouched")
    check(not [n for n in os.listdir(a.tmp) if n.endswith(".tmp")], "SIGTERM: no temporary file left")

    # 2. A whole quick run.
    t0 = time.monotonic()
    proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    print(proc.stdout[-3000:])
    check(proc.returncode == 0, f"quick run: exit code {proc.returncode}")
    print(f"quick run took {time.monotonic() - t0:.0f} s")
    if proc.returncode != 0:
        return 1
    text = open(out).read()
    for section in SECTIONS:
        check(section in text, f"section '{section}'")
    commit = subprocess.run(["git", "-C", a.source, "rev-parse", "--short=12", "HEAD"],
                            capture_output=True, text=True).stdout.strip()
    check(f"| commit | `{commit}`" in text, f"header names the commit {commit}")
    check(re.search(r"\| machine \| .*\d+ CPU cores", text) is not None, "header names the machine")
    check(re.search(r"\| load average \(1 min\) \| \d", text) is not None, "header gives the load")
    check("| runs | 1 per configuration" in text, "header gives the number of runs")
    # Every method of the ablation: final and online ATE, a number, with poses / frames.
    for method in ("none", "paper", "boxes", "geometry", "full"):
        m = re.search(r"^\| `" + method + r"`: [^|]+\| ([\d.]+) \| (\d+) / (\d+) \| ([\d.]+) \| (\d+) / (\d+) \|",
                      text, re.M)
        check(m is not None, f"accuracy row of {method}: final ATE, poses / frames, online ATE")
        if m:
            check(int(m.group(3)) == NUM_FRAMES, f"{method}: {m.group(3)} frames processed ({NUM_FRAMES} expected)")
            check(0 < int(m.group(2)) <= NUM_FRAMES, f"{method}: {m.group(2)} frames with a pose")
            check(0 < float(m.group(1)) < 5 and 0 < float(m.group(4)) < 5,
                  f"{method}: ATE {m.group(1)} m, online {m.group(4)} m")
    full = re.search(r"^\| `full`: [^|]+\| ([\d.]+) \|", text, re.M)
    check(full is not None and float(full.group(1)) < 0.1, "full method tracks the 90 frames (ATE < 0.1 m)")
    check("dygslam run DATA --config config/bonn.yaml --filter METHOD --direct" in text,
          "the ablation's command line is printed")
    check("dygslam eval DATA/groundtruth.txt OUT/trajectory_online.txt" in text,
          "the online ATE's command line is printed")
    dds = re.search(r"^\| default \(DDS\) \| ([\d.]+) \| (\d+) / (\d+) \| ([\d.]+) \|", text, re.M)
    check(dds is not None, "schedule: default DDS mode row with final and online ATE")
    check("--rate" in text, "schedule: --rate 1 measured or said not measured")
    check(re.search(r"^\| \*\*DDS / direct, frames/s\*\* \| \*\*[\d.]+\*\*", text, re.M) is not None,
          "DDS / direct frames/s ratio")
    check(re.search(r"^\| `full` \| [\d.]+ \| [\d.]+ \| [\d.]+ \|", text, re.M) is not None,
          "speed row of full: frames/s, CPU ms/frame, stage time")
    check(re.search(r"^\| localization \(`--load-map --localization`\) \| [\d.]+ \| \d+ / \d+ \|", text, re.M)
          is not None, "map reuse: localization ATE with poses / frames")
    check(re.search(r"^\| with the dynamic masks \(default\) \| \d+ \|", text, re.M) is not None,
          "map quality: ghost voxels with masks")
    check("Not measured: skipped in --quick mode." in text, "quick mode says what it left out")
    check("DYG-SLAM paper, Table 2" in text, "published figures keep their sources")
    links = re.findall(r"\]\(([^)]+\.png)\)", text)
    check(len(links) >= 1, f"pictures linked ({len(links)})")
    for link in links:
        check(not link.startswith("/"), f"picture link {link} is relative")
        check(os.path.exists(os.path.join(a.tmp, link)), f"picture {link} exists")
    for word in ("/tmp/", a.tmp):
        check(word not in text, f"no path under {word} in the document")
    # README: the block rewritten, the rest kept.
    new_readme = open(readme).read()
    check(new_readme.startswith("# product\n\nintro line\n\n<!-- figures:begin -->\n"), "README: text before the block kept")
    check(new_readme.endswith("<!-- figures:end -->\n\n## after the block\nkept\n"), "README: text after the block kept")
    check("old figures" not in new_readme and "| final ATE" in new_readme and "| online ATE" in new_readme,
          "README: figures block rewritten with final and online ATE")
    check(not [n for n in os.listdir(a.tmp) if n.endswith(".tmp")], "no temporary file left")
    print(f"{len(failures)} failed checks" if failures else "all checks passed")
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""ctest apps/CommandLine: the shape of the `dygslam` command line (help, the main commands,
usage errors exit 2, bad input exits 1 with a message naming the file and line)."""
import argparse
import json
import os
import shutil
import subprocess
import sys

FAILURES = []


def run(exe, *args):
    p = subprocess.run([exe] + list(args), capture_output=True, text=True)
    return p.returncode, p.stdout, p.stderr


def expect(cond, what):
    print(("ok      " if cond else "FAILED  ") + what)
    if not cond:
        FAILURES.append(what)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--dygslam", required=True)
    ap.add_argument("--tmp", required=True)
    a = ap.parse_args()
    exe = a.dygslam
    os.makedirs(a.tmp, exist_ok=True)

    rc, out, err = run(exe)
    expect(rc == 2 and "usage: dygslam <command>" in err, "no arguments: usage on stderr, exit 2")
    rc, out, err = run(exe, "help")
    expect(rc == 0, "help exits 0")
    for name in ("run", "eval", "synth", "map", "bench", "version", "help"):
        expect(("  " + name) in out, "help lists " + name)
    rc, out, err = run(exe, "--help")
    expect(rc == 0 and "commands:" in out, "--help exits 0")
    rc, out, err = run(exe, "version")
    expect(rc == 0 and out.startswith("dygslam "), "version")
    rc, out, err = run(exe, "frobnicate")
    expect(rc == 2 and "unknown command 'frobnicate'" in err, "unknown command exits 2")

    # The main commands are always built: --help exits 0 with their usage.
    for name in ("run", "eval", "synth", "map", "bench"):
        rc, out, err = run(exe, name, "--help")
        expect(rc == 0 and ("usage: dygslam " + name) in out, name + " --help exits 0 with usage")
    rc, out, err = run(exe, "run", "--help")
    if rc == 0:
        for opt in ("DATASET_DIR", "--config", "--filter", "--frames", "--out", "--deterministic"):
            expect(opt in out, "run --help mentions " + opt)

    # eval: usage errors (2) and bad input (1).
    rc, out, err = run(exe, "eval", "only_one")
    expect(rc == 2 and "missing argument ESTIMATE" in err, "eval with one argument: exit 2")
    rc, out, err = run(exe, "eval", "a", "b", "--bogus")
    expect(rc == 2 and "unknown option --bogus" in err, "eval unknown option: exit 2")
    rc, out, err = run(exe, "eval", "a", "b", "--plot")
    expect(rc == 2 and "needs a value" in err, "eval --plot without value: exit 2")
    rc, out, err = run(exe, "eval", "a", "b", "--gt-calibration", "marker")
    expect(rc == 2 and "--gt-calibration" in err, "eval --gt-calibration unknown name: exit 2")
    rc, out, err = run(exe, "eval", "a", "b", "--gt-calibration", "none", "--calibrated-ate")
    expect(rc == 2 and "--calibrated-ate" in err, "eval --calibrated-ate without calibration: exit 2")
    missing = os.path.join(a.tmp, "missing.txt")
    rc, out, err = run(exe, "eval", missing, missing + ".estimate")
    expect(rc == 1 and missing in err and "not found" in err, "eval missing file: exit 1 naming it")

    gt = os.path.join(a.tmp, "gt.txt")
    with open(gt, "w") as f:
        for i in range(60):
            t = 100 + i * 0.05
            f.write("%.6f %.4f %.4f 0.0 0 0 0 1\n" % (t, 0.1 * i, 0.02 * i * i))
    bad = os.path.join(a.tmp, "bad.txt")
    with open(bad, "w") as f:
        f.write("# header\n100.0 0 0 0 0 0 0 1\n100.05 0 0 0 0 0 1\n")
    rc, out, err = run(exe, "eval", gt, bad)
    expect(rc == 1 and (bad + ":3") in err and "8 columns" in err, "eval malformed line: exit 1, file:line")
    far = os.path.join(a.tmp, "far.txt")
    with open(far, "w") as f:
        f.write("500.0 0 0 0 0 0 0 1\n501.0 0 0 0 0 0 0 1\n502.0 0 0 0 0 0 0 1\n")
    rc, out, err = run(exe, "eval", gt, far)
    expect(rc == 1 and "pairs" in err, "eval without overlapping stamps: exit 1")

    # One file as both trajectories is a usage error; an identical copy scores 0.
    rc, out, err = run(exe, "eval", gt, gt)
    expect(rc == 2 and "the same file" in err, "eval of one file against itself: exit 2")
    same = os.path.join(a.tmp, "same.txt")
    shutil.copyfile(gt, same)
    rc, out, err = run(exe, "eval", gt, same)
    expect(rc == 0 and "ATE" in out and "rmse 0.000000" in out, "eval of a copy: text output, ATE 0")
    rc, out, err = run(exe, "eval", gt, same, "--json")
    try:
        j = json.loads(out)
        keys = ("pairs", "ate_rmse", "ate_mean", "ate_median", "ate_sd", "ate_min", "ate_max",
                "rpe_pairs", "rpe_trans_rmse", "rpe_rot_rmse")
        expect(rc == 0 and all(k in j for k in keys) and j["pairs"] == 60, "eval --json has the fields")
    except ValueError:
        expect(False, "eval --json prints JSON: " + out)
    aligned = os.path.join(a.tmp, "aligned.txt")
    rc, out, err = run(exe, "eval", gt, same, "--save-aligned", aligned)
    expect(rc == 0 and os.path.exists(aligned), "eval --save-aligned writes a trajectory")
    rc, out, err = run(exe, "eval", gt, same, "--plot", os.path.join(a.tmp, "no_dir", "x.png"))
    expect(rc == 1 and "does not exist" in err, "eval --plot into a missing directory: exit 1")

    print("%d failure(s)" % len(FAILURES))
    return 1 if FAILURES else 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""ctest apps/FetchDataLocal: scripts/fetch_data.sh finds local data and models, verifies the
layout and the weights' size, and fails clearly when something is missing and downloads are
disabled (DYGSLAM_OFFLINE=1: this test never touches the network)."""
import argparse
import os
import shutil
import subprocess
import sys

FAILURES = []


def expect(cond, what):
    print(("ok      " if cond else "FAILED  ") + what)
    if not cond:
        FAILURES.append(what)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--script", required=True)
    ap.add_argument("--tmp", required=True)
    a = ap.parse_args()
    shutil.rmtree(a.tmp, ignore_errors=True)
    data = os.path.join(a.tmp, "data")
    models = os.path.join(a.tmp, "models")
    os.makedirs(data)
    os.makedirs(models)

    def fetch(*args, **env_overrides):
        env = dict(os.environ)
        env.update({"DYGSLAM_OFFLINE": "1", "DYGSLAM_DATA_DIR": data, "DYGSLAM_MODELS_DIR": models})
        env.update(env_overrides)
        p = subprocess.run(["bash", a.script] + list(args), capture_output=True, text=True, env=env)
        return p.returncode, p.stdout.strip().splitlines()[-1] if p.stdout.strip() else "", p.stderr

    def same_folder(printed, expected):
        # The script prints the folder as reached (symlinks kept); compare what both resolve to.
        return printed != "" and os.path.realpath(printed) == os.path.realpath(expected)

    # A dataset in DYGSLAM_DATA_DIR under its TUM archive name.
    seq = os.path.join(data, "rgbd_dataset_freiburg3_walking_xyz")
    for d in ("rgb", "depth"):
        os.makedirs(os.path.join(seq, d))
    for f in ("rgb.txt", "depth.txt", "groundtruth.txt"):
        open(os.path.join(seq, f), "w").close()
    rc, out, err = fetch("fr3_walking_xyz")
    expect(rc == 0 and same_folder(out, seq), "finds fr3_walking_xyz in DYGSLAM_DATA_DIR")
    # The data folder reached through a symlink (as shared data often is).
    linked = os.path.join(a.tmp, "data_link")
    os.symlink(data, linked)
    rc, out, err = fetch("fr3_walking_xyz", DYGSLAM_DATA_DIR=linked)
    expect(rc == 0 and same_folder(out, seq) and out.startswith(linked),
           "finds fr3_walking_xyz through a symlinked DYGSLAM_DATA_DIR (%s)" % out)
    os.remove(os.path.join(seq, "depth.txt"))
    rc, out, err = fetch("fr3_walking_xyz")
    expect(rc == 1 and "missing: depth.txt" in err, "incomplete dataset: names the missing file")

    rc, out, err = fetch("bonn_crowd2")
    expect(rc == 1 and "rgbd_bonn_crowd2.zip" in err and "DYGSLAM_OFFLINE" in err,
           "missing dataset offline: clear error with the URL")
    rc, out, err = fetch("fr3_walking_rpy")
    expect(rc == 1 and "https://cvg.cit.tum.de/rgbd/dataset/freiburg3/rgbd_dataset_freiburg3_walking_rpy.tgz" in err,
           "TUM URL pattern")
    rc, out, err = fetch("no_such_thing")
    expect(rc == 2 and "unknown name" in err, "unknown name: exit 2")
    rc, out, err = fetch()
    expect(rc == 2, "no name: exit 2")

    # Models: the weights must have the exact size.
    y = os.path.join(models, "yolov3-tiny")
    os.makedirs(y)
    open(os.path.join(y, "yolov3-tiny.cfg"), "w").close()
    with open(os.path.join(y, "yolov3-tiny.weights"), "wb") as f:
        f.truncate(1000)
    rc, out, err = fetch("yolov3-tiny", "--dest", os.path.join(a.tmp, "dest"))
    expect(rc == 1 and "expected 35434956" in err, "wrong-size weights are rejected")
    with open(os.path.join(y, "yolov3-tiny.weights"), "wb") as f:
        f.truncate(35434956)
    rc, out, err = fetch("yolov3-tiny")
    expect(rc == 0 and same_folder(out, y), "weights of the right size are found")
    os.symlink(models, os.path.join(a.tmp, "models_link"))
    rc, out, err = fetch("yolov3-tiny", DYGSLAM_MODELS_DIR=os.path.join(a.tmp, "models_link"))
    expect(rc == 0 and same_folder(out, y), "weights found through a symlinked DYGSLAM_MODELS_DIR")

    # The shipped excerpt, when the shared data is there.
    shared = os.environ.get("DYGSLAM_DEFAULT_DATA_DIR", "")
    if os.path.isdir(os.path.join(shared, "bonn_crowd_part")):
        rc, out, err = fetch("bonn_crowd_part", DYGSLAM_DATA_DIR=shared)
        expect(rc == 0 and same_folder(out, os.path.join(shared, "bonn_crowd_part")),
               "finds bonn_crowd_part in the shared data")
    print("%d failure(s)" % len(FAILURES))
    return 1 if FAILURES else 0


if __name__ == "__main__":
    sys.exit(main())

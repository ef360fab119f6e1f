#!/usr/bin/env python3
"""Independent reference for ATE / RPE with the TUM RGB-D benchmark conventions (numpy only).

Written for dygslam's tests from the method description (not from the TUM scripts):
  * ATE: association of ground truth (first) and estimate (second) stamps: every pair with
    |t_gt - (t_est + offset)| < max_difference is a candidate, candidates are taken greedily by
    increasing difference, one-to-one. Horn's closed-form absolute orientation (via SVD of the
    cross-covariance, reflection-corrected) aligns the estimate positions onto the ground truth.
    Errors: Euclidean distance per pair; rmse, mean, median, population sd, min, max.
  * RPE (fixed delta in seconds, all pairs): for estimate pose i, j = pose closest to t_i + delta
    (skipped if j is the last pose); ground-truth poses closest to both ends, skipped beyond twice
    the median ground-truth interval; error = (E_i^-1 E_j) (G_i^-1 G_j)^-1.

Usage: evaluate_ate_reference.py GROUNDTRUTH ESTIMATE [--json]
"""
import argparse
import json
import os
import sys

try:
    import numpy as np
except ImportError:
    # A python3 without numpy first on PATH (pyenv, venv): use the system one (python3-numpy).
    if os.path.exists("/usr/bin/python3") and os.path.realpath(sys.executable) != os.path.realpath("/usr/bin/python3"):
        os.execv("/usr/bin/python3", ["/usr/bin/python3"] + sys.argv)
    raise


def read_tum(path):
    stamps, poses = [], []
    with open(path) as f:
        for line in f:
            line = line.replace(",", " ").replace("\t", " ").strip()
            if not line or line.startswith("#"):
                continue
            v = line.split()
            if len(v) != 8:
                raise ValueError(f"{path}: expected 8 columns: {line}")
            stamps.append(float(v[0]))
            poses.append([float(x) for x in v[1:]])
    return np.array(stamps), np.array(poses)


def associate(first, second, max_difference, offset=0.0):
    candidates = []
    for i, a in enumerate(first):
        d = np.abs(a - (second + offset))
        for j in np.nonzero(d < max_difference)[0]:
            candidates.append((d[j], i, int(j)))
    candidates.sort()
    used_first, used_second, matches = set(), set(), []
    for _, i, j in candidates:
        if i in used_first or j in used_second:
            continue
        used_first.add(i)
        used_second.add(j)
        matches.append((i, j))
    matches.sort()
    return matches


def horn_align(source, target):
    """R, t minimising sum |target - (R source + t)|^2; source, target: 3xN."""
    mu_s = source.mean(axis=1, keepdims=True)
    mu_t = target.mean(axis=1, keepdims=True)
    cov = (target - mu_t) @ (source - mu_s).T  # 3x3
    u, _, vt = np.linalg.svd(cov)
    s = np.eye(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        s[2, 2] = -1
    rot = u @ s @ vt
    return rot, mu_t - rot @ mu_s


def matrix(pose):
    tx, ty, tz, qx, qy, qz, qw = pose
    q = np.array([qw, qx, qy, qz]) / np.linalg.norm([qw, qx, qy, qz])
    w, x, y, z = q
    m = np.eye(4)
    m[:3, :3] = [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                 [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                 [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]]
    m[:3, 3] = [tx, ty, tz]
    return m


def closest(stamps, t):
    i = int(np.argmin(np.abs(stamps - t)))
    return i


def ate(gt_stamps, gt, est_stamps, est, max_difference=0.02, offset=0.0):
    matches = associate(gt_stamps, est_stamps, max_difference, offset)
    g = np.array([gt[i][:3] for i, _ in matches]).T
    e = np.array([est[j][:3] for _, j in matches]).T
    rot, trans = horn_align(e, g)
    err = np.sqrt(np.sum((rot @ e + trans - g) ** 2, axis=0))
    return {
        "pairs": len(matches),
        "ate_rmse": float(np.sqrt(np.dot(err, err) / len(err))),
        "ate_mean": float(np.mean(err)),
        "ate_median": float(np.median(err)),
        "ate_sd": float(np.std(err)),
        "ate_min": float(np.min(err)),
        "ate_max": float(np.max(err)),
    }


def rpe(gt_stamps, gt, est_stamps, est, delta=1.0, offset=0.0):
    gt_m = [matrix(p) for p in gt]
    est_m = [matrix(p) for p in est]
    max_gt = 2 * np.median(np.diff(gt_stamps))
    trans, rot = [], []
    for i in range(len(est_stamps)):
        j = closest(est_stamps, est_stamps[i] + delta)
        if j == len(est_stamps) - 1:
            continue
        gi = closest(gt_stamps, est_stamps[i] + offset)
        gj = closest(gt_stamps, est_stamps[j] + offset)
        if abs(gt_stamps[gi] - est_stamps[i] - offset) > max_gt or \
           abs(gt_stamps[gj] - est_stamps[j] - offset) > max_gt:
            continue
        err = np.linalg.inv(est_m[i]) @ est_m[j] @ np.linalg.inv(np.linalg.inv(gt_m[gi]) @ gt_m[gj])
        trans.append(np.linalg.norm(err[:3, 3]))
        rot.append(np.degrees(np.arccos(np.clip((np.trace(err[:3, :3]) - 1) / 2, -1, 1))))
    trans, rot = np.array(trans), np.array(rot)
    if len(trans) == 0:
        return {"rpe_pairs": 0}
    return {
        "rpe_pairs": len(trans),
        "rpe_trans_rmse": float(np.sqrt(np.mean(trans ** 2))),
        "rpe_trans_mean": float(np.mean(trans)),
        "rpe_trans_median": float(np.median(trans)),
        "rpe_rot_rmse": float(np.sqrt(np.mean(rot ** 2))),
        "rpe_rot_mean": float(np.mean(rot)),
        "rpe_rot_median": float(np.median(rot)),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("groundtruth")
    ap.add_argument("estimate")
    ap.add_argument("--max_difference", type=float, default=0.02)
    ap.add_argument("--delta", type=float, default=1.0)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    gs, g = read_tum(args.groundtruth)
    es, e = read_tum(args.estimate)
    result = ate(gs, g, es, e, args.max_difference)
    result.update(rpe(gs, g, es, e, args.delta))
    if args.json:
        print(json.dumps(result))
    else:
        for k, v in result.items():
            print(f"{k} {v}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

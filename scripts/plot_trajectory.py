#!/usr/bin/env python3
"""Plot ground truth vs aligned estimate (top view) and the ATE over time.

Called by `dygslam eval --plot FILE.png` with a data file of associated pairs:
    t gt_x gt_y gt_z est_x est_y est_z error
Exit codes: 0 written, 2 bad input, 3 matplotlib missing.
"""
import argparse
import sys

from plot_common import import_pyplot, save_figure


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--data", required=True, help="pairs file written by dygslam eval")
    ap.add_argument("--out", required=True, help="output PNG")
    ap.add_argument("--title", default="", help="figure title")
    args = ap.parse_args()

    plt = import_pyplot("plot_trajectory.py")
    if plt is None:
        return 3

    rows = []
    with open(args.data) as f:
        for number, line in enumerate(f, 1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            values = line.split()
            if len(values) != 8:
                print(f"{args.data}:{number}: expected 8 columns", file=sys.stderr)
                return 2
            rows.append([float(v) for v in values])
    if not rows:
        print(f"{args.data}: no data", file=sys.stderr)
        return 2

    t0 = rows[0][0]
    t = [r[0] - t0 for r in rows]
    gt = [r[1:4] for r in rows]
    est = [r[4:7] for r in rows]
    err = [r[7] for r in rows]

    # Top view: the two axes with the largest extent of the ground truth.
    extent = [max(p[k] for p in gt) - min(p[k] for p in gt) for k in range(3)]
    a, b = sorted(sorted(range(3), key=lambda k: -extent[k])[:2])
    names = "xyz"

    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12, 5))
    ax0.plot([p[a] for p in gt], [p[b] for p in gt], "-", color="black", lw=1.5, label="ground truth")
    ax0.plot([p[a] for p in est], [p[b] for p in est], "-", color="tab:blue", lw=1.0,
             label="estimate (aligned)")
    for i in range(0, len(gt), max(1, len(gt) // 60)):
        ax0.plot([gt[i][a], est[i][a]], [gt[i][b], est[i][b]], "-", color="tab:red", lw=0.5)
    ax0.set_xlabel(f"{names[a]} [m]")
    ax0.set_ylabel(f"{names[b]} [m]")
    ax0.set_aspect("equal", adjustable="datalim")
    ax0.legend(loc="best")
    ax0.set_title(f"trajectory ({names[a]}-{names[b]} plane)")

    rmse = (sum(e * e for e in err) / len(err)) ** 0.5
    ax1.plot(t, err, "-", color="tab:red", lw=1.0)
    ax1.axhline(rmse, color="gray", ls="--", lw=1.0, label=f"RMSE {rmse:.4f} m")
    ax1.set_xlabel("time [s]")
    ax1.set_ylabel("ATE [m]")
    ax1.set_ylim(bottom=0)
    ax1.legend(loc="best")
    ax1.set_title(f"absolute trajectory error ({len(err)} pairs)")
    if args.title:
        fig.suptitle(args.title)
    fig.tight_layout()

    save_figure(fig, args.out, dpi=100)
    return 0


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""Pictures of `dygslam bench`: per sequence and configuration, ground truth vs. the aligned
estimate (top view) and the ATE over time; per sequence, all configurations in one figure.

Called by `dygslam bench` with a manifest (JSON):
    {"sequences": [{"sequence": NAME, "compare_png": PATH,
                    "series": [{"config": C, "label": L, "pairs": FILE, "png": PATH}, ...]}]}
where each pairs FILE has one line per associated pose: t gt_x gt_y gt_z est_x est_y est_z error.
Exit codes: 0 written, 2 bad input, 3 matplotlib missing.
"""
import argparse
import json
import os
import sys

from plot_common import import_pyplot, save_figure

# One colour per configuration, none shared (a configuration not listed gets one of the spare colours).
COLORS = {"none": "tab:red", "boxes": "tab:orange", "geometry": "tab:purple", "full": "tab:blue",
          "paper": "tab:brown", "paper+margin": "tab:olive", "paper+margin+demotion": "tab:cyan",
          "rgbd_icp_odometry": "tab:gray"}
SPARE_COLORS = ["tab:green", "tab:pink", "black", "gold"]


def read_pairs(path):
    rows = []
    with open(path) as f:
        for number, line in enumerate(f, 1):
            line = line.strip()
            if not line or line.startswith("#"):
                continue
            values = line.split()
            if len(values) != 8:
                raise ValueError(f"{path}:{number}: expected 8 columns, got {len(values)}")
            rows.append([float(v) for v in values])
    if not rows:
        raise ValueError(f"{path}: no pairs")
    return rows


def plane_axes(gt):
    extent = [max(p[k] for p in gt) - min(p[k] for p in gt) for k in range(3)]
    return sorted(sorted(range(3), key=lambda k: -extent[k])[:2])


def save(fig, path):
    out_dir = os.path.dirname(os.path.abspath(path))
    os.makedirs(out_dir, exist_ok=True)
    save_figure(fig, path, dpi=90)


def draw(plt, sequence, series, out_png):
    """series: list of (config, label, rows)."""
    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12, 5))
    gt_rows = max((rows for _, _, rows in series), key=len)
    gt = [r[1:4] for r in gt_rows]
    a, b = plane_axes(gt)
    names = "xyz"
    t0 = min(rows[0][0] for _, _, rows in series)
    ax0.plot([p[a] for p in gt], [p[b] for p in gt], "-", color="black", lw=2.0, label="ground truth")
    spare = iter(SPARE_COLORS)
    for config, label, rows in series:
        color = COLORS.get(config) or next(spare, "dimgray")
        est = [r[4:7] for r in rows]
        err = [r[7] for r in rows]
        rmse = (sum(e * e for e in err) / len(err)) ** 0.5
        ax0.plot([p[a] for p in est], [p[b] for p in est], "-", color=color, lw=1.0,
                 label=f"{label}")
        ax1.plot([r[0] - t0 for r in rows], err, "-", color=color, lw=1.0,
                 label=f"{label}: RMSE {rmse:.4f} m")
        if len(series) == 1:
            for i in range(0, len(rows), max(1, len(rows) // 60)):
                ax0.plot([rows[i][1 + a], rows[i][4 + a]], [rows[i][1 + b], rows[i][4 + b]], "-",
                         color="tab:red", lw=0.5)
    if len(series) > 1:
        # Frame the ground truth: estimates that drift far away leave the picture (their ATE
        # curve on the right still shows them) instead of shrinking the good ones to a dot.
        lo = [min(p[k] for p in gt) for k in (a, b)]
        hi = [max(p[k] for p in gt) for k in (a, b)]
        span = max(hi[0] - lo[0], hi[1] - lo[1], 0.2)
        centre = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2]
        half = 0.5 * span * 1.6
        ax0.set_xlim(centre[0] - half, centre[0] + half)
        ax0.set_ylim(centre[1] - half, centre[1] + half)
        ax0.set_aspect("equal", adjustable="box")
    else:
        ax0.set_aspect("equal", adjustable="datalim")
    ax0.set_xlabel(f"{names[a]} [m]")
    ax0.set_ylabel(f"{names[b]} [m]")
    ax0.legend(loc="best", fontsize=8)
    ax0.set_title(f"ground truth vs. aligned estimate ({names[a]}-{names[b]} plane)"
                  + (", framed on the ground truth" if len(series) > 1 else ""), fontsize=10)
    ax1.set_xlabel("time [s]")
    ax1.set_ylabel("ATE [m]")
    ax1.set_yscale("log" if len(series) > 1 else "linear")
    if len(series) == 1:
        ax1.set_ylim(bottom=0)
    ax1.legend(loc="best", fontsize=8)
    ax1.set_title("absolute trajectory error over time")
    fig.suptitle(sequence if len(series) > 1 else f"{sequence}: {series[0][1]}")
    fig.tight_layout()
    save(fig, out_png)
    plt.close(fig)


def main():
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--manifest", required=True)
    args = ap.parse_args()
    plt = import_pyplot("bench_plots.py")
    if plt is None:
        return 3
    try:
        with open(args.manifest) as f:
            manifest = json.load(f)
        for seq in manifest["sequences"]:
            series = [(s["config"], s["label"], read_pairs(s["pairs"])) for s in seq["series"]]
            for one, s in zip(series, seq["series"]):
                draw(plt, seq["sequence"], [one], s["png"])
            if series:
                draw(plt, seq["sequence"], series, seq["compare_png"])
    except (OSError, ValueError, KeyError) as e:
        print(f"bench_plots.py: {e}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())

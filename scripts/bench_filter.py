#!/usr/bin/env python3
"""Runs `dygslam run` N times per filter mode on a dataset and prints a Markdown table of medians:
ATE RMSE/mean/SD (via `dygslam eval --json`), tracked frames, and per-stage times from frames.csv.
Usage: bench_filter.py --dygslam BIN --dataset DIR --config YAML [--runs 3] [--modes none,boxes,geometry,full]
       [--out DIR] [--frames A:B] [--deterministic]
"""
import argparse, csv, json, os, statistics, subprocess, sys, time

def median(xs):
    return statistics.median(xs) if xs else float('nan')

def main():
    ap = argparse.ArgumentParser()
    ap.add_argument('--dygslam', required=True)
    ap.add_argument('--dataset', required=True)
    ap.add_argument('--config', required=True)
    ap.add_argument('--runs', type=int, default=3)
    ap.add_argument('--modes', default='none,boxes,geometry,full')
    ap.add_argument('--out', default='out/bench')
    ap.add_argument('--frames', default='')
    ap.add_argument('--deterministic', action='store_true')
    a = ap.parse_args()
    gt = os.path.join(a.dataset, 'groundtruth.txt')
    rows = []
    modes = a.modes.split(',')
    total = len(modes) * a.runs
    done = 0
    for mode in modes:
        runs = []
        for k in range(a.runs):
            out = os.path.join(a.out, f'{mode}_{k}')
            cmd = [a.dygslam, 'run', a.dataset, '--config', a.config, '--filter', mode, '--out', out, '--quiet']
            if a.frames: cmd += ['--frames', a.frames]
            if a.deterministic: cmd.append('--deterministic')
            t0 = time.time()
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
            wall = time.time() - t0
            ev = json.loads(subprocess.run([a.dygslam, 'eval', gt, os.path.join(out, 'trajectory.txt'), '--json'],
                                           check=True, capture_output=True, text=True).stdout)
            frames = list(csv.DictReader(open(os.path.join(out, 'frames.csv'))))
            col = lambda name: [float(f[name]) for f in frames]
            runs.append(dict(rmse=ev['ate_rmse'], mean=ev['ate_mean'], sd=ev['ate_sd'], pairs=ev['pairs'],
                             lost=sum(f['state'] == 'lost' for f in frames), n=len(frames),
                             orb=median(col('orb_ms')), det=median(col('detection_ms')),
                             match=median(col('matching_ms')), prob=median(col('probability_ms')),
                             track=median(col('tracking_ms')), total=median(col('total_ms')),
                             fps=len(frames) / wall))
            done += 1
            print(f'\r[bench] {done}/{total} {mode} run {k}: ATE {ev["ate_rmse"]:.4f} m', end='', file=sys.stderr)
        med = {key: median([r[key] for r in runs]) for key in runs[0]}
        med['rmse_all'] = [r['rmse'] for r in runs]
        rows.append((mode, med))
    print(file=sys.stderr)
    base = dict(rows).get('none')
    print('| filter | ATE RMSE (m) | mean | SD | γ vs none | tracked / frames | runs (RMSE) |')
    print('|---|---|---|---|---|---|---|')
    for mode, m in rows:
        gamma = f'{(1 - m["rmse"] / base["rmse"]) * 100:.1f} %' if base else '-'
        runs_txt = ', '.join(f'{x:.4f}' for x in m['rmse_all'])
        print(f'| {mode} | {m["rmse"]:.4f} | {m["mean"]:.4f} | {m["sd"]:.4f} | {gamma} | {m["pairs"]:.0f} / {m["n"]:.0f} | {runs_txt} |')
    print()
    print('| filter | ORB extraction | detection (parallel) | matching | probability | tracking | total per frame | frames/s (wall) |')
    print('|---|---|---|---|---|---|---|---|')
    for mode, m in rows:
        print(f'| {mode} | {m["orb"]:.1f} | {m["det"]:.1f} | {m["match"]:.2f} | {m["prob"]:.2f} | {m["track"]:.1f} | {m["total"]:.1f} | {m["fps"]:.1f} |')
    if base:
        full = dict(rows).get('full')
        if full:
            print(f'\nfull / none median per-frame time: {full["total"] / base["total"]:.2f}x; '
                  f'ATE improvement none/full: {base["rmse"] / full["rmse"]:.1f}x')

if __name__ == '__main__':
    main()

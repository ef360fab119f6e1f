#!/usr/bin/env python3
"""BENCHMARKS.md from the current commit, in one command (`make bench`).

Runs the `dygslam` binary of BUILD with the shipped settings (config/bonn.yaml, no extra keys) and
writes BENCHMARKS.md from scratch: the commit, the machine, the number of runs, then one section per
measurement, each table with the command lines that produced it, medians with their ranges, frames
with a pose beside every ATE, final and online ATE:

  accuracy and ablation   bonn_crowd_part, filters none / paper / boxes / geometry / full (direct)
  schedule (live)         the default command (DDS pipeline, shipped defaults); --rate 1 when the
                          run command has it
  speed and CPU           frames/s, CPU ms per frame over all threads, per-stage times (frames.csv)
  DDS against direct      frames/s ratio, the two modes interleaved in the same rounds
  memory                  resident memory over a longer run (the player replays the frames)
  loop closing            generated loops (24.4 m and 62.2 m), loop closing on (default) and off
  map reuse               save the SLAM map, localize in it, ATE
  map quality             ghost voxels with and without the dynamic masks (`dygslam map`)
  published figures       quoted from docs/benchmarks/published_figures.md (not measured)

Scores come from `dygslam eval --json`; pictures go to docs/benchmarks/ (committed). The README's
block between <!-- figures:begin --> and <!-- figures:end --> is rewritten with the headline
figures when both markers exist. Outputs are written only at the end, each through a temporary
file renamed into place: a stopped run (SIGINT / SIGTERM) leaves the previous files untouched.

DDS runs stay on this machine: the whole benchmark runs in a private network namespace (loopback
only, private /dev/shm; scripts/netns_lib.sh), entered automatically when this process may create
one. Without it the DDS sections say "not measured" and why.

  scripts/make_benchmarks.py [--build build] [--data DIR] [--runs N] [--quick] [--frames A:B] ...
  BENCH_QUICK=1 scripts/make_benchmarks.py     (1 run, no memory and loop sections)
"""
import argparse
import csv
import datetime
import json
import math
import os
import re
import shlex
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ABLATION = ["none", "paper", "boxes", "geometry", "full"]
LABELS = {
    "none": "no filter",
    "paper": "the paper's method as written",
    "boxes": "person boxes only",
    "geometry": "geometry only (depth-residual test)",
    "full": "full method (default)",
}
# One colour per method, never shared (pictures).
COLOURS = {"none": "#d62728", "paper": "#8c564b", "boxes": "#ff7f0e", "geometry": "#9467bd",
           "full": "#1f77b4", "loop_on": "#1f77b4", "loop_off": "#d62728"}
# Generated loops: (name, length text, `dygslam synth` arguments). Rendered once into the cache
# folder and reused while the command is the same (the renderer is deterministic).
# Generated crowds for the filter's sensitivity table: two walkers in the handheld room, each run
# with its ground-truth person boxes (the detector does not find the textured boxes).
CROWDS = [(f"crowd_s{seed}", ["--frames", "300", "--objects", "2", "--noise", "--seed", str(seed)])
          for seed in (1, 2, 3)]
# A person filling the view (generated): a walker moving with the camera covers this share of the
# image for STRETCH["frames"] frames (1 s) after sliding in over STRETCH["ramp"] frames, in a static
# room; boxed (its ground-truth box in detections.txt) or never detected.
STRETCH = {"frames": 30, "start": 60, "ramp": 6, "length": 150}
COVERAGES = (0.6, 0.8, 0.95)
STRETCH_SEEDS = (1, 2, 3)
STRETCH_MODES = ("paper", "boxes", "geometry", "full")
# Start entries of the start-frame spread: the same sequence started one frame later is a
# neutral perturbation of a chaotic system.
STARTS = list(range(8))
LOOPS = [
    ("loop24", "24.4 m inward loop, 480 frames (1.18 laps)",
     ["--room", "10.5,8,3", "--loop-path", "4,2.75", "--loop-corner", "1.5", "--loop-inward",
      "--speed", "1.2", "--fps", "20", "--texels", "200", "--objects", "0", "--noise",
      "--supersampling", "1", "--frames", "480"]),
    ("loop62", "62.2 m inward loop, 1,150 frames (1.11 laps)",
     ["--room", "26.5,11.2,3", "--loop-path", "12,4.2", "--loop-corner", "1.5", "--loop-inward",
      "--speed", "1.2", "--fps", "20", "--texels", "200", "--objects", "0", "--noise",
      "--supersampling", "1", "--frames", "1150", "--seed", "2"]),
]
FIGURES_BEGIN = "<!-- figures:begin -->"
FIGURES_END = "<!-- figures:end -->"


class Stopped(Exception):
    def __init__(self, signum):
        super().__init__(f"stopped by signal {signum}")
        self.signum = signum


class RunFailed(Exception):
    pass


CURRENT_CHILD = [None]


def on_signal(signum, _frame):
    child = CURRENT_CHILD[0]
    if child is not None and child.poll() is None:
        try:
            os.killpg(child.pid, signal.SIGTERM)
        except ProcessLookupError:
            pass
    raise Stopped(signum)


# --- small helpers ---------------------------------------------------------------------------

def say(text):
    print(f"[bench {time.strftime('%H:%M:%S')}] {text}", file=sys.stderr, flush=True)


def median(values):
    v = [x for x in values if x is not None and math.isfinite(x)]
    return statistics.median(v) if v else float("nan")


def fmt(value, digits=4):
    return "-" if value is None or not math.isfinite(value) else f"{value:.{digits}f}"


def med_range(values, digits=4):
    """'median (min–max)' over the finite values; one value alone; '-' for none."""
    v = [x for x in values if x is not None and math.isfinite(x)]
    if not v:
        return "-"
    if len(v) == 1:
        return fmt(v[0], digits)
    return f"{fmt(statistics.median(v), digits)} ({fmt(min(v), digits)}–{fmt(max(v), digits)})"


def stage_text(values):
    """A stage's milliseconds; '-' for a stage the method does not run (0 in every run)."""
    return "-" if values and all(v == 0 for v in values) else med_range(values, 2)


def int_range(values):
    v = [x for x in values if x is not None]
    if not v:
        return "-"
    lo, hi = min(v), max(v)
    return str(lo) if lo == hi else f"{lo}–{hi}"


def poses_text(runs, key_poses="poses", key_frames="frames"):
    return f"{int_range([r.get(key_poses) for r in runs])} / {int_range([r.get(key_frames) for r in runs])}"


def command_text(cmd, replacements):
    """A command line as a user would type it (paths shortened)."""
    words = []
    for word in cmd:
        for long, short in replacements:
            if word == long or word.startswith(long + "/"):
                word = short + word[len(long):]
                break
        words.append(shlex.quote(word))
    return " ".join(words)


def load1():
    try:
        return float(open("/proc/loadavg").read().split()[0])
    except (OSError, ValueError, IndexError):
        return float("nan")


def loadavg_text():
    try:
        return " / ".join(open("/proc/loadavg").read().split()[:3])
    except OSError:
        return "n/a"


def machine_text():
    model = "unknown CPU"
    try:
        for line in open("/proc/cpuinfo"):
            if line.startswith("model name"):
                model = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = 0.0
    try:
        for line in open("/proc/meminfo"):
            if line.startswith("MemTotal:"):
                mem = float(line.split()[1]) / (1024 * 1024)
                break
    except OSError:
        pass
    return f"{model}, {os.cpu_count()} CPU cores, {mem:.0f} GiB RAM"


def git(*args):
    try:
        return subprocess.run(["git", "-C", REPO] + list(args), capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return ""


def write_atomically(path, text):
    directory = os.path.dirname(os.path.abspath(path))
    os.makedirs(directory, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", suffix=".tmp", dir=directory)
    with os.fdopen(fd, "w") as f:
        f.write(text)
    return tmp


def rss_mib(pid):
    try:
        for line in open(f"/proc/{pid}/status"):
            if line.startswith("VmRSS:"):
                return float(line.split()[1]) / 1024.0
    except OSError:
        pass
    return None


# --- running the binary ----------------------------------------------------------------------

def run(cmd, log_path, sample_rss_every=None, check=True):
    """Runs cmd (its own process group), stdout+stderr into log_path. Returns a dict: exit code,
    wall seconds, CPU seconds (user + sys, all threads), peak RSS (MiB), the log text and, with
    sample_rss_every, [(seconds, RSS MiB)] of the process."""
    os.makedirs(os.path.dirname(log_path), exist_ok=True)
    samples = []
    with open(log_path, "w") as log:
        t0 = time.monotonic()
        child = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        CURRENT_CHILD[0] = child
        next_sample = t0
        while True:
            pid, status, usage = os.wait4(child.pid, os.WNOHANG)
            if pid != 0:
                break
            now = time.monotonic()
            if sample_rss_every and now >= next_sample:
                value = rss_mib(child.pid)
                if value is not None:
                    samples.append((now - t0, value))
                next_sample = now + sample_rss_every
            time.sleep(0.05)
        child.returncode = os.waitstatus_to_exitcode(status)
        CURRENT_CHILD[0] = None
        wall = time.monotonic() - t0
    text = open(log_path, errors="replace").read()
    result = {"exit": child.returncode, "wall_s": wall, "cpu_s": usage.ru_utime + usage.ru_stime,
              "peak_rss_mib": usage.ru_maxrss / 1024.0, "log": text, "rss": samples}
    if check and child.returncode != 0:
        tail = "\n".join(text.splitlines()[-15:])
        raise RunFailed(f"exit code {child.returncode}: {' '.join(cmd)}\n{tail}")
    return result


def evaluate(dygslam, groundtruth, trajectory, work, save_aligned=None):
    """`dygslam eval --json` of one trajectory (None when it has fewer than 3 poses)."""
    if not os.path.exists(trajectory) or sum(1 for _ in open(trajectory)) < 3:
        return None
    cmd = [dygslam, "eval", groundtruth, trajectory, "--json"]
    if save_aligned:
        cmd += ["--save-aligned", save_aligned]
    r = run(cmd, os.path.join(work, "eval_" + os.path.basename(trajectory) + ".log"), check=False)
    if r["exit"] != 0:
        return None
    for line in r["log"].splitlines():
        if line.startswith("{"):
            return json.loads(line)
    return None


def count_poses(path):
    if not os.path.exists(path):
        return 0
    return sum(1 for line in open(path) if line.strip() and not line.startswith("#"))


def read_frames_csv(path):
    if not os.path.exists(path):
        return []
    lines = [l.rstrip("\n").split(",") for l in open(path) if l.strip()]
    if not lines:
        return []
    header = lines[0]
    return [dict(zip(header, row)) for row in lines[1:]]


def score_run(dygslam, groundtruth, out_dir, result, aligned_prefix=None):
    """Final and online ATE, poses, frames, frames/s, CPU per frame, stage means of one run."""
    log = result["log"]
    frames = None
    fps = float("nan")
    m = re.search(r"^frames: (\d+) processed, (\d+) tracked.*?([\d.]+) fps", log, re.M)
    if m:
        frames, fps = int(m.group(1)), float(m.group(3))
    m = re.search(r"^poses: (\d+) of (\d+) frames", log, re.M)
    poses = int(m.group(1)) if m else count_poses(os.path.join(out_dir, "trajectory.txt"))
    if frames is None and m:
        frames = int(m.group(2))
    traj = os.path.join(out_dir, "trajectory.txt")
    online = os.path.join(out_dir, "trajectory_online.txt")
    final_eval = evaluate(dygslam, groundtruth, traj, out_dir,
                          aligned_prefix + "_final.txt" if aligned_prefix else None)
    online_eval = evaluate(dygslam, groundtruth, online, out_dir,
                           aligned_prefix + "_online.txt" if aligned_prefix else None)
    rows = read_frames_csv(os.path.join(out_dir, "frames.csv"))
    stages = {}
    for key in ("orb_ms", "detection_ms", "matching_ms", "probability_ms", "tracking_ms",
                "total_ms"):
        values = [float(r[key]) for r in rows if key in r and r[key] not in ("", None)]
        if values:
            stages[key] = sum(values) / len(values)
    # Local mapping per keyframe, from the run summary's "local mapping schedule" line.
    local_mapping = {}
    m = re.search(r"^local mapping schedule: local BA solve median ([\d.]+) ms, in tracking's thread "
                  r"median ([\d.]+) ms per keyframe; (\d+) local BAs late \(tracking waited ([\d.]+) "
                  r"ms in all\), (\d+) landed early", log, re.M)
    if m:
        local_mapping = {"solve_ms": float(m.group(1)), "tracking_ms": float(m.group(2)),
                         "late": int(m.group(3)), "waited_ms": float(m.group(4)),
                         "early": int(m.group(5))}
    m = re.search(r"^local mapping: (\d+) keyframes", log, re.M)
    if m:
        local_mapping["keyframes"] = int(m.group(1))
    totals = [float(r["total_ms"]) for r in rows if r.get("total_ms")]
    if totals:
        stages["total_median_ms"] = statistics.median(totals)
    return {
        "frames": frames if frames is not None else len(rows),
        "poses": poses,
        "online_poses": count_poses(online),
        "ate": final_eval["ate_rmse"] if final_eval else float("nan"),
        "ate_pairs": final_eval["pairs"] if final_eval else 0,
        "online_ate": online_eval["ate_rmse"] if online_eval else float("nan"),
        "fps": fps,
        "cpu_ms_per_frame": 1000.0 * result["cpu_s"] / frames if frames else float("nan"),
        "wall_s": result["wall_s"],
        "peak_rss_mib": result["peak_rss_mib"],
        "stages": stages,
        "local_mapping": local_mapping,
        "log": log,
        "aligned": aligned_prefix,
    }


# --- the benchmark ---------------------------------------------------------------------------

class Bench:
    def __init__(self, args):
        self.args = args
        self.dygslam = os.path.abspath(os.path.join(args.build, "apps", "dygslam"))
        self.data = os.path.abspath(args.data)
        self.groundtruth = os.path.join(self.data, "groundtruth.txt")
        self.config = os.path.join(REPO, "config", "bonn.yaml")
        self.work = os.path.abspath(args.work)
        self.cache = os.path.abspath(args.cache)
        self.figures_stage = os.path.join(self.work, "figures")
        self.frames = ["--frames", args.frames] if args.frames else []
        self.notes = []
        self.load_samples = []
        self.replacements = [(self.dygslam, "dygslam"), (os.path.abspath(args.build), "BUILD"),
                             (self.data, "DATA"),
                             (os.path.join(REPO, "config"), "config"), (self.work, "OUT"),
                             (self.cache, "LOOPS")]
        # Longest path first: the scratch folders may lie inside the build folder.
        self.replacements.sort(key=lambda r: -len(r[0]))
        self.results = {}
        self.figures = []
        # System CPU on frames decoded beforehand (the robot case); the whole sequence only.
        decoded = os.path.abspath(os.path.join(args.build, "tests", "cpu_per_frame_benchmark"))
        self.decoded_bin = decoded if os.access(decoded, os.X_OK) and not args.frames else None
        if not os.access(decoded, os.X_OK):
            self.decoded_reason = f"{os.path.relpath(decoded, REPO)} is not built (tests off)"
        elif args.frames:
            self.decoded_reason = "it takes the whole sequence (--frames given)"  # file names written into figures_stage

    def cmdline(self, cmd):
        """The command as printed: the run's own scratch folder shown as OUT."""
        text = command_text(cmd, self.replacements)
        text = re.sub(r"--out OUT/\S+", "--out OUT", text)
        return re.sub(r"OUT/\S*/(\w+\.dygmap)", r"OUT/\1", text)

    def record_load(self):
        self.load_samples.append(load1())

    # accuracy, ablation, speed, DDS against direct, schedule ------------------------------
    def scored_run(self, commands, key, out, args, label, aligned_prefix=None):
        """One `dygslam run DATA --config CONFIG ARGS --out OUT --quiet` of the bonn data, its
        command kept in commands[key], scored (score_run)."""
        shutil.rmtree(out, ignore_errors=True)
        cmd = ([self.dygslam, "run", self.data, "--config", self.config] + args +
               ["--out", out, "--quiet"] + self.frames)
        commands[key] = cmd
        say(label)
        self.record_load()
        r = run(cmd, out + ".log")
        return score_run(self.dygslam, self.groundtruth, out, r, aligned_prefix)

    def ablation_and_schedule(self):
        a = self.args
        ablation = {c: [] for c in ABLATION}
        deterministic = []
        dds = []
        rate = []
        decoded = []
        commands = {}
        for k in range(a.runs):
            for config in ABLATION:
                s = self.scored_run(
                    commands, config, os.path.join(self.work, "ablation", f"{config}_{k + 1}"),
                    ["--filter", config, "--direct"], f"ablation {config} run {k + 1}/{a.runs}",
                    os.path.join(self.work, "ablation", f"{config}_{k + 1}_aligned"))
                say(f"  ATE {fmt(s['ate'])} m (online {fmt(s['online_ate'])}), "
                    f"{s['poses']}/{s['frames']} poses, {fmt(s['fps'], 1)} frames/s")
                ablation[config].append(s)
            s = self.scored_run(
                commands, "deterministic",
                os.path.join(self.work, "ablation", f"deterministic_{k + 1}"),
                ["--direct", "--deterministic"], f"--deterministic run {k + 1}/{a.runs}")
            say(f"  ATE {fmt(s['ate'])} m, local BA solve median "
                f"{fmt(s['local_mapping'].get('solve_ms', float('nan')), 1)} ms")
            deterministic.append(s)
            if self.dds_ok:
                s = self.scored_run(commands, "dds",
                                    os.path.join(self.work, "dds", f"default_{k + 1}"), [],
                                    f"default DDS mode run {k + 1}/{a.runs}")
                say(f"  ATE {fmt(s['ate'])} m (online {fmt(s['online_ate'])}), "
                    f"{s['poses']}/{s['frames']} poses, {fmt(s['fps'], 1)} frames/s")
                dds.append(s)
                if self.has_rate:
                    out = os.path.join(self.work, "dds", f"rate1_{k + 1}")
                    shutil.rmtree(out, ignore_errors=True)
                    cmd = [self.dygslam, "run", self.data, "--config", self.config, "--rate", "1",
                           "--out", out, "--quiet"] + self.frames
                    commands["rate"] = cmd
                    say(f"default DDS mode --rate 1 run {k + 1}/{a.runs}")
                    self.record_load()
                    # At the camera's rate an incomplete run (exit 3: frames dropped, or a stall
                    # on a loaded machine) is what the paced run measured, reported in the table
                    # (dropped, late, latency); any other failure stops the bench.
                    r = run(cmd, out + ".log", check=False)
                    if r["exit"] not in (0, 3):
                        tail = "\n".join(r["log"].splitlines()[-15:])
                        raise RunFailed(f"exit code {r['exit']}: {' '.join(cmd)}\n{tail}")
                    s = score_run(self.dygslam, self.groundtruth, out, r)
                    # What the paced run measured (OUT/realtime.txt: key value lines).
                    report, rows = {}, []
                    path = os.path.join(out, "realtime.txt")
                    if os.path.exists(path):
                        for line in open(path):
                            parts = line.split()
                            if len(parts) == 2:
                                report[parts[0]] = float(parts[1])
                            elif len(parts) == 3 and parts[0] == "latency":
                                rows.append((float(parts[1]), float(parts[2])))
                    s["realtime"] = report
                    s["latency_rows"] = rows
                    s["frame_states"] = read_frame_states(os.path.join(out, "frames.csv"))
                    say(f"  ATE {fmt(s['ate'])} m (online {fmt(s['online_ate'])}), "
                        f"{int(report.get('frames', 0) - report.get('results', 0))} dropped, "
                        f"{int(report.get('late', 0))} late, latency median "
                        f"{fmt(report.get('latency_median_ms', float('nan')), 1)} ms")
                    rate.append(s)
            if self.decoded_bin:
                out = os.path.join(self.work, "decoded", f"full_{k + 1}")
                cmd = [self.decoded_bin, self.data, "--config", self.config, "--runs", "1"]
                commands["decoded"] = cmd
                say(f"System CPU on decoded frames run {k + 1}/{a.runs}")
                self.record_load()
                r = run(cmd, out + ".log")
                m = re.search(r"^\| 1 \| (\d+) \| ([\d.]+) \| ([\d.]+) \| ([\d.]+) \| ([\d.]+) \| ([\d.]+) \| (\d+)/(\d+) \|",
                              r["log"], re.M)
                if not m:
                    raise RunFailed(f"no result row in {out}.log")
                frames = int(m.group(1))
                decoded.append({"frames": frames, "decode_ms": float(m.group(2)),
                                "system_ms": float(m.group(3)), "sum_ms": float(m.group(4)),
                                "fps": frames / float(m.group(5)) if float(m.group(5)) > 0 else float("nan"),
                                "ate": float(m.group(6)), "poses": int(m.group(7))})
                say(f"  System {m.group(3)} ms/frame, decoding {m.group(2)} ms/frame")
        self.results.update(ablation=ablation, dds=dds, rate=rate, decoded=decoded,
                            deterministic=deterministic, commands=commands)

    # memory over a longer run -----------------------------------------------------------------
    def memory(self):
        minutes = self.args.memory_minutes
        out = os.path.join(self.work, "memory")
        shutil.rmtree(out, ignore_errors=True)
        cmd = [self.dygslam, "run", self.data, "--config", self.config, "--loop-minutes",
               f"{minutes:g}", "--out", out, "--quiet"]
        say(f"memory: {minutes:g} minutes of the player replaying the sequence (DDS)")
        self.record_load()
        r = run(cmd, out + ".log", sample_rss_every=2.0)
        samples = r["rss"]
        end = samples[-1][0] if samples else 0
        half = [(t, y) for t, y in samples if end / 2 <= t <= end - 5]
        slope = float("nan")
        if len(half) > 2:
            n = len(half)
            sx = sum(t for t, _ in half)
            sy = sum(y for _, y in half)
            sxx = sum(t * t for t, _ in half)
            sxy = sum(t * y for t, y in half)
            if n * sxx != sx * sx:
                slope = (n * sxy - sx * sy) / (n * sxx - sx * sx) * 60.0  # MiB per minute

        def at(t):
            best = min(samples, key=lambda s: abs(s[0] - t)) if samples else None
            return best[1] if best else float("nan")

        m = re.search(r"^frames: (\d+) processed", r["log"], re.M)
        self.results["memory"] = {
            "cmd": cmd, "samples": samples, "peak": r["peak_rss_mib"], "slope": slope,
            "at_1min": at(60), "at_half": at(end / 2), "at_end": at(max(end - 5, 0)),
            "frames": int(m.group(1)) if m else None, "seconds": r["wall_s"],
            "cpu_ms_per_frame": 1000.0 * r["cpu_s"] / int(m.group(1)) if m else float("nan"),
        }

    # loop closing on the generated loops ------------------------------------------------------
    def render_loops(self):
        """Renders the missing loops (in parallel, before any timed run)."""
        pending = []
        self.loop_dirs = {}
        for name, _, synth_args in LOOPS:
            directory = os.path.join(self.cache, name)
            self.loop_dirs[name] = directory
            stamp = os.path.join(directory, ".synth_command")
            command = " ".join(synth_args)
            if synth_is_cached(directory, command):
                continue
            shutil.rmtree(directory, ignore_errors=True)
            os.makedirs(self.cache, exist_ok=True)
            cmd = [self.dygslam, "synth", directory] + synth_args + ["--quiet"]
            pending.append((name, directory, stamp, command, cmd))
        if not pending:
            self.loop_render_note = "The loops were reused from the cache (same `dygslam synth` command)"
            return
        say("rendering " + ", ".join(p[0] for p in pending) + " (once; cached for later runs)")
        t0 = time.monotonic()
        procs = []
        for name, directory, stamp, command, cmd in pending:
            log = open(os.path.join(self.cache, name + ".log"), "w")
            p = subprocess.Popen(cmd, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
            procs.append((p, log, name, stamp, command))
        try:
            for p, log, name, stamp, command in procs:
                if p.wait() != 0:
                    raise RunFailed(f"dygslam synth {name} failed (see {log.name})")
                log.close()
                with open(stamp, "w") as f:
                    f.write(command + "\n")
        finally:
            for p, *_ in procs:
                if p.poll() is None:
                    os.killpg(p.pid, signal.SIGTERM)
        self.loop_render_note = (f"The loops were rendered in this run ({time.monotonic() - t0:.0f} s, "
                                 "before the loop runs; reused by later runs)")

    def loops(self):
        self.render_loops()
        results = {}
        for name, title, synth_args in LOOPS:
            directory = self.loop_dirs[name]
            camera = os.path.join(directory, "camera.yaml")
            off = os.path.join(self.work, "loops", name + "_loop_closing_off.yaml")
            os.makedirs(os.path.dirname(off), exist_ok=True)
            with open(off, "w") as f:
                f.write(loop_closing_off(open(camera).read()))
            gt = os.path.join(directory, "groundtruth.txt")
            entry = {"title": title, "synth": [self.dygslam, "synth", "LOOPS/" + name] + synth_args,
                     "on": [], "off": []}
            for k in range(self.args.loop_runs):
                for mode, config in (("on", camera), ("off", off)):
                    out = os.path.join(self.work, "loops", f"{name}_{mode}_{k + 1}")
                    shutil.rmtree(out, ignore_errors=True)
                    cmd = [self.dygslam, "run", directory, "--config", config, "--filter", "none",
                           "--direct", "--no-map", "--out", out, "--quiet"]
                    entry["cmd_" + mode] = cmd
                    say(f"{name} loop closing {mode} run {k + 1}/{self.args.loop_runs}")
                    self.record_load()
                    r = run(cmd, out + ".log")
                    s = score_run(self.dygslam, gt, out, r,
                                  os.path.join(self.work, "loops", f"{name}_{mode}_{k + 1}_aligned"))
                    m = re.search(r"^loop closing: (\d+) loops closed", r["log"], re.M)
                    s["loops_closed"] = int(m.group(1)) if m else None
                    s["gt"] = gt
                    say(f"  ATE {fmt(s['ate'])} m, {s['loops_closed']} loops")
                    entry[mode].append(s)
            results[name] = entry
        self.results["loops"] = results

    # the filter where nobody is in view, and the start-frame spread ---------------------------
    def filter_sensitivity(self):
        """bonn frames 0:110 per filter, the whole run from 8 start entries and the generated
        crowds, with and without the planar-to-line conversion of the anchor residual."""
        work = os.path.join(self.work, "sensitivity")
        os.makedirs(work, exist_ok=True)
        planar_off = write_planar_as_line(self.config, os.path.join(work, "planar_as_line.yaml"))
        variants = (("full", self.config, "full"), ("planar_off", planar_off, "full"))

        def one(name, data, groundtruth, config, filter_mode, extra):
            out = os.path.join(work, name)
            shutil.rmtree(out, ignore_errors=True)
            cmd = [self.dygslam, "run", data, "--config", config, "--filter", filter_mode,
                   "--direct", "--no-map", "--out", out, "--quiet"] + extra
            self.record_load()
            r = run(cmd, out + ".log")
            s = score_run(self.dygslam, groundtruth, out, r, os.path.join(work, name + "_aligned"))
            s["by_state"] = rmse_by_state(groundtruth, s["aligned"] + "_final.txt",
                                          os.path.join(out, "frames.csv"))
            s["cmd"] = cmd
            return s

        empty = {}
        for name, config, mode in (("none", self.config, "none"),) + variants:
            say(f"frames 0:110 (nobody in view), {name}")
            empty[name] = one(f"empty_{name}", self.data, self.groundtruth, config, mode,
                              ["--frames", "0:110"])
        starts = {name: [] for name, _, _ in variants}
        for k in STARTS:
            for name, config, mode in variants:
                say(f"whole run from entry {k}, {name}")
                s = one(f"start{k}_{name}", self.data, self.groundtruth, config, mode,
                        ["--frames", f"{k}:"])
                say(f"  ATE {fmt(s['ate'])} m (online {fmt(s['online_ate'])})")
                starts[name].append(s)
        crowds = {}
        for cname, synth_args in CROWDS:
            directory = self.synth_cached(cname, synth_args)
            gt = os.path.join(directory, "groundtruth.txt")
            crowds[cname] = {"synth": [self.dygslam, "synth", "LOOPS/" + cname] + synth_args}
            for name, config, mode in variants:
                say(f"{cname}, {name}")
                camera = os.path.join(directory, "camera.yaml")
                config = camera if name == "full" else write_planar_as_line(
                    camera, os.path.join(work, cname + "_planar_as_line.yaml"))
                crowds[cname][name] = one(f"{cname}_{name}", directory, gt, config, mode,
                                          ["--detections", os.path.join(directory, "detections.txt")])
        self.results["sensitivity"] = {"empty": empty, "starts": starts, "crowds": crowds}

    # a person filling the view ---------------------------------------------------------------
    def crowd_stretch(self):
        """Generated sequences where a walker covers 60/80/95 % of the view for 1 s: per filter
        mode, whole-run ATE and the drift across the stretch, against the same run without it."""
        work = os.path.join(self.work, "stretch")
        os.makedirs(work, exist_ok=True)
        before = STRETCH["start"] - 1
        after = STRETCH["start"] + 2 * STRETCH["ramp"] + STRETCH["frames"]
        variants = [("none", None, False)] + [
            (f"{variant}_{c}", c, variant == "undetected")
            for c in COVERAGES for variant in ("boxed", "undetected")]
        results = {"before": before, "after": after, "variants": [v[0] for v in variants]}
        for seed in STRETCH_SEEDS:
            for name, coverage, undetected in variants:
                synth_args = ["--frames", str(STRETCH["length"]), "--objects", "0", "--noise",
                              "--seed", str(seed)]
                if coverage is not None:
                    synth_args += ["--occluder", str(coverage), "--occluder-from",
                                   str(STRETCH["start"]), "--occluder-frames", str(STRETCH["frames"])]
                    if undetected:
                        synth_args.append("--occluder-undetected")
                directory = self.synth_cached(f"stretch_s{seed}_{name}", synth_args)
                gt = os.path.join(directory, "groundtruth.txt")
                for mode in STRETCH_MODES:
                    key = f"s{seed}_{name}_{mode}"
                    out = os.path.join(work, key)
                    shutil.rmtree(out, ignore_errors=True)
                    cmd = [self.dygslam, "run", directory, "--config",
                           os.path.join(directory, "camera.yaml"), "--filter", mode, "--detections",
                           os.path.join(directory, "detections.txt"), "--direct", "--no-map",
                           "--out", out, "--quiet"]
                    say(f"person filling the view: seed {seed}, {name}, {mode}")
                    self.record_load()
                    r = run(cmd, out + ".log")
                    sc = score_run(self.dygslam, gt, out, r)
                    sc["drift"] = relative_pose_error(gt, os.path.join(out, "trajectory.txt"),
                                                      before, after)
                    sc["cmd"] = cmd
                    sc["synth"] = [self.dygslam, "synth", directory] + synth_args
                    del sc["log"]
                    results[key] = sc
        self.results["stretch"] = results

    # the pose priors (local BA, tracking) -----------------------------------------------------
    def pose_prior(self, which):
        """The runs of the sections above once more with one pose prior off (PRIORS[which]): bonn
        from the 8 start entries, the generated crowds, the walker filling the view (full filter)
        and the loops (one run each; loop closing on, no filter, as in the loop table)."""
        work = os.path.join(self.work, which)
        os.makedirs(work, exist_ok=True)
        key = PRIORS[which]["key"]

        def write_without_pose_prior(config, path):
            return write_without(config, path, key)

        def one(name, data, groundtruth, config, extra):
            out = os.path.join(work, name)
            shutil.rmtree(out, ignore_errors=True)
            cmd = [self.dygslam, "run", data, "--config", config, "--direct", "--no-map", "--out",
                   out, "--quiet"] + extra
            say(f"without {key}: {name}")
            self.record_load()
            r = run(cmd, out + ".log")
            s = score_run(self.dygslam, groundtruth, out, r)
            s["cmd"] = cmd
            del s["log"]
            return s

        off = {}
        bonn_off = write_without_pose_prior(self.config, os.path.join(work, "bonn_without.yaml"))
        off["bonn"] = [one(f"bonn_start{k}", self.data, self.groundtruth, bonn_off,
                           ["--filter", "full", "--frames", f"{k}:"]) for k in STARTS]
        for cname, _ in CROWDS:
            directory = os.path.join(self.cache, cname)
            config = write_without_pose_prior(os.path.join(directory, "camera.yaml"),
                                              os.path.join(work, cname + "_without.yaml"))
            off[cname] = one(cname, directory, os.path.join(directory, "groundtruth.txt"), config,
                             ["--filter", "full", "--detections",
                              os.path.join(directory, "detections.txt")])
        for seed in STRETCH_SEEDS:
            for name in ["none"] + [f"boxed_{c}" for c in COVERAGES]:
                directory = os.path.join(self.cache, f"stretch_s{seed}_{name}")
                config = write_without_pose_prior(os.path.join(directory, "camera.yaml"),
                                                  os.path.join(work, f"s{seed}_{name}.yaml"))
                off[f"s{seed}_{name}"] = one(
                    f"stretch_s{seed}_{name}", directory, os.path.join(directory, "groundtruth.txt"),
                    config, ["--filter", "full", "--detections",
                             os.path.join(directory, "detections.txt")])
        for name, _, _ in LOOPS:
            directory = self.loop_dirs[name]
            config = write_without_pose_prior(os.path.join(directory, "camera.yaml"),
                                              os.path.join(work, name + "_without.yaml"))
            off[name] = one(name, directory, os.path.join(directory, "groundtruth.txt"), config,
                            ["--filter", "none"])
        self.results[which] = off

    def render_pose_prior(self, L, which):
        """The section comparing the runs with and without one pose prior (PRIORS[which])."""
        prior = PRIORS[which]
        L.append(f"## {prior['title']}\n")
        off = self.results.get(which)
        R = self.results
        if not off or not R.get("sensitivity") or not R.get("stretch") or not R.get("loops"):
            L.append("Not measured (`--quick`).\n")
            return
        L.append(f"{prior['what']} (`{prior['key']}`, on by default; how it works: "
                 "docs/how_it_works.md). The same runs as in the sections above, without it: "
                 "bonn_crowd_part from the 8 start entries (median, range), the generated crowds, "
                 "the walker filling the view (full filter; median over the seeds, the ratio to "
                 "the run without the walker per seed) and the loops (loop closing on, no filter; "
                 "with the prior: the median of the loop table's runs, without: one run).\n")
        L.append("| sequence | final ATE with (m) | final ATE without (m) | online ATE with (m) | "
                 "online ATE without (m) | poses / frames with, without |")
        L.append("|---|---|---|---|---|---|")

        def row(label, on, without, ratio_on=None, ratio_off=None):
            on, without = list(on), list(without)
            extra_on = f" ({fmt(median(ratio_on), 2)}x)" if ratio_on else ""
            extra_off = f" ({fmt(median(ratio_off), 2)}x)" if ratio_off else ""
            L.append(f"| {label} | {med_range([r['ate'] for r in on])}{extra_on} | "
                     f"{med_range([r['ate'] for r in without])}{extra_off} | "
                     f"{med_range([r['online_ate'] for r in on])} | "
                     f"{med_range([r['online_ate'] for r in without])} | "
                     f"{poses_text(on)}, {poses_text(without)} |")

        row("bonn_crowd_part, 8 start entries", R["sensitivity"]["starts"]["full"], off["bonn"])
        for cname, _ in CROWDS:
            row(f"generated crowd {cname}", [R["sensitivity"]["crowds"][cname]["full"]],
                [off[cname]])
        st = R["stretch"]
        for name in [f"boxed_{c}" for c in COVERAGES] + ["none"]:
            on = [st[f"s{seed}_{name}_full"] for seed in STRETCH_SEEDS]
            without = [off[f"s{seed}_{name}"] for seed in STRETCH_SEEDS]
            label = ("walker: none" if name == "none" else
                     f"walker boxed, covers {int(round(float(name.split('_')[1]) * 100))} %")
            ratio_on = [r["ate"] / st[f"s{seed}_none_full"]["ate"]
                        for seed, r in zip(STRETCH_SEEDS, on) if st[f"s{seed}_none_full"]["ate"]]
            ratio_off = [r["ate"] / off[f"s{seed}_none"]["ate"]
                         for seed, r in zip(STRETCH_SEEDS, without) if off[f"s{seed}_none"]["ate"]]
            row(label, on, without, ratio_on if name != "none" else None,
                ratio_off if name != "none" else None)
        for name, title, _ in LOOPS:
            row(title, R["loops"][name]["on"], [off[name]])
        L.append("")
        L.append("```")
        L.append(self.cmdline(off["bonn"][0]["cmd"]))
        L.append("```\n")

    def render_stretch(self, L):
        """The section on a person filling the view (generated)."""
        L.append("## A person filling the view (generated)\n")
        st = self.results.get("stretch")
        if not st:
            L.append("Not measured (`--quick`).\n")
            return
        L.append(f"`dygslam synth --occluder C`: in a static textured room, a walker moving along "
                 f"with the handheld camera, 0.9 m in front of it, slides in from the right over "
                 f"{STRETCH['ramp']} frames, covers the share C of the image (full height) for "
                 f"{STRETCH['frames']} frames (1 s) from entry {STRETCH['start'] + STRETCH['ramp']}, "
                 f"and slides out; {STRETCH['length']} frames with depth and colour noise. Boxed: its "
                 "ground-truth box is in detections.txt; undetected: never (a missed person). "
                 f"Drift across the stretch: the error of the estimated motion from entry "
                 f"{st['before']} (before the walker) to entry {st['after']} (after it), translation "
                 "and rotation (the `none` rows: the same over the same frames without a walker). Figures: median "
                 f"over seeds {', '.join(str(x) for x in STRETCH_SEEDS)} (range of poses / frames). "
                 "The ratio compares the final ATE with the same seed and filter without the walker.\n")
        L.append("| walker | filter | final ATE (m) | online ATE (m) | ATE / no walker | "
                 "drift across the stretch (cm, deg) | poses / frames |")
        L.append("|---|---|---|---|---|---|---|")
        for name in st["variants"]:
            label = "none"
            if name != "none":
                variant, c = name.split("_")
                label = f"{variant}, covers {int(round(float(c) * 100))} %"
            for mode in STRETCH_MODES:
                runs = [st[f"s{seed}_{name}_{mode}"] for seed in STRETCH_SEEDS]
                base = [st[f"s{seed}_none_{mode}"]["ate"] for seed in STRETCH_SEEDS]
                ratios = [r["ate"] / b for r, b in zip(runs, base) if b and b == b]
                drift_cm = [r["drift"][0] * 100 for r in runs if r["drift"]]
                drift_deg = [r["drift"][1] for r in runs if r["drift"]]
                drift = (f"{fmt(median(drift_cm), 2)}, {fmt(median(drift_deg), 2)}"
                         if len(drift_cm) == len(runs) else "no pose at an end")
                L.append(f"| {label} | `{mode}` | {fmt(median([r['ate'] for r in runs]))} | "
                         f"{fmt(median([r['online_ate'] for r in runs]))} | "
                         f"{fmt(median(ratios), 2) if ratios else '-'}x | {drift} | "
                         f"{poses_text(runs)} |")
        L.append("")
        r = st[f"s{STRETCH_SEEDS[0]}_boxed_{COVERAGES[-1]}_full"]
        L.append("```")
        L.append(self.cmdline(r["synth"]))
        L.append(self.cmdline(r["cmd"]))
        L.append("```\n")

    def synth_cached(self, name, synth_args):
        """A `dygslam synth` sequence in the cache, rendered once per command."""
        directory = os.path.join(self.cache, name)
        stamp = os.path.join(directory, ".synth_command")
        command = " ".join(synth_args)
        if not synth_is_cached(directory, command):
            shutil.rmtree(directory, ignore_errors=True)
            os.makedirs(self.cache, exist_ok=True)
            say(f"rendering {name} (once; cached for later runs)")
            run([self.dygslam, "synth", directory] + synth_args + ["--quiet"],
                os.path.join(self.cache, name + ".log"))
            with open(stamp, "w") as f:
                f.write(command + "\n")
        return directory

    # map reuse --------------------------------------------------------------------------------
    def map_reuse(self):
        rounds = []
        for k in range(self.args.map_runs):
            base = os.path.join(self.work, "map_reuse", f"round_{k + 1}")
            shutil.rmtree(base, ignore_errors=True)
            os.makedirs(base)
            map_file = os.path.join(base, "crowd.dygmap")
            save = [self.dygslam, "run", self.data, "--config", self.config, "--direct",
                    "--save-map", map_file, "--out", os.path.join(base, "mapping"), "--quiet"] + self.frames
            loc = [self.dygslam, "run", self.data, "--config", self.config, "--direct",
                   "--load-map", map_file, "--localization", "--out",
                   os.path.join(base, "localization"), "--quiet"] + self.frames
            say(f"map reuse round {k + 1}/{self.args.map_runs}: mapping, then localization")
            self.record_load()
            r1 = run(save, os.path.join(base, "mapping.log"))
            s1 = score_run(self.dygslam, self.groundtruth, os.path.join(base, "mapping"), r1)
            self.record_load()
            r2 = run(loc, os.path.join(base, "localization.log"))
            s2 = score_run(self.dygslam, self.groundtruth, os.path.join(base, "localization"), r2)
            m = re.search(r"map file: saved \S+ \(([^)]*)\)", r1["log"])
            s1["map_text"] = m.group(1) if m else ""
            s1["map_bytes"] = os.path.getsize(map_file) if os.path.exists(map_file) else 0
            say(f"  mapping ATE {fmt(s1['ate'])}, localization ATE {fmt(s2['ate'])} m")
            rounds.append((s1, s2))
        self.results["map_reuse"] = {"rounds": rounds, "save": save, "loc": loc}

    # map quality: ghost voxels ----------------------------------------------------------------
    def map_quality(self):
        first = int(self.args.frames.split(":")[0] or 0) if self.args.frames else 0
        until = 100
        if first >= until:
            self.results["map_quality"] = None
            self.notes.append("map quality not measured: the frame range starts after rgb entry "
                              f"{until} (the people-free reference needs the frames before it)")
            return
        rows = {"masks": [], "no_masks": []}
        cmds = {}
        for k in range(self.args.map_runs):
            for mode in ("masks", "no_masks"):
                out = os.path.join(self.work, "map_quality", f"{mode}_{k + 1}")
                shutil.rmtree(out, ignore_errors=True)
                cmd = [self.dygslam, "map", self.data, "--config", self.config,
                       "--reference-until", str(until), "--out", out, "--quiet"] + self.frames
                if mode == "no_masks":
                    cmd.append("--no-mask")
                cmds[mode] = cmd
                say(f"map quality ({mode}) run {k + 1}/{self.args.map_runs}")
                self.record_load()
                r = run(cmd, out + ".log")
                m = re.search(r"^ghost voxels: ([\d,]+) .*?map occupied ([\d,]+), reference occupied ([\d,]+)",
                              r["log"], re.M)
                if not m:
                    raise RunFailed(f"no 'ghost voxels:' line in {out}.log")
                as_int = lambda s: int(s.replace(",", ""))
                rows[mode].append({"ghost": as_int(m.group(1)), "occupied": as_int(m.group(2)),
                                   "reference": as_int(m.group(3))})
                say(f"  ghost voxels {m.group(1)} of {m.group(2)} occupied")
        self.results["map_quality"] = {"rows": rows, "cmds": cmds, "until": until}

    # pictures ---------------------------------------------------------------------------------
    def draw(self):
        try:
            import matplotlib
            matplotlib.use("Agg")
            import matplotlib.pyplot as plt
        except ImportError:
            self.notes.append("pictures not drawn: python3-matplotlib is not installed for "
                              f"{sys.executable}")
            return
        os.makedirs(self.figures_stage, exist_ok=True)
        gt = read_tum(self.groundtruth)

        def save(fig, name):
            fig.tight_layout()
            fig.savefig(os.path.join(self.figures_stage, name), dpi=80)
            plt.close(fig)
            self.figures.append(name)

        # Ablation: the median run of each method, top view and ATE over time.
        ablation = self.results.get("ablation") or {}
        series = []
        for config in ABLATION:
            runs = [r for r in ablation.get(config, []) if math.isfinite(r["ate"])]
            if not runs:
                continue
            mid = sorted(runs, key=lambda r: r["ate"])[(len(runs) - 1) // 2]
            path = mid["aligned"] + "_final.txt"
            if os.path.exists(path):
                series.append((config, f"{LABELS[config]}: {mid['ate']:.4f} m", read_tum(path)))
        if series:
            fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(12, 5))
            draw_top_view(ax0, gt, series, lambda c: COLOURS[c])
            draw_error_over_time(ax1, gt, series, lambda c: COLOURS[c])
            ax0.set_title("bonn_crowd_part: ground truth and aligned estimates (top view)")
            ax1.set_title("ATE over time (median run of each method)")
            ax1.set_yscale("log")
            save(fig, "accuracy_ablation.png")

        memory = self.results.get("memory")
        if memory and memory["samples"]:
            fig, ax = plt.subplots(figsize=(8, 4))
            ax.plot([t / 60 for t, _ in memory["samples"]], [y for _, y in memory["samples"]],
                    color=COLOURS["full"], label="resident memory of `dygslam run` (DDS pipeline)")
            ax.set_xlabel("minutes")
            ax.set_ylabel("MiB")
            ax.legend(loc="lower right")
            ax.grid(alpha=0.3)
            save(fig, "memory_rss.png")

        rate = [r for r in self.results.get("rate") or [] if r.get("latency_rows")]
        if rate:
            fig, ax = plt.subplots(figsize=(10, 4))
            states = rate[0]["frame_states"]
            index = {stamp: k for k, stamp in enumerate(sorted(states))}
            # The frames the dense fallback tracked and the keyframes, from the first run's
            # frames.csv (the trajectory is the same in every run).
            for stamp, (state, keyframe) in states.items():
                if state == "fallback":
                    ax.axvspan(index[stamp] - 0.5, index[stamp] + 0.5, color="#f4c7c3", lw=0)
                elif keyframe:
                    ax.axvspan(index[stamp] - 0.5, index[stamp] + 0.5, color="#d9e7f7", lw=0)
            for k, r in enumerate(rate):
                pts = sorted((index[round(t, 6)], ms) for t, ms in r["latency_rows"]
                             if round(t, 6) in index)
                ax.plot([p for p, _ in pts], [ms for _, ms in pts], lw=1,
                        label=f"run {k + 1}" if k < 5 else None)
            ax.axhline(100, color="grey", ls="--", lw=1, label="late: 3 frame periods")
            ax.set_xlabel("frame (blue: keyframe, red: dense fallback)")
            ax.set_ylabel("frame to pose (ms)")
            ax.set_yscale("log")
            ax.set_title("`dygslam run --rate 1`: latency of each frame")
            ax.legend(loc="upper left", fontsize=8)
            ax.grid(alpha=0.3)
            save(fig, "realtime_latency.png")

        loops = self.results.get("loops") or {}
        if loops:
            fig, axes = plt.subplots(1, len(loops), figsize=(6 * len(loops), 5), squeeze=False)
            for ax, (name, entry) in zip(axes[0], loops.items()):
                loop_series = []
                for mode, label in (("on", "loop closing on (default)"), ("off", "loop closing off")):
                    runs = [r for r in entry[mode] if math.isfinite(r["ate"])]
                    if not runs:
                        continue
                    mid = sorted(runs, key=lambda r: r["ate"])[(len(runs) - 1) // 2]
                    path = mid["aligned"] + "_final.txt"
                    if os.path.exists(path):
                        loop_series.append(("loop_" + mode, f"{label}: {mid['ate']:.4f} m",
                                            read_tum(path)))
                if loop_series:
                    draw_top_view(ax, read_tum(entry["on"][0]["gt"]), loop_series,
                                  lambda c: COLOURS[c])
                ax.set_title(entry["title"])
            save(fig, "loop_closing.png")

    # the documents ------------------------------------------------------------------------------
    def render(self, started, finished, elapsed, out_path, figures_dir):
        a = self.args
        R = self.results
        rel_fig = os.path.relpath(figures_dir, os.path.dirname(os.path.abspath(out_path)))
        fig = lambda name: f"{rel_fig}/{name}"
        cmd = self.cmdline
        commit = git("rev-parse", "--short=12", "HEAD") or "unknown"
        ignored = {os.path.relpath(os.path.abspath(p), REPO)
                   for p in (out_path, a.readme)} | {os.path.relpath(figures_dir, REPO)}
        dirty_lines = [l for l in git("status", "--porcelain").splitlines()
                       if not any(l[3:].startswith(p) for p in ignored)]
        loads = [x for x in self.load_samples if math.isfinite(x)]
        L = []
        L.append("# dygslam benchmarks\n")
        L.append("Generated by `make bench` (`scripts/make_benchmarks.py`) from the commit below; do not edit by "
                 "hand: the whole file is rewritten. Every table gives the command lines that produced it "
                 "(`DATA` = the bonn_crowd_part folder, `OUT` = a scratch folder, `dygslam` = the binary of "
                 "the build). Figures are medians over the runs with the range (min–max) in brackets; "
                 "\"poses / frames\" are the frames with a pose out of the frames processed (a range "
                 "when the runs differ). ATE = RMSE of the absolute trajectory error after rigid SE(3) "
                 "alignment (`dygslam eval`, TUM conventions, metres). *Final* is `trajectory.txt` (the "
                 "refined trajectory at the end of the run); *online* is `trajectory_online.txt` (the "
                 "pose published for each frame at the moment it was tracked).\n")
        L.append("| | |\n|---|---|")
        L.append(f"| commit | `{commit}`" + (f" with uncommitted changes ({len(dirty_lines)} file{'s' if len(dirty_lines) > 1 else ''})" if dirty_lines else " (clean tree)") + " |")
        L.append(f"| date | {started} to {finished} ({elapsed / 60:.0f} min) |")
        L.append(f"| machine | {machine_text()} |")
        L.append(f"| load average (1 min) | {fmt(loads[0], 2) if loads else '-'} at the start, median "
                 f"{fmt(median(loads), 2)} over the runs, max {fmt(max(loads), 2) if loads else '-'}; "
                 f"1/5/15 min at the end: {loadavg_text()}. A load above the {os.cpu_count()} cores "
                 "means other jobs shared them: timings are then slower than on a quiet machine "
                 "(accuracy is not affected) |")
        L.append(f"| runs | {a.runs} per configuration (accuracy, schedule, speed); {a.map_runs} (map reuse, "
                 f"map quality); {a.loop_runs if not a.quick else 0} per loop and mode |")
        L.append(f"| data | bonn_crowd_part (360 frames of the Bonn RGB-D Dynamic `crowd` sequence, "
                 f"ground truth `groundtruth.txt`, marker body){'; rgb.txt entries ' + a.frames if a.frames else ''} |")
        L.append("| settings | `config/bonn.yaml` as shipped (sensor and ORB); every other setting at its default |")
        L.append(f"| mode | {'quick (development check: 1 run, fewer sections)' if a.quick else 'full'} |")
        L.append("")
        L.append("Regenerate: `make bench` (BUILD_DIR, BENCH_ARGS; `make bench BENCH_ARGS=--quick` for a "
                 "short check).\n")
        if self.notes:
            L.append("Notes of this run:\n")
            L.extend(f"- {n}" for n in self.notes)
            L.append("")

        # Accuracy and ablation.
        ab = R.get("ablation") or {}
        L.append("## Accuracy and ablation (bonn_crowd_part)\n")
        L.append("`paper` is DYG-SLAM's filter as the paper writes it (person boxes, epipolar probability, "
                 "Kalman filter); `boxes` removes every feature in a person box; `geometry` uses the "
                 "depth-residual test alone; `full` is the default (README, *How it works*). Direct "
                 "library loop (`--direct`), map on, local mapping and loop closing on their threads.\n")
        L.append("| method | final ATE (m) | poses / frames | online ATE (m) | online poses / frames |")
        L.append("|---|---|---|---|---|")
        for config in ABLATION:
            runs = ab.get(config) or []
            if not runs:
                continue
            L.append(f"| `{config}`: {LABELS[config]} | {med_range([r['ate'] for r in runs])} | "
                     f"{poses_text(runs)} | {med_range([r['online_ate'] for r in runs])} | "
                     f"{poses_text(runs, 'online_poses')} |")
        L.append("")
        if "none" in R.get("commands", {}):
            L.append("```")
            L.append(cmd(R["commands"]["none"]).replace("--filter none", "--filter METHOD"))
            L.append(f"dygslam eval DATA/groundtruth.txt OUT/trajectory.txt --json          # final")
            L.append(f"dygslam eval DATA/groundtruth.txt OUT/trajectory_online.txt --json   # online")
            L.append("```\n")
        L.append("RPE is not given for Bonn: its ground truth is the pose of the motion-capture marker "
                 "body, not of the camera, so a relative error per second mixes the marker-to-camera "
                 "offset into the figure; ATE after alignment is what published tables report.\n")
        if "accuracy_ablation.png" in self.figures:
            L.append(f"![bonn_crowd_part: aligned trajectories and ATE over time, median run of each method]"
                     f"({fig('accuracy_ablation.png')})\n")

        # Schedule / live.
        L.append("## Schedule: the default command (live)\n")
        dds = R.get("dds") or []
        if not self.dds_ok:
            L.append(f"Not measured: {self.dds_reason}.\n")
        else:
            L.append("What a user gets from `dygslam run` with the shipped settings: the DDS pipeline "
                     "(player, detector, slam, mapper, recorder as threads of one process), the full "
                     "filter, map on. The player sends frames as fast as the pipeline takes them.\n")
            L.append("| command | final ATE (m) | poses / frames | online ATE (m) | online poses / frames | frames/s |")
            L.append("|---|---|---|---|---|---|")
            L.append(f"| default (DDS) | {med_range([r['ate'] for r in dds])} | {poses_text(dds)} | "
                     f"{med_range([r['online_ate'] for r in dds])} | {poses_text(dds, 'online_poses')} | "
                     f"{med_range([r['fps'] for r in dds], 1)} |")
            rate = R.get("rate") or []
            if rate:
                L.append(f"| `--rate 1` (camera rate) | {med_range([r['ate'] for r in rate])} | {poses_text(rate)} | "
                         f"{med_range([r['online_ate'] for r in rate])} | {poses_text(rate, 'online_poses')} | "
                         f"{med_range([r['fps'] for r in rate], 1)} |")
            L.append("")
            L.append("```")
            L.append(cmd(R["commands"]["dds"]))
            if rate:
                L.append(cmd(R["commands"]["rate"]))
            L.append("```\n")
            if rate:
                rt = lambda key: [r["realtime"].get(key, float("nan")) for r in rate]
                dropped = [int(r["realtime"].get("frames", 0) - r["realtime"].get("results", 0))
                           for r in rate if r["realtime"]]
                L.append("`--rate 1`: the player sends the frames at the camera's rate (30 Hz); frames "
                         "the pipeline cannot take in time are dropped; a result is late when it comes "
                         "more than 3 frame periods after its frame; latency = frame to pose "
                         "(`OUT/realtime.txt`).\n")
                L.append("| frames | dropped | late | latency median (ms) | latency 99th percentile (ms) |")
                L.append("|---|---|---|---|---|")
                L.append(f"| {int_range([int(v) for v in rt('frames') if math.isfinite(v)])} | "
                         f"{int_range(dropped)} | {int_range([int(v) for v in rt('late') if math.isfinite(v)])} | "
                         f"{med_range(rt('latency_median_ms'), 1)} | {med_range(rt('latency_p99_ms'), 1)} |")
                L.append("")
                if "realtime_latency.png" in self.figures:
                    L.append("Each frame's latency (`latency` rows of `OUT/realtime.txt`), over the "
                             "frames' states in `OUT/frames.csv`:\n")
                    L.append(f"![frame-to-pose latency of each frame, --rate 1]"
                             f"({fig('realtime_latency.png')})\n")
            else:
                L.append("`--rate 1` (the dataset played at the camera's rate): not measured: "
                         "`dygslam run` has no `--rate` option in this build.\n")

        # Speed and CPU per stage.
        L.append("## Speed and CPU per stage (direct loop)\n")
        L.append("Same runs as the accuracy table. frames/s as `dygslam run` reports it (frames / wall "
                 "time of the run, PNG decoding and start-up included). CPU = user + system time of "
                 "the process over all its threads / frames (decoding, detector, local mapping, loop "
                 "closing, mapper and start-up included). Stage columns: mean milliseconds per frame "
                 "from `frames.csv` (wall time on the tracking thread; the detector runs beside ORB "
                 "extraction); \"total\" is the wall time of one frame through `FeedRgbdFrame`, mean "
                 "and median. Peak memory: maximum resident set of the process.\n")
        L.append("| method | frames/s | CPU ms / frame | ORB extraction | detection | matching | probability | tracking | total (mean) | total (median) | peak memory (MiB) |")
        L.append("|---|---|---|---|---|---|---|---|---|---|---|")
        for config in ABLATION:
            runs = ab.get(config) or []
            if not runs:
                continue
            st = lambda key: stage_text([r["stages"].get(key, float("nan")) for r in runs])
            L.append(f"| `{config}` | {med_range([r['fps'] for r in runs], 1)} | "
                     f"{med_range([r['cpu_ms_per_frame'] for r in runs], 1)} | {st('orb_ms')} | "
                     f"{st('detection_ms')} | {st('matching_ms')} | {st('probability_ms')} | "
                     f"{st('tracking_ms')} | {st('total_ms')} | {st('total_median_ms')} | "
                     f"{med_range([r['peak_rss_mib'] for r in runs], 0)} |")
        if dds:
            st = lambda key: stage_text([r["stages"].get(key, float("nan")) for r in dds])
            L.append(f"| `full`, default DDS mode | {med_range([r['fps'] for r in dds], 1)} | "
                     f"{med_range([r['cpu_ms_per_frame'] for r in dds], 1)} | {st('orb_ms')} | "
                     f"{st('detection_ms')} | {st('matching_ms')} | {st('probability_ms')} | "
                     f"{st('tracking_ms')} | {st('total_ms')} | {st('total_median_ms')} | "
                     f"{med_range([r['peak_rss_mib'] for r in dds], 0)} |")
        L.append("")
        if "none" in R.get("commands", {}):
            L.append("```")
            L.append(cmd(R["commands"]["none"]).replace("--filter none", "--filter METHOD"))
            if dds:
                L.append(cmd(R["commands"]["dds"]))
            L.append("```\n")
        # Local mapping per keyframe.
        L.append("### Local mapping per keyframe\n")
        L.append("From the run summary (`local mapping schedule`): the local BA's solve (wall time "
                 "on the mapping thread, median over the keyframes; in a `--deterministic` run it is "
                 "solved in tracking's thread with nothing beside it, the cost of the solve alone), "
                 "the part of local mapping in tracking's thread, and the local BAs not done when "
                 "their result was due (tracking waited for them; the budget is 2 frame periods) or "
                 "landed early because the next keyframe came first.\n")
        L.append("| run | keyframes | local BA solve (ms, median) | in tracking's thread (ms, median) | late | tracking waited (ms, in all) | landed early |")
        L.append("|---|---|---|---|---|---|---|")
        lm_rows = [("`--deterministic` (direct)", R.get("deterministic") or []),
                   ("`full` (direct)", ab.get("full") or []),
                   ("default (DDS)", dds), ("`--rate 1`", R.get("rate") or [])]
        for name, runs in lm_rows:
            runs = [r for r in runs if r.get("local_mapping", {}).get("solve_ms") is not None]
            if not runs:
                continue
            lm = lambda key, digits=1: med_range([r["local_mapping"].get(key, float("nan")) for r in runs], digits)
            L.append(f"| {name} | {int_range([r['local_mapping'].get('keyframes', 0) for r in runs])} | "
                     f"{lm('solve_ms')} | {lm('tracking_ms')} | "
                     f"{int_range([r['local_mapping']['late'] for r in runs])} | {lm('waited_ms', 0)} | "
                     f"{int_range([r['local_mapping']['early'] for r in runs])} |")
        L.append("")
        if "deterministic" in R.get("commands", {}):
            L.append("```")
            L.append(cmd(R["commands"]["deterministic"]))
            L.append("```\n")
        decoded = R.get("decoded") or []
        L.append("### CPU per frame on decoded frames (the robot case)\n")
        if decoded:
            L.append("The frames decoded into memory first (a camera driver hands over raw images), "
                     "then fed to the System (full method, shipped settings) as fast as it takes them; "
                     "CPU of the process over all threads from the first frame to the end of local "
                     "mapping, without start-up (models, vocabulary). PNG decoding is measured alone, "
                     "one frame at a time as the run's loader decodes (each frame released before the "
                     "next; the frames the feed holds are decoded in a second pass, not measured).\n")
            L.append("| System CPU ms / frame | PNG decoding CPU ms / frame | sum | feed frames/s | final ATE (m) | poses / frames |")
            L.append("|---|---|---|---|---|---|")
            L.append(f"| {med_range([r['system_ms'] for r in decoded], 1)} | "
                     f"{med_range([r['decode_ms'] for r in decoded], 1)} | "
                     f"{med_range([r['sum_ms'] for r in decoded], 1)} | "
                     f"{med_range([r['fps'] for r in decoded], 1)} | {med_range([r['ate'] for r in decoded])} | "
                     f"{poses_text(decoded)} |")
            L.append("")
            L.append("```")
            L.append(cmd(R["commands"]["decoded"]))
            L.append("```\n")
        else:
            L.append(f"Not measured: {self.decoded_reason}.\n")

        # DDS against direct.
        L.append("## DDS pipeline against the direct loop\n")
        full = ab.get("full") or []
        if not dds:
            L.append(f"Not measured: {self.dds_reason}.\n")
        else:
            ratios = [d["fps"] / f["fps"] for d, f in zip(dds, full) if f["fps"] > 0]
            L.append("The full method, shipped settings, map on; the two modes alternate in the same "
                     "rounds (each round: the direct run, then the DDS run), ratio per round.\n")
            L.append("| mode | frames/s | CPU ms / frame | final ATE (m) | poses / frames |")
            L.append("|---|---|---|---|---|")
            L.append(f"| direct (`--direct`) | {med_range([r['fps'] for r in full], 1)} | "
                     f"{med_range([r['cpu_ms_per_frame'] for r in full], 1)} | "
                     f"{med_range([r['ate'] for r in full])} | {poses_text(full)} |")
            L.append(f"| default (DDS, one process) | {med_range([r['fps'] for r in dds], 1)} | "
                     f"{med_range([r['cpu_ms_per_frame'] for r in dds], 1)} | "
                     f"{med_range([r['ate'] for r in dds])} | {poses_text(dds)} |")
            L.append(f"| **DDS / direct, frames/s** | **{med_range(ratios, 2)}** | | | |")
            L.append("")
            L.append("```")
            L.append(cmd(R["commands"]["full"]))
            L.append(cmd(R["commands"]["dds"]))
            L.append("```\n")

        # Memory.
        L.append("## Memory over a longer run\n")
        mem = R.get("memory")
        if not mem:
            L.append("Not measured: " + ("skipped in --quick mode" if a.quick else
                                         (self.dds_reason if not self.dds_ok else "no samples")) + ".\n")
        else:
            L.append(f"The default command with the player replaying bonn_crowd_part for "
                     f"{a.memory_minutes:g} minute{'s' if a.memory_minutes != 1 else ''} (stamps continue: one long sequence of "
                     f"{mem['frames'] or '?'} frames), resident memory of the process sampled every 2 s; "
                     "slope = least-squares line over the second half (the last 5 s, shutdown, left out).\n")
            L.append("| frames | peak RSS (MiB) | RSS at 1 min | at half | at end | slope, second half (MiB/min) | CPU ms / frame |")
            L.append("|---|---|---|---|---|---|---|")
            L.append(f"| {mem['frames'] or '-'} | {mem['peak']:.0f} | {fmt(mem['at_1min'], 0)} | "
                     f"{fmt(mem['at_half'], 0)} | {fmt(mem['at_end'], 0)} | {fmt(mem['slope'], 2)} | "
                     f"{fmt(mem['cpu_ms_per_frame'], 1)} |")
            L.append("")
            L.append("```")
            L.append(cmd(mem["cmd"]))
            L.append("```\n")
            if "memory_rss.png" in self.figures:
                L.append(f"![resident memory over the run]({fig('memory_rss.png')})\n")

        # Loop closing.
        L.append("## Loop closing on generated loops\n")
        loops = R.get("loops")
        if not loops:
            L.append("Not measured: skipped in --quick mode.\n")
        else:
            L.append("Sequences rendered by `dygslam synth` (textured rooms, depth and colour noise, no "
                     "people: `--filter none`); the camera goes once round and past its start. Loop "
                     "closing is on by default; *off* adds `LoopClosing: {enabled: false}` to the "
                     "sequence's camera.yaml. " + self.loop_render_note + ".\n")
            L.append("| loop | loop closing | final ATE (m) | poses / frames | online ATE (m) | loops closed (per run) | ATE off / on |")
            L.append("|---|---|---|---|---|---|---|")
            for name, e in loops.items():
                on = median([r["ate"] for r in e["on"]])
                off = median([r["ate"] for r in e["off"]])
                gain = off / on if on > 0 else float("nan")
                for mode in ("on", "off"):
                    runs = e[mode]
                    closed = ", ".join(str(r["loops_closed"]) for r in runs)
                    L.append(f"| {e['title']} | {mode}{' (default)' if mode == 'on' else ''} | "
                             f"{med_range([r['ate'] for r in runs])} | {poses_text(runs)} | "
                             f"{med_range([r['online_ate'] for r in runs])} | {closed} | "
                             f"{'**' + fmt(gain, 1) + 'x**' if mode == 'on' else ''} |")
            L.append("")
            L.append("```")
            for name, e in loops.items():
                L.append(cmd(e["synth"]))
                L.append(cmd(e["cmd_on"]).replace(self.loop_dirs[name], "LOOPS/" + name))
                L.append(cmd(e["cmd_off"]).replace(self.loop_dirs[name], "LOOPS/" + name)
                         + "   # camera.yaml + LoopClosing: {enabled: false}")
            L.append("```\n")
            if "loop_closing.png" in self.figures:
                L.append(f"![generated loops: ground truth and the median run with loop closing on and off]"
                         f"({fig('loop_closing.png')})\n")

        # Map reuse.
        L.append("## Map reuse: save, then localize\n")
        mr = R.get("map_reuse")
        if mr and mr["rounds"]:
            maps = [m for m, _ in mr["rounds"]]
            locs = [l for _, l in mr["rounds"]]
            L.append("A run saves its SLAM map (keyframes, map points, place-recognition index); a "
                     "second run over the same frames loads it and tracks against it without adding "
                     "keyframes or points (`--localization`).\n")
            L.append("| run | final ATE (m) | poses / frames | online ATE (m) | frames/s | map file |")
            L.append("|---|---|---|---|---|---|")
            L.append(f"| mapping (`--save-map`) | {med_range([r['ate'] for r in maps])} | {poses_text(maps)} | "
                     f"{med_range([r['online_ate'] for r in maps])} | {med_range([r['fps'] for r in maps], 1)} | "
                     f"{maps[0]['map_text'] or '-'}; {med_range([r['map_bytes'] / 1e6 for r in maps], 1)} MB |")
            L.append(f"| localization (`--load-map --localization`) | {med_range([r['ate'] for r in locs])} | "
                     f"{poses_text(locs)} | {med_range([r['online_ate'] for r in locs])} | "
                     f"{med_range([r['fps'] for r in locs], 1)} | |")
            ratio = [l["ate"] / m["ate"] for m, l in mr["rounds"] if m["ate"] > 0]
            L.append(f"| localization / mapping, final ATE per round | {med_range(ratio, 2)} | | | | |")
            L.append("")
            L.append("```")
            L.append(cmd(mr["save"]))
            L.append(cmd(mr["loc"]))
            L.append("```\n")
        else:
            L.append("Not measured.\n")

        self.render_sensitivity(L)
        self.render_stretch(L)
        for which in PRIORS:
            self.render_pose_prior(L, which)

        # Map quality.
        L.append("## Map quality: ghost voxels\n")
        mq = R.get("map_quality")
        if mq:
            rows = mq["rows"]
            L.append(f"`dygslam map` runs the SLAM and builds the OctoMap of the static scene from the "
                     f"keyframes; with `--reference-until {mq['until']}` it also builds a reference from "
                     f"the keyframes before rgb entry {mq['until']} (no person in view yet) and counts "
                     "*ghost voxels*: cells occupied in the map, observed free in the reference, with no "
                     "reference surface within one cell (people baked into the map). With masks is the "
                     "default (people's pixels left out of the map); `--no-mask` inserts every pixel.\n")
            L.append("| map | ghost voxels | occupied cells | reference occupied | ghost fraction |")
            L.append("|---|---|---|---|---|")
            for mode, label in (("masks", "with the dynamic masks (default)"), ("no_masks", "without masks (`--no-mask`)")):
                rs = rows[mode]
                L.append(f"| {label} | {med_range([r['ghost'] for r in rs], 0)} | "
                         f"{med_range([r['occupied'] for r in rs], 0)} | {med_range([r['reference'] for r in rs], 0)} | "
                         f"{med_range([100.0 * r['ghost'] / r['occupied'] for r in rs if r['occupied']], 2)} % |")
            gm, gn = median([r["ghost"] for r in rows["masks"]]), median([r["ghost"] for r in rows["no_masks"]])
            L.append(f"| **fewer with masks** | **{fmt(gn / gm, 1) + 'x' if gm > 0 else '-'}** | | | |")
            L.append("")
            L.append("```")
            L.append(cmd(mq["cmds"]["masks"]))
            L.append(cmd(mq["cmds"]["no_masks"]))
            L.append("```\n")
        else:
            L.append("Not measured (see the notes above).\n")

        # Published figures.
        published = os.path.join(REPO, "docs", "benchmarks", "published_figures.md")
        L.append(open(published).read().rstrip() + "\n")
        return "\n".join(L)

    def render_sensitivity(self, L):
        """The section on the filter where nobody is in view and the start-frame spread."""
        cmd = self.cmdline
        R = self.results
        L.append("## Where nobody is in view, and the start-frame spread\n")
        sv = R.get("sensitivity")
        if sv:
            def state_rmse(runs, state):
                values = [r["by_state"][state][1] for r in runs if state in r["by_state"]]
                return med_range(values) if values else "-"

            def state_count(runs, state):
                return int_range([r["by_state"].get(state, (0, 0))[0] for r in runs])

            names = {"none": "no filter", "full": "full method (default)",
                     "planar_off": "full, anchor residual taken as a 1-D distance "
                                   "(`DynamicFilter.planar_residual_to_line: 0`)"}
            L.append("The dynamic filter's depth-residual test compares a feature with where its "
                     "3-D anchor projects, a 2-D distance; eq. 5 of the paper was set for the 1-D "
                     "distance to an epipolar line. By default the residual is divided by "
                     "sqrt(2 ln 2) / 0.6745 = 1.75, the ratio of the two medians for the same "
                     "noise per axis (docs/how_it_works.md). Frames 0-110 of bonn_crowd_part have "
                     "nobody in view (motion blur in 42-75): there any feature the filter drops is "
                     "a static one. One run each (the runs are deterministic).\n")
            L.append("| frames 0:110 | final ATE (m) | online ATE (m) | poses / frames |")
            L.append("|---|---|---|---|")
            for name in ("none", "full", "planar_off"):
                r = sv["empty"][name]
                L.append(f"| {names[name]} | {fmt(r['ate'])} | {fmt(r['online_ate'])} | "
                         f"{r['poses']} / {r['frames']} |")
            L.append("")
            L.append("```")
            for name in ("none", "full", "planar_off"):
                L.append(cmd(sv["empty"][name]["cmd"]))
            L.append("```\n")
            L.append(f"A run of the whole sequence is one sample of a chaotic system: starting it one "
                     f"entry later (`--frames K:`, K = {STARTS[0]}..{STARTS[-1]}) changes nothing "
                     "about the method and moves the ATE by more than most changes of it. Figures: "
                     "median (range) over the start entries; the error of the fallback and `ok` "
                     "frames is the RMSE over those frames of the whole-run alignment (frames.csv "
                     "state).\n")
            L.append(f"| whole run, {len(STARTS)} start entries | final ATE (m) | online ATE (m) | `ok` frames: RMSE (m) | "
                     "fallback frames: count, RMSE (m) | poses / frames |")
            L.append("|---|---|---|---|---|---|")
            for name in ("full", "planar_off"):
                rs = sv["starts"][name]
                L.append(f"| {names[name]} | {med_range([r['ate'] for r in rs])} | "
                         f"{med_range([r['online_ate'] for r in rs])} | {state_rmse(rs, 'ok')} | "
                         f"{state_count(rs, 'fallback')}, {state_rmse(rs, 'fallback')} | "
                         f"{poses_text(rs)} |")
            L.append("")
            L.append("```")
            for name in ("full", "planar_off"):
                L.append(cmd(sv["starts"][name][0]["cmd"]).replace("--frames 0:", "--frames K:"))
            L.append("```\n")
            L.append("Generated crowds (two walkers, `dygslam synth`, each run with its ground-truth "
                     "person boxes): final ATE per seed.\n")
            L.append("| generated crowd | " + " | ".join(names[n] for n in ("full", "planar_off")) + " |")
            L.append("|---|---|---|")
            for cname, _ in CROWDS:
                c = sv["crowds"][cname]
                L.append(f"| {cname.replace('crowd_s', 'seed ')} | {fmt(c['full']['ate'])} | "
                         f"{fmt(c['planar_off']['ate'])} |")
            L.append("")
            L.append("```")
            c = sv["crowds"][CROWDS[0][0]]
            L.append(cmd(c["synth"]))
            L.append(cmd(c["full"]["cmd"]))
            L.append("```\n")
        else:
            L.append("Not measured (`--quick`).\n")

    def headline(self):
        """The README's figures table."""
        R = self.results
        dds = R.get("dds") or []
        full = (R.get("ablation") or {}).get("full") or []
        main = dds or full
        mode = "default command, DDS pipeline" if dds else "direct loop"
        L = [f"Measured by `make bench` at commit `{git('rev-parse', '--short=12', 'HEAD') or 'unknown'}` "
             f"on {machine_text()} ({self.args.runs} run{'s' if self.args.runs > 1 else ''}, median "
             "and range; BENCHMARKS.md has every table with its command).", "",
             "| figure | bonn_crowd_part, shipped settings |", "|---|---|"]
        L.append(f"| final ATE ({mode}) | {med_range([r['ate'] for r in main])} m, {poses_text(main)} frames with a pose |")
        L.append(f"| online ATE (pose published at the moment) | {med_range([r['online_ate'] for r in main])} m, "
                 f"{poses_text(main, 'online_poses')} frames |")
        if dds:
            L.append(f"| frames/s, default command | {med_range([r['fps'] for r in dds], 1)} |")
        decoded = R.get("decoded") or []
        if decoded:
            L.append(f"| CPU per frame, all threads, frames decoded beforehand (robot case) | "
                     f"{med_range([r['system_ms'] for r in decoded], 1)} ms (+ "
                     f"{med_range([r['decode_ms'] for r in decoded], 1)} ms of PNG decoding) |")
        if full:
            L.append(f"| frames/s, `--direct` | {med_range([r['fps'] for r in full], 1)} |")
            L.append(f"| CPU per frame, all threads (`--direct`, PNG decoding included) | "
                     f"{med_range([r['cpu_ms_per_frame'] for r in full], 1)} ms |")
        L.append(f"| peak memory ({mode}) | {med_range([r['peak_rss_mib'] for r in main], 0)} MiB |")
        mem = R.get("memory")
        if mem:
            L.append(f"| memory over {self.args.memory_minutes:g} min (player replaying) | peak "
                     f"{mem['peak']:.0f} MiB, slope {fmt(mem['slope'], 2)} MiB/min over the second half |")
        return "\n".join(L)


# --- trajectories and drawing ----------------------------------------------------------------

def read_frame_states(path):
    """frames.csv of a run -> {stamp (rounded to the microsecond): (state, is keyframe)}."""
    states = {}
    if os.path.exists(path):
        with open(path) as f:
            for row in csv.DictReader(f):
                states[round(float(row["stamp"]), 6)] = (row["state"], row["keyframe"] == "1")
    return states


def read_tum(path):
    rows = []
    for line in open(path):
        parts = line.split()
        if len(parts) >= 8 and not line.startswith("#"):
            rows.append([float(v) for v in parts[:8]])  # t, x, y, z, qx, qy, qz, qw
    return rows


def associate(gt, est, max_dt=0.02):
    """(t, gt xyz, est xyz) pairs, nearest stamp within max_dt (pictures only; scores come from
    `dygslam eval`)."""
    import bisect
    stamps = [g[0] for g in gt]
    pairs = []
    for e in est:
        i = bisect.bisect_left(stamps, e[0])
        best = None
        for j in (i - 1, i):
            if 0 <= j < len(gt) and (best is None or abs(gt[j][0] - e[0]) < abs(gt[best][0] - e[0])):
                best = j
        if best is not None and abs(gt[best][0] - e[0]) <= max_dt:
            pairs.append((e[0], gt[best][1:4], e[1:4]))
    return pairs


def read_tum_poses(path):
    """{stamp rounded to 0.1 ms: (x, y, z, qx, qy, qz, qw)} of a TUM trajectory."""
    if not os.path.exists(path):
        return {}
    return {round(row[0], 4): tuple(row[1:8]) for row in read_tum(path)}


def quat_mul(a, b):
    ax, ay, az, aw = a
    bx, by, bz, bw = b
    return (aw * bx + ax * bw + ay * bz - az * by, aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw, aw * bw - ax * bx - ay * by - az * bz)


def quat_rotate(q, v):
    x, y, z, _ = quat_mul(quat_mul(q, (v[0], v[1], v[2], 0.0)), (-q[0], -q[1], -q[2], q[3]))
    return (x, y, z)


def relative_motion(a, b):
    """The pose of b in a's frame, both world_from_cam (x, y, z, qx, qy, qz, qw)."""
    qa_inv = (-a[3], -a[4], -a[5], a[6])
    t = quat_rotate(qa_inv, (b[0] - a[0], b[1] - a[1], b[2] - a[2]))
    return t, quat_mul(qa_inv, b[3:7])


def relative_pose_error(groundtruth, trajectory, first, last):
    """(metres, degrees) between the estimated and the true motion from ground-truth entry
    `first` to entry `last`; None when the trajectory has no pose at either."""
    gt = read_tum_poses(groundtruth)
    est = read_tum_poses(trajectory)
    stamps = sorted(gt)
    a, b = stamps[first], stamps[last]
    if a not in est or b not in est:
        return None
    tg, qg = relative_motion(gt[a], gt[b])
    te, qe = relative_motion(est[a], est[b])
    # error = true^-1 * estimated
    qg_inv = (-qg[0], -qg[1], -qg[2], qg[3])
    dq = quat_mul(qg_inv, qe)
    dt = quat_rotate(qg_inv, (te[0] - tg[0], te[1] - tg[1], te[2] - tg[2]))
    angle = 2 * math.degrees(math.acos(min(1.0, abs(dq[3]))))
    return (math.sqrt(sum(v * v for v in dt)), angle)


def synth_is_cached(directory, command):
    """The cache folder holds a sequence `dygslam synth` made with exactly these arguments."""
    stamp = os.path.join(directory, ".synth_command")
    return (os.path.exists(os.path.join(directory, "rgb.txt")) and os.path.exists(stamp)
            and open(stamp).read().strip() == command)


def write_planar_as_line(config, path):
    """`config` with the anchor residual taken as a 1-D distance (the conversion's ablation)."""
    with open(path, "w") as f:
        f.write(open(config).read().rstrip("\n") + "\nDynamicFilter.planar_residual_to_line: 0\n")
    return path


# The pose priors measured on and off (their ablations).
PRIORS = {
    "pose_prior": {
        "key": "LocalMapping.pose_prior",
        "title": "The local bundle adjustment's pose prior",
        "what": "The local BA holds each keyframe near its pose in the directions its points leave "
                "nearly free",
    },
    "motion_prior": {
        "key": "Tracking.motion_prior",
        "title": "Tracking's motion prior",
        "what": "Tracking holds each frame's pose near the motion model's prediction in the "
                "directions its matches leave nearly free",
    },
}


def write_without(config, path, key):
    """`config` with the boolean settings key `key` off."""
    with open(path, "w") as f:
        f.write(open(config).read().rstrip("\n") + f"\n{key}: 0\n")
    return path


def rmse_by_state(groundtruth, aligned, frames_csv):
    """RMSE of the aligned final poses per tracking state of frames.csv ({state: (n, rmse)})."""
    if not os.path.exists(aligned):
        return {}
    states = {round(float(r["stamp"]), 4): r["state"] for r in read_frames_csv(frames_csv)}
    sums = {}
    for t, g, e in associate(read_tum(groundtruth), read_tum(aligned)):
        state = states.get(round(t, 4), "?")
        n, total = sums.get(state, (0, 0.0))
        sums[state] = (n + 1, total + sum((a - b) ** 2 for a, b in zip(g, e)))
    return {k: (n, (total / n) ** 0.5) for k, (n, total) in sums.items()}


def draw_top_view(ax, gt, series, colour):
    # The ground truth over the time the estimates cover (a --frames range is part of it).
    t_lo = min(e[0][0] for _, _, e in series if e) - 0.05
    t_hi = max(e[-1][0] for _, _, e in series if e) + 0.05
    gt = [g for g in gt if t_lo <= g[0] <= t_hi] or gt
    extent = [max(p[k] for p in gt) - min(p[k] for p in gt) for k in (1, 2, 3)]
    a, b = sorted(sorted(range(3), key=lambda k: -extent[k])[:2])
    ax.plot([p[1 + a] for p in gt], [p[1 + b] for p in gt], "-", color="black", lw=2.5,
            label="ground truth")
    for key, label, est in series:
        ax.plot([p[1 + a] for p in est], [p[1 + b] for p in est], "-", color=colour(key), lw=1.2,
                label=label)
    # Framed on the ground truth: an estimate that drifts far leaves the picture (its error curve
    # shows it) instead of shrinking the others to a dot.
    lo = [min(p[1 + k] for p in gt) for k in (a, b)]
    hi = [max(p[1 + k] for p in gt) for k in (a, b)]
    half = 0.8 * max(hi[0] - lo[0], hi[1] - lo[1], 0.2)
    centre = [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2]
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_xlabel("xyz"[a] + " (m)")
    ax.set_ylabel("xyz"[b] + " (m)")
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")


def draw_error_over_time(ax, gt, series, colour):
    t0 = gt[0][0]
    for key, label, est in series:
        pairs = associate(gt, est)
        ax.plot([t - t0 for t, _, _ in pairs],
                [math.dist(g, e) for _, g, e in pairs], "-", color=colour(key), lw=1.0, label=label)
    ax.set_xlabel("time (s)")
    ax.set_ylabel("position error after alignment (m)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best")


def loop_closing_off(camera_yaml):
    """camera.yaml text with loop closing switched off (the section's key replaced or added)."""
    lines = camera_yaml.rstrip("\n").split("\n")
    for i, line in enumerate(lines):
        if line.rstrip() == "LoopClosing:":
            j = i + 1
            while j < len(lines) and (lines[j].startswith(" ") or not lines[j].strip()):
                if re.match(r"\s+enabled\s*:", lines[j]):
                    lines[j] = "  enabled: false"
                    return "\n".join(lines) + "\n"
                j += 1
            lines.insert(i + 1, "  enabled: false")
            return "\n".join(lines) + "\n"
    return "\n".join(lines + ["", "LoopClosing:", "  enabled: false"]) + "\n"


def replace_between_markers(text, content, name):
    b, e = text.find(FIGURES_BEGIN), text.find(FIGURES_END)
    if b < 0 or e < 0:
        return None
    if e < b or text.count(FIGURES_BEGIN) != 1 or text.count(FIGURES_END) != 1:
        raise SystemExit(f"make_benchmarks: {name}: the figures markers are repeated or out of order")
    return text[:b + len(FIGURES_BEGIN)] + "\n" + content.rstrip("\n") + "\n" + text[e:]


# --- main ------------------------------------------------------------------------------------

def in_private_netns():
    return os.environ.get("DYGSLAM_BENCH_NETNS") == "1"


def reexec_in_netns():
    """Replaces this process by this script run inside a private network + mount namespace
    (loopback only, private /dev/shm; the pid stays, so signals reach it) when this process may
    create one; returns when it may not."""
    if in_private_netns() or shutil.which("unshare") is None:
        return
    probe = subprocess.run(["unshare", "-n", "-m", "--propagation", "private", "true"],
                           capture_output=True)
    if probe.returncode != 0:
        return
    lib = os.path.join(REPO, "scripts", "netns_lib.sh")
    env = dict(os.environ, DYGSLAM_BENCH_NETNS="1")
    bash = shutil.which("bash")
    os.execve(bash, [bash, "-c", f'source {shlex.quote(lib)} && netns_exec "$@"', "netns",
                     sys.executable, os.path.abspath(__file__)] + sys.argv[1:], env)


def parse_args():
    default_data = os.path.join(os.environ.get("DYGSLAM_DATA_DIR", os.path.join(REPO, "..", "shared", "data")),
                                "bonn_crowd_part")
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--build", default=os.path.join(REPO, "build"), help="build folder (apps/dygslam)")
    p.add_argument("--data", default=default_data, help="the bonn_crowd_part folder")
    p.add_argument("--runs", type=int, help="runs per configuration (default 5; 1 with --quick)")
    p.add_argument("--quick", action="store_true", default=os.environ.get("BENCH_QUICK") == "1",
                   help="development check: 1 run, no memory and loop sections (also BENCH_QUICK=1)")
    p.add_argument("--frames", help="rgb.txt entries FIRST:LAST of bonn_crowd_part (default: all)")
    p.add_argument("--out", default=os.path.join(REPO, "BENCHMARKS.md"), help="the file written")
    p.add_argument("--readme", default=os.path.join(REPO, "README.md"),
                   help="README whose figures block is rewritten (skipped without the markers)")
    p.add_argument("--figures", default=os.path.join(REPO, "docs", "benchmarks"),
                   help="folder of the pictures (committed; linked relative to --out)")
    p.add_argument("--work", help="scratch folder of the runs (default BUILD/bench_work)")
    p.add_argument("--cache", help="rendered loop sequences (default BUILD/bench_cache)")
    p.add_argument("--memory-minutes", type=float, default=3.0, help="length of the memory run")
    p.add_argument("--loop-runs", type=int, default=3, help="runs per loop and mode")
    p.add_argument("--map-runs", type=int, help="rounds of map reuse and map quality (default 3; 1 with --quick)")
    a = p.parse_args()
    if a.runs is None:
        a.runs = 1 if a.quick else 5
    if a.map_runs is None:
        a.map_runs = 1 if a.quick else min(3, a.runs)
    if a.runs < 1 or a.loop_runs < 1 or a.map_runs < 1:
        p.error("--runs, --loop-runs and --map-runs must be at least 1")
    a.work = os.path.abspath(a.work or os.path.join(a.build, "bench_work"))
    a.cache = os.path.abspath(a.cache or os.path.join(a.build, "bench_cache"))
    a.out = os.path.abspath(a.out)
    a.readme = os.path.abspath(a.readme)
    a.figures = os.path.abspath(a.figures)
    return a


def reexec_with_matplotlib():
    """A python3 without matplotlib first on PATH (pyenv, venv): this script again with the
    system's /usr/bin/python3 when that one has it (before any run; the pictures need it)."""
    try:
        import matplotlib  # noqa: F401
        return
    except ImportError:
        pass
    system = "/usr/bin/python3"
    if os.path.exists(system) and os.path.realpath(sys.executable) != os.path.realpath(system) \
            and subprocess.run([system, "-c", "import matplotlib"], capture_output=True).returncode == 0:
        os.execv(system, [system, os.path.abspath(__file__)] + sys.argv[1:])


def main():
    # First: a stop during the set-up below is a clean stop too (nothing written yet).
    for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        signal.signal(signum, on_signal)
    try:
        return bench_main()
    except Stopped as e:
        say(f"{e} during set-up: nothing written")
        return 128 + e.signum


def bench_main():
    a = parse_args()
    reexec_with_matplotlib()
    reexec_in_netns()

    bench = Bench(a)
    if not os.access(bench.dygslam, os.X_OK):
        print(f"make_benchmarks: {bench.dygslam} not built (make build, or --build DIR)", file=sys.stderr)
        return 1
    for name in ("rgb.txt", "depth.txt", "groundtruth.txt"):
        if not os.path.exists(os.path.join(bench.data, name)):
            print(f"make_benchmarks: {os.path.join(bench.data, name)} missing: the bonn_crowd_part data "
                  "is needed (scripts/fetch_data.sh bonn_crowd_part, or --data DIR)", file=sys.stderr)
            return 1
    if os.path.exists(a.work) and os.path.abspath(a.work) in (REPO, "/"):
        print("make_benchmarks: --work must be a scratch folder", file=sys.stderr)
        return 2
    help_text = subprocess.run([bench.dygslam, "run", "--help"], capture_output=True, text=True).stdout
    bench.has_rate = "--rate" in help_text
    bench.dds_ok = in_private_netns()
    bench.dds_reason = ("" if bench.dds_ok else
                        "no private network namespace could be created (needs root or CAP_SYS_ADMIN); "
                        "DDS runs stay off the network")
    cache_file = os.path.join(a.build, "CMakeCache.txt")
    if os.path.exists(cache_file) and "DYGSLAM_BUILD_DDS:BOOL=OFF" in open(cache_file).read():
        bench.dds_ok, bench.dds_reason = False, "this build has no DDS components (DYGSLAM_BUILD_DDS=OFF)"
    if not bench.dds_ok:
        bench.notes.append("DDS sections not measured: " + bench.dds_reason)

    started_wall = time.monotonic()
    started = datetime.datetime.utcnow().strftime("%Y-%m-%d %H:%M UTC")
    staged = []
    try:
        shutil.rmtree(bench.figures_stage, ignore_errors=True)
        os.makedirs(a.work, exist_ok=True)
        bench.ablation_and_schedule()
        if not a.quick:
            if bench.dds_ok:
                bench.memory()
            bench.loops()
            bench.filter_sensitivity()
            bench.crowd_stretch()
            for which in PRIORS:
                bench.pose_prior(which)
        bench.map_reuse()
        bench.map_quality()
        bench.draw()
        finished = datetime.datetime.utcnow().strftime("%Y-%m-%d %H:%M UTC")
        elapsed = time.monotonic() - started_wall
        text = bench.render(started, finished, elapsed, a.out, a.figures)
        staged.append((write_atomically(a.out, text), a.out))
        readme_updated = False
        if os.path.exists(a.readme):
            updated = replace_between_markers(open(a.readme).read(), bench.headline(), a.readme)
            if updated is not None:
                staged.append((write_atomically(a.readme, updated), a.readme))
                readme_updated = True
            else:
                say(f"{a.readme}: no {FIGURES_BEGIN} ... {FIGURES_END} block: left as it is")
        # The commit point: signals wait until every file is in place.
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM, signal.SIGHUP})
        os.makedirs(a.figures, exist_ok=True)
        for name in bench.figures:
            os.replace(os.path.join(bench.figures_stage, name), os.path.join(a.figures, name))
        for tmp, target in staged:
            os.replace(tmp, target)
        staged = []
        signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT, signal.SIGTERM, signal.SIGHUP})
        say(f"wrote {a.out} in {elapsed / 60:.1f} min"
            + (f" and the figures block of {a.readme}" if readme_updated else ""))
        return 0
    except Stopped as e:
        child = CURRENT_CHILD[0]
        if child is not None:
            try:  # the run flushes its outputs and ends on SIGTERM
                child.wait(timeout=30)
            except subprocess.TimeoutExpired:
                os.killpg(child.pid, signal.SIGKILL)
        say(f"{e}: {a.out} and {a.readme} left untouched")
        return 128 + e.signum
    except RunFailed as e:
        print(f"make_benchmarks: a run failed, nothing written: {e}", file=sys.stderr)
        return 1
    finally:
        for tmp, _ in staged:
            try:
                os.remove(tmp)
            except OSError:
                pass


if __name__ == "__main__":
    sys.exit(main())

#!/usr/bin/env python3
"""Runs every shipped scene and compares the cost estimate a run prints with what it took.

The flagship scenes run as drafts (--scale 0.5) so the whole check takes minutes. For each scene
it prints the estimated and the actual step count and simulation seconds (run.json's stages,
without setup, drawing and encoding) and their ratio; it exits 1 if any estimate is off by more
than a factor of two.

    python3 scripts/estimate_check.py [--snowsim build/app/snowsim] [--out out/estimate_check]
        [--threads 2] [SCENE ...]
"""
import argparse
import json
import pathlib
import re
import subprocess
import sys

DRAWING_STAGES = {"setup", "snapshot", "surface", "render", "wait for encoding", "write"}
ROOT = pathlib.Path(__file__).resolve().parent.parent


def shipped_scenes():
    scenes = sorted((ROOT / "scenes").glob("*.json")) + sorted((ROOT / "scenes/flagship").glob("*.json"))
    return [s for s in scenes if s.name != "figures.json"]


def seconds_of(text):
    value, unit = re.fullmatch(r"([0-9.e+-]+) (s|min|h)", text).groups()
    return float(value) * {"s": 1, "min": 60, "h": 3600}[unit]


def estimate_of(output):
    """The step count and the seconds (low, high) the run's estimate lines give."""
    steps = re.search(r"about ([0-9.]+)( thousand| million| billion)? steps", output)
    span = re.search(r"the steps take (?:about )?([0-9.e+-]+ (?:s|min|h))(?: to ([0-9.e+-]+ (?:s|min|h)))?",
                     output)
    if not steps or not span:
        return None
    scale = {None: 1, " thousand": 1e3, " million": 1e6, " billion": 1e9}
    count = float(steps.group(1)) * scale[steps.group(2)]
    low = seconds_of(span.group(1))
    high = seconds_of(span.group(2)) if span.group(2) else low
    return count, low, high


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--snowsim", default=str(ROOT / "build/app/snowsim"))
    parser.add_argument("--out", default="out/estimate_check")
    parser.add_argument("--threads", default="2")
    parser.add_argument("scenes", nargs="*")
    args = parser.parse_args()
    scenes = [pathlib.Path(s) for s in args.scenes] or shipped_scenes()
    worst = 1.0
    print(f"{'scene':34} {'steps est':>10} {'actual':>8} {'seconds est':>14} {'actual':>8} {'ratio':>6}")
    for scene in scenes:
        extra = ["--scale", "0.5"] if scene.parent.name == "flagship" else []
        out = pathlib.Path(args.out) / scene.stem
        command = [args.snowsim, "run", str(scene), "-o", str(out), "--overwrite", "--no-mp4",
                   "--no-ply", "--width", "160", "--height", "90", "--threads", args.threads,
                   *extra]
        run = subprocess.run(command, capture_output=True, text=True)
        if run.returncode != 0:
            print(f"{scene.stem}: exit {run.returncode}\n{run.stderr}", file=sys.stderr)
            return 2
        estimate = estimate_of(run.stdout + run.stderr)
        if estimate is None:
            print(f"{scene.stem}: printed no estimate (a run of fewer than 11 steps)")
            continue
        steps_estimated, low, high = estimate
        record = json.loads((out / "run.json").read_text())
        actual = max(1e-9, sum(s["seconds"] for s in record["stages"]
                               if s["stage"] not in DRAWING_STAGES))
        # Within the range is right; outside it, off by the factor to its nearer end.
        ratio = high / actual if actual > high else low / actual if actual < low else 1.0
        off = max(ratio, 1 / ratio)
        worst = max(worst, off)
        span = f"{low:.3g}" if low == high else f"{low:.3g}-{high:.3g}"
        print(f"{scene.stem:34} {steps_estimated:>10.0f} {record['steps']:>8} {span:>14} "
              f"{actual:>8.3g} {ratio:>6.2f}{'  off by more than 2x' if off > 2 else ''}",
              flush=True)
    print(f"worst: off by {worst:.2f}x")
    return 1 if worst > 2 else 0


if __name__ == "__main__":
    sys.exit(main())

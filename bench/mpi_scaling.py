#!/usr/bin/env python3
"""Strong and weak scaling of one run across MPI ranks, and what each rank sends a step.

Runs `mpirun -np N snowsim run` (oversubscribed when N exceeds the cores) and reads each run's
run.json: its wall time, and per rank the halo nodes and bytes a step and the particles that
migrated. Strong: one scene at --scale S on 1, 2, 4 ranks, also giving the largest difference of
any particle's position from the one-rank run in the last PLY frame. Weak: the particles per rank
kept, the scale growing as the cube root of the ranks (3D, rounded to a multiple of 0.05 for
whole cells), for --weak-duration.

Usage: bench/mpi_scaling.py [--scene scenes/flagship/smash_wall.json] [--scale 0.25]
                            [--duration 0.3] [--weak-duration 0.05] [--ranks 1,2,4]
                            [--threads 1] [--build build]
"""
import argparse
import json
import os
import struct
import subprocess
import sys
import tempfile


def run(args, ranks, scale, duration, out, ply):
    command = ["mpirun", "--allow-run-as-root", "--oversubscribe", "-np", str(ranks),
               os.path.join(args.build, "app", "snowsim"), "run", args.scene, "-o", out,
               "--scale", str(scale), "--set", "time.duration=%g" % duration,
               "--no-png", "--no-mp4", "--threads", str(args.threads),
               # every particle awake: each rank's whole share of the work, every step
               "--set", "mpm.auto_sleep.enabled=false"]
    if not ply:
        command.append("--no-ply")
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    with open(os.path.join(out, "run.json")) as f:
        summary = json.load(f)
    return summary, summary["wall_time"]


def positions(path):
    """The particles' positions of a binary PLY frame (x y z first, then other properties)."""
    with open(path, "rb") as f:
        data = f.read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    count, stride, in_vertex = 0, 0, False
    for line in data[:end].decode().splitlines():
        words = line.split()
        if words[:2] == ["element", "vertex"]:
            count, in_vertex = int(words[2]), True
        elif words[:1] == ["element"]:
            in_vertex = False
        elif words[:1] == ["property"] and in_vertex:
            stride += 8 if words[1] == "double" else 4
    return [struct.unpack_from("<3f", data, end + p * stride) for p in range(count)]


def largest_difference(a, b):
    return max(max(abs(x - y) for x, y in zip(p, q)) for p, q in zip(a, b))


def traffic(summary):
    """The busiest rank's halo (nodes, KB a step) and all ranks' migration a step."""
    ranks = summary.get("ranks", [])
    if not ranks:
        return "-", "-", "-", "-"
    steps = summary["steps"]
    busiest = max(ranks, key=lambda r: r["halo_bytes_a_step"])
    sent = sum(r["particles_sent"] for r in ranks) / steps / len(ranks)
    sent_kb = sum(r["particle_bytes"] for r in ranks) / steps / len(ranks) / 1e3
    return ("%.0f" % busiest["halo_nodes_a_step"], "%.1f" % (busiest["halo_bytes_a_step"] / 1e3),
            "%.2f" % sent, "%.3f" % sent_kb)


def table(title, rows):
    print(title)
    print("| ranks | scale | particles | steps | wall s | particle-steps/s | efficiency "
          "| halo nodes a step (busiest rank) | halo KB a step | particles migrating a step a rank "
          "| migration KB a step a rank | largest position difference from 1 rank (m) |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    base = None
    for ranks, scale, summary, wall, difference in rows:
        rate = summary["particles"] * summary["steps"] / wall
        per_rank = rate / ranks
        base = base or per_rank
        print("| %d | %.3g | %d | %d | %.1f | %.3g | %.0f%% | %s | %s | %s | %s | %s |" % (
            (ranks, scale, summary["particles"], summary["steps"], wall, rate,
             100 * per_rank / base) + traffic(summary) + (difference,)))
    print()


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="scenes/flagship/smash_wall.json")
    parser.add_argument("--scale", type=float, default=0.25)
    parser.add_argument("--duration", type=float, default=0.3)
    parser.add_argument("--weak-duration", type=float, default=0.05)
    parser.add_argument("--ranks", default="1,2,4")
    parser.add_argument("--threads", type=int, default=1)
    parser.add_argument("--build", default="build")
    args = parser.parse_args()
    counts = [int(n) for n in args.ranks.split(",")]
    with open("/proc/loadavg") as f:
        print("load average before: %s (2 cores; wall times under load unless it is near 0)"
              % f.read().split()[0])
    with tempfile.TemporaryDirectory() as tmp:
        strong, weak = [], []
        reference = None
        for n in counts:
            out = os.path.join(tmp, "strong%d" % n)
            summary, wall = run(args, n, args.scale, args.duration, out, True)
            last = positions(os.path.join(out, "frame_%05d.ply" % (summary["frames"] - 1)))
            reference = reference or last
            strong.append((n, args.scale, summary, wall, "%.3g" % largest_difference(reference, last)))
        for n in counts:
            # --scale must give whole cells: the flagship grids take multiples of 0.05.
            scale = round(args.scale * n ** (1 / 3) / 0.05) * 0.05
            summary, wall = run(args, n, scale, args.weak_duration,
                                os.path.join(tmp, "weak%d" % n), False)
            weak.append((n, scale, summary, wall, "-"))
    name = os.path.basename(args.scene)
    table("Strong scaling: %s at --scale %g, %g s, %d thread(s) a rank (efficiency: "
          "particle-steps/s a rank against 1 rank)" % (name, args.scale, args.duration,
                                                        args.threads), strong)
    table("Weak scaling: %s, %g s, the scale growing with the cube root of the ranks"
          % (name, args.weak_duration), weak)


if __name__ == "__main__":
    sys.exit(main())

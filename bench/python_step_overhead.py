#!/usr/bin/env python3
"""What stepping from Python costs beside the command line: the same 3D scene of about 30k
particles run by `snowsim run` (no outputs) and by the Python module, each a whole process, in
alternating pairs; prints each time and the median ratio Python / command line.

Usage: bench/python_step_overhead.py [--build build] [--python /usr/bin/python3] [--pairs 3]
                                     [--duration 0.05] [--threads 1]
"""
import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time

SCENE = "scenes/mpm_snowball_wall.json"
SCALE = 2.5  # 2,144 particles at scale 1, about 33k here (whole cells need a multiple of 0.25)

PYTHON_RUN = """
import sys
import snowsim
scene = snowsim.load_scene(sys.argv[1], {"time.duration": float(sys.argv[3])}, scale=float(sys.argv[2]))
simulation = snowsim.Simulation(scene, threads=int(sys.argv[4]))
for frame in range(1, scene.frame_count + 1):  # to each frame's time, as a run steps
    simulation.advance_to(min(scene.duration, frame / scene.fps))
print(simulation.particle_count, simulation.step_count)
"""


def timed(command, env=None):
    start = time.perf_counter()
    done = subprocess.run(command, check=True, capture_output=True, text=True, env=env)
    return time.perf_counter() - start, done.stdout


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--build", default="build")
    parser.add_argument("--python", default="/usr/bin/python3")
    parser.add_argument("--pairs", type=int, default=3)
    parser.add_argument("--duration", type=float, default=0.05)
    parser.add_argument("--threads", type=int, default=1)
    args = parser.parse_args()
    env = dict(os.environ, PYTHONPATH=os.path.join(args.build, "python"))
    with tempfile.TemporaryDirectory() as out:
        cli = [os.path.join(args.build, "app", "snowsim"), "run", SCENE, "-o", out, "--overwrite",
               "--scale", str(SCALE), "--set", f"time.duration={args.duration}",
               "--no-ply", "--no-png", "--no-mp4", "--threads", str(args.threads)]
        python = [args.python, "-c", PYTHON_RUN, SCENE, str(SCALE), str(args.duration),
                  str(args.threads)]
        ratios = []
        for pair in range(args.pairs):
            cli_seconds, _ = timed(cli)
            python_seconds, counts = timed(python, env)
            particles, steps = counts.split()
            ratios.append(python_seconds / cli_seconds)
            print(f"pair {pair + 1}: snowsim run {cli_seconds:.2f} s, Python {python_seconds:.2f} s "
                  f"({particles} particles, {steps} steps): ratio {ratios[-1]:.3f}")
    print(f"median ratio Python / command line: {statistics.median(ratios):.3f}")


if __name__ == "__main__":
    sys.exit(main())

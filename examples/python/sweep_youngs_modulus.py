#!/usr/bin/env python3
"""A sweep of snow's Young's modulus E0: the time-step error of each against its wall time.

Each E0 runs the 3D snowball drop twice: as the scene says, and with a quarter of its largest step
and of its CFL number (the stable step's share, mpm.cfl). The error is the RMS distance between
the two runs' particles at the end, the wall time the first run's. Stiffer snow has faster
elastic waves, so a smaller stable step: more steps, more wall time.

Usage: PYTHONPATH=build/python python3 examples/python/sweep_youngs_modulus.py [out.png]
"""
import sys
import time

import matplotlib

matplotlib.use("Agg")  # no display needed
import matplotlib.pyplot as plt
import numpy as np

import snowsim

SCENE = "scenes/mpm_snowball_drop_3d.json"
DURATION = 0.15  # s: the ball has landed and spread


def final_positions(overrides):
    scene = snowsim.load_scene(SCENE, {"time.duration": DURATION, **overrides})
    with snowsim.Simulation(scene, threads=2) as simulation:
        start = time.perf_counter()
        simulation.advance_to(scene.duration)
        return simulation.positions(), time.perf_counter() - start, simulation.step_count


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else "sweep_youngs_modulus.png"
    scene = snowsim.load_scene(SCENE)
    finer = {"time.dt": scene.dt / 4, "mpm.cfl": scene.to_dict()["mpm"]["cfl"] / 4}
    moduli = [3.5e4, 7e4, 1.4e5, 2.8e5, 5.6e5]
    errors, seconds = [], []
    for e0 in moduli:
        coarse, wall, steps = final_positions({"material.E0": e0})
        fine, _, _ = final_positions({"material.E0": e0, **finer})
        errors.append(np.sqrt(np.mean(np.sum((coarse - fine) ** 2, axis=1))))
        seconds.append(wall)
        print(f"E0 = {e0:8.3g} Pa: {steps:5d} steps, {wall:6.2f} s, RMS error {errors[-1]:.3g} m")

    figure, axes = plt.subplots(figsize=(5, 3.5), layout="constrained")
    axes.plot(seconds, errors, "o-", color="#3b6ea5")
    axes.margins(0.2)
    for e0, x, y in zip(moduli, seconds, errors):
        axes.annotate(f"E0 {e0:.3g}", (x, y), textcoords="offset points", xytext=(5, 5))
    axes.set_xlabel("wall time (s)")
    axes.set_ylabel("RMS position error at t = %.2f s (m)" % DURATION)
    axes.set_title("Snowball drop: time-step error against wall time")
    figure.savefig(out, dpi=150)
    print("wrote", out)


if __name__ == "__main__":
    main()

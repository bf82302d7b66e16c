#!/usr/bin/env python3
"""Renders a frame of two snowballs colliding, coloured by plastic J, beside the histogram of
the particles' J_P.

Usage: PYTHONPATH=build/python python3 examples/python/plastic_histogram.py [out.png]
"""
import sys

import matplotlib

matplotlib.use("Agg")  # no display needed
import matplotlib.pyplot as plt
import numpy as np

import snowsim

scene = snowsim.load_scene("scenes/mpm_snowballs_collide_3d.json", {"time.duration": 0.1})
out = sys.argv[1] if len(sys.argv) > 1 else "plastic_histogram.png"
with snowsim.Simulation(scene, threads=2) as simulation:
    simulation.advance_to(0.1)
    image = snowsim.render(simulation, 960, 540, color_by="plastic")
    j = simulation.plastic_j()

figure, (left, right) = plt.subplots(1, 2, figsize=(11, 3.6), width_ratios=[1.6, 1],
                                     layout="constrained")
left.imshow(image)
left.set_axis_off()
left.set_title("t = 0.1 s, coloured by J_P (viridis, 0.8 to 1.2)")
right.hist(j, bins=np.linspace(0.8, 1.2, 41), color="#3b6ea5")
right.axvline(1, color="k", linewidth=0.8)
right.set_xlabel("plastic volume ratio J_P (< 1: compacted)")
right.set_ylabel("particles")
right.set_title(f"{j.size} particles, median J_P {np.median(j):.3f}")
figure.savefig(out, dpi=120)
print("wrote", out)

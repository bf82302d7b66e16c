#!/usr/bin/env python3
"""Writes a run's frame as a points body whose snow is made unevenly strong, for experiments on
what starts a fracture (docs/snow-at-scale.md, "Irregular seeding and uneven strength").

    python3 scripts/plastic_noise_ply.py IN.ply OUT.ply AMPLITUDE [CORRELATION_M] [SEED]

Each particle keeps its position, velocity and mass; its plastic_j becomes 1 + n. The hardening
e^(xi (1 - J_P)) then makes it stiffer (n < 0) or softer (n > 0): at xi = 10, n = 0.02 is 18%
softer. With CORRELATION_M 0 (the default) n is uniform in [-AMPLITUDE, AMPLITUDE] per particle;
with CORRELATION_M > 0 it is value noise, uniform in [-AMPLITUDE, AMPLITUDE] at the nodes of a
lattice of that side (metres) and trilinear between them, so neighbouring particles share it. The
same arguments give the same file. Use OUT.ply as {"shape": "points", "file": "OUT.ply"}.
"""
import math
import random
import struct
import sys


def read_ply(path):
    data = open(path, "rb").read()
    end = data.index(b"end_header\n") + len(b"end_header\n")
    names, types, count = [], [], 0
    for line in data[:end].decode().splitlines():
        words = line.split()
        if words[:2] == ["element", "vertex"]:
            count = int(words[2])
        elif words[:1] == ["element"] and words[1] != "vertex":
            break  # the vertices come first; a frame's grid densities follow them
        elif words[:1] == ["property"]:
            types.append("f" if words[1] == "float" else "i")
            names.append(words[2])
    row = struct.Struct("<" + "".join(types))
    return [dict(zip(names, row.unpack_from(data, end + i * row.size))) for i in range(count)]


def node_value(seed, i, j, k):
    return 2 * random.Random(f"{seed}:{i}:{j}:{k}").random() - 1


def value_noise(seed, side, x, y, z):
    u, v, w = x / side, y / side, z / side
    i, j, k = math.floor(u), math.floor(v), math.floor(w)
    fu, fv, fw = u - i, v - j, w - k
    total = 0.0
    for a in (0, 1):
        for b in (0, 1):
            for c in (0, 1):
                weight = (fu if a else 1 - fu) * (fv if b else 1 - fv) * (fw if c else 1 - fw)
                total += weight * node_value(seed, i + a, j + b, k + c)
    return total


def main():
    if len(sys.argv) not in (4, 5, 6):
        sys.exit(__doc__)
    source, target, amplitude = sys.argv[1], sys.argv[2], float(sys.argv[3])
    side = float(sys.argv[4]) if len(sys.argv) > 4 else 0.0
    seed = int(sys.argv[5]) if len(sys.argv) > 5 else 1
    if not 0 <= amplitude < 1 or side < 0:
        sys.exit("AMPLITUDE must be in [0, 1) and CORRELATION_M at least 0")
    uniform = random.Random(seed)
    columns = ("x", "y", "z", "vx", "vy", "vz", "mass", "plastic_j")
    rows = []
    for p in read_ply(source):
        noise = value_noise(seed, side, p["x"], p["y"], p["z"]) if side > 0 else (
            2 * uniform.random() - 1)
        rows.append(struct.pack("<8f", *(p[c] for c in columns[:-1]), 1 + amplitude * noise))
    header = ["ply", "format binary_little_endian 1.0", f"element vertex {len(rows)}"]
    header += [f"property float {c}" for c in columns] + ["end_header"]
    with open(target, "wb") as out:
        out.write(("\n".join(header) + "\n").encode() + b"".join(rows))


if __name__ == "__main__":
    main()

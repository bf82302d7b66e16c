#!/usr/bin/env python3
"""Prints how compacted or stretched the snow of PLY frames is: the plastic volume ratio J_P
(each particle's plastic_j) at quantiles by mass, for comparing runs (docs/snow-at-scale.md).

    python3 scripts/plastic_quantiles.py FRAME.ply...

One line per frame: the file, then J_P at 1, 10, 50, 90 and 99% of the mass. J_P below 1 is
compacted snow, whose hardening e^(xi (1 - J_P)) makes it stiffer; above 1, stretched snow.
"""
import struct
import sys

QUANTILES = (0.01, 0.1, 0.5, 0.9, 0.99)


SIZES = {"char": "b", "uchar": "B", "int8": "b", "uint8": "B", "short": "h", "ushort": "H",
         "int16": "h", "uint16": "H", "int": "i", "uint": "I", "int32": "i", "uint32": "I",
         "float": "f", "float32": "f", "double": "d", "float64": "d"}


def columns(path):
    try:
        data = open(path, "rb").read()
    except OSError as error:
        sys.exit(f"{path}: cannot read: {error.strerror}")
    if b"end_header\n" not in data:
        sys.exit(f"{path}: not a PLY file (no end_header)")
    end = data.index(b"end_header\n") + len(b"end_header\n")
    names, types, count, binary = [], [], None, False
    for line in data[:end].decode(errors="replace").splitlines():
        words = line.split()
        if words[:2] == ["format", "binary_little_endian"]:
            binary = True
        elif words[:2] == ["element", "vertex"]:
            count = int(words[2])
        elif words[:1] == ["element"] and words[1] != "vertex":
            break  # the vertices come first; a 2D frame's node densities follow them
        elif words[:1] == ["property"] and len(words) == 3 and words[1] in SIZES:
            types.append(SIZES[words[1]])
            names.append(words[2])
        elif words[:1] == ["property"]:
            sys.exit(f"{path}: unsupported vertex property '{line}'")
    row = struct.Struct("<" + "".join(types))
    if (not binary or not count or "plastic_j" not in names or "mass" not in names
            or len(data) < end + count * row.size):
        sys.exit(f"{path}: not a snowsim frame (needs binary little-endian vertices, at least one, "
                 "with plastic_j and mass)")
    j, m = names.index("plastic_j"), names.index("mass")
    values = [row.unpack_from(data, end + i * row.size) for i in range(count)]
    return [(v[j], v[m]) for v in values]


def main():
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    lines = []  # every frame read before anything is printed: a bad file prints nothing
    for path in sys.argv[1:]:
        particles = sorted(columns(path))
        total = sum(m for _, m in particles)
        found, seen = [], 0.0
        for j, m in particles:
            seen += m
            while len(found) < len(QUANTILES) and seen >= QUANTILES[len(found)] * total:
                found.append(j)
        lines.append(path + "," + ",".join(f"{j:.4f}" for j in found))
    print("frame," + ",".join(f"J_P_{round(q * 100)}pct" for q in QUANTILES))
    print("\n".join(lines))

if __name__ == "__main__":
    main()

#!/usr/bin/env python3
"""Writes the small closed meshes of scenes/meshes/: procedural shapes, no downloads.

    python3 scripts/make_meshes.py [OUT_DIR]    # default: scenes/meshes

cube.obj   a unit cube centred on the origin (12 triangles)
sphere.obj a unit sphere: an icosahedron subdivided 3 times (1280 triangles)
rock.obj   a lumpy rock about 1 across: the sphere pushed in and out by smooth waves
torus.stl  a torus (ASCII STL), ring radius 0.35, tube radius 0.15: outer diameter 1
Every mesh is watertight with outward-facing triangles. The output is the same on every run.
"""
import math
import os
import sys


def cube():
    v = [(x - 0.5, y - 0.5, z - 0.5) for x in (0, 1) for y in (0, 1) for z in (0, 1)]
    # Corner index = 4x + 2y + z; each face as two counter-clockwise triangles seen from outside.
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    tris = []
    for a, b, c, d in quads:
        tris += [(a, b, c), (a, c, d)]
    return v, tris


def icosphere(subdivisions):
    t = (1 + math.sqrt(5)) / 2
    v = [(-1, t, 0), (1, t, 0), (-1, -t, 0), (1, -t, 0), (0, -1, t), (0, 1, t), (0, -1, -t),
         (0, 1, -t), (t, 0, -1), (t, 0, 1), (-t, 0, -1), (-t, 0, 1)]
    v = [tuple(c / math.sqrt(1 + t * t) for c in p) for p in v]
    tris = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
            (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
            (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    for _ in range(subdivisions):
        middle = {}

        def midpoint(a, b):
            key = (min(a, b), max(a, b))
            if key not in middle:
                p = [(x + y) / 2 for x, y in zip(v[a], v[b])]
                n = math.sqrt(sum(c * c for c in p))
                v.append(tuple(c / n for c in p))
                middle[key] = len(v) - 1
            return middle[key]

        finer = []
        for a, b, c in tris:
            ab, bc, ca = midpoint(a, b), midpoint(b, c), midpoint(c, a)
            finer += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        tris = finer
    return v, tris


def rock():
    v, tris = icosphere(3)
    lumpy = []
    for x, y, z in v:
        r = 0.5 * (1 + 0.18 * math.sin(3 * x + 1) * math.cos(2 * y) + 0.12 * math.sin(4 * z + 2 * x)
                   + 0.08 * math.cos(5 * y + 3 * z))
        lumpy.append((r * x, 0.8 * r * y, r * z))  # flattened a little, like a stone
    return lumpy, tris


def torus(ring=0.35, tube=0.15, segments=32, sides=16):
    v, tris = [], []
    for i in range(segments):
        u = 2 * math.pi * i / segments
        for j in range(sides):
            w = 2 * math.pi * j / sides
            r = ring + tube * math.cos(w)
            v.append((r * math.cos(u), tube * math.sin(w), r * math.sin(u)))
    for i in range(segments):
        for j in range(sides):
            a = i * sides + j
            b = ((i + 1) % segments) * sides + j
            c = ((i + 1) % segments) * sides + (j + 1) % sides
            d = i * sides + (j + 1) % sides
            tris += [(a, d, c), (a, c, b)]
    return v, tris


def write_obj(path, name, v, tris):
    with open(path, "w") as f:
        f.write(f"# {name}, written by scripts/make_meshes.py\n")
        for p in v:
            f.write("v %.6f %.6f %.6f\n" % p)
        for a, b, c in tris:
            f.write(f"f {a + 1} {b + 1} {c + 1}\n")


def write_stl(path, name, v, tris):
    with open(path, "w") as f:
        f.write(f"solid {name}\n")
        for tri in tris:
            p = [v[k] for k in tri]
            e1 = [p[1][i] - p[0][i] for i in range(3)]
            e2 = [p[2][i] - p[0][i] for i in range(3)]
            n = [e1[1] * e2[2] - e1[2] * e2[1], e1[2] * e2[0] - e1[0] * e2[2],
                 e1[0] * e2[1] - e1[1] * e2[0]]
            length = math.sqrt(sum(c * c for c in n))
            f.write("facet normal %.6f %.6f %.6f\n outer loop\n" % tuple(c / length for c in n))
            for q in p:
                f.write("  vertex %.6f %.6f %.6f\n" % q)
            f.write(" endloop\nendfacet\n")
        f.write(f"endsolid {name}\n")


def main():
    out = sys.argv[1] if len(sys.argv) > 1 else os.path.join(os.path.dirname(__file__), "..",
                                                             "scenes", "meshes")
    os.makedirs(out, exist_ok=True)
    write_obj(os.path.join(out, "cube.obj"), "unit cube", *cube())
    write_obj(os.path.join(out, "sphere.obj"), "unit sphere", *icosphere(3))
    write_obj(os.path.join(out, "rock.obj"), "lumpy rock", *rock())
    write_stl(os.path.join(out, "torus.stl"), "torus", *torus())


if __name__ == "__main__":
    main()

"""Loads a snowsim run into Blender (3.4 or later) as one animated object.

    blender --python scripts/blender_load_run.py -- RUN_DIR [--vdb]
    blender -b --python scripts/blender_load_run.py --python-expr
        "import bpy; bpy.ops.wm.save_as_mainfile(filepath='run.blend')" -- RUN_DIR --vdb

(the second, on one line, without a display: the loaded run saved to run.blend)

or, in Blender's Text Editor, set RUN_DIR below and press Run Script.

The run's frame_NNNNN.ply files become ONE mesh object of vertices, `snowsim_particles`, whose
positions and attributes a frame-change handler swaps in from the frame's PLY: only the current
frame is in memory (per-frame shape keys would hold every frame's positions, and still not the
attributes). Blender frame k shows snowsim frame k; the scene's frame range and frame rate come
from run.json. The vertices carry these mesh attributes (point domain), in the object's space:
  velocity   vector, m/s (the PLY's vx vy vz; Blender's name, which Cycles' motion blur reads)
  density    float, kg/m^3 (kg/m^2 for 2D runs)
  plastic_j  float, MPM's J_P (below 1 compacted, above 1 stretched)
  mass       float, kg
  pscale     float, the particle's radius in m (Houdini's name)
  id         int, the particle's index at creation
A Geometry Nodes "Mesh to Points" with Radius = Named Attribute "pscale" turns them into
renderable spheres. snowsim's y-up frames get the object turned +90 degrees about x, so the snow
stands on Blender's z-up ground; frames written with --z-up need no turn.

With --vdb, the run's frame_NNNNN.vdb files (snowsim run --vdb) become a volume object,
`snowsim_volume`, with the grids `density` and `velocity`, turned the same way.

When the handler runs in a saved .blend file opened later, run this script again to re-register it
(Blender does not store Python handlers in files).
"""

import json
import math
import os
import sys

import bpy
import numpy as np

RUN_DIR = ""  # for Blender's Text Editor: the run directory to load

PLY_TYPES = {
    "char": "i1", "int8": "i1", "uchar": "u1", "uint8": "u1",
    "short": "<i2", "int16": "<i2", "ushort": "<u2", "uint16": "<u2",
    "int": "<i4", "int32": "<i4", "uint": "<u4", "uint32": "<u4",
    "float": "<f4", "float32": "<f4", "double": "<f8", "float64": "<f8",
}
# Mesh attribute name, PLY columns, Blender type.
ATTRIBUTES = [
    ("velocity", ("vx", "vy", "vz"), "FLOAT_VECTOR"),
    ("density", ("density",), "FLOAT"),
    ("plastic_j", ("plastic_j",), "FLOAT"),
    ("mass", ("mass",), "FLOAT"),
    ("pscale", ("pscale",), "FLOAT"),
    ("id", ("id",), "INT"),
]
HANDLER_NAME = "snowsim_frame_change"


def read_ply(path):
    """The vertex columns of a binary little-endian PLY (a dict of numpy arrays) and its up axis."""
    with open(path, "rb") as f:
        if f.readline().strip() != b"ply":
            raise ValueError(path + ": not a PLY file")
        fields, up, in_vertex = [], "y", False
        while True:
            words = f.readline().decode("ascii", "replace").split()
            if not words:
                continue
            if words[0] == "end_header":
                break
            if words[0] == "format" and words[1] != "binary_little_endian":
                raise ValueError(path + ": only binary_little_endian PLY is read")
            if words[:3] == ["comment", "snowsim", "up"]:
                up = words[3]
            if words[0] == "element":
                in_vertex = words[1] == "vertex"
                if in_vertex:
                    count = int(words[2])
            if words[0] == "property" and in_vertex:
                fields.append((words[2], PLY_TYPES[words[1]]))
        vertices = np.fromfile(f, dtype=np.dtype(fields), count=count)
    return {name: vertices[name] for name, _ in fields}, up


def frame_files(run_dir, extension):
    """{snowsim frame number: path} of the run's frame_NNNNN.EXT files."""
    files = {}
    for name in os.listdir(run_dir):
        stem, ext = os.path.splitext(name)
        if ext == "." + extension and stem.startswith("frame_") and stem[6:].isdigit():
            files[int(stem[6:])] = os.path.join(run_dir, name)
    return dict(sorted(files.items()))


def show_frame(obj, path):
    """Puts the PLY frame at `path` into the object's mesh: positions and attributes."""
    columns, _ = read_ply(path)
    mesh = obj.data
    count = len(columns["x"])
    if len(mesh.vertices) != count:
        mesh.clear_geometry()
        mesh.vertices.add(count)
    positions = np.column_stack([columns["x"], columns["y"], columns["z"]]).astype(np.float32)
    mesh.vertices.foreach_set("co", positions.ravel())
    for name, sources, kind in ATTRIBUTES:
        if not all(s in columns for s in sources):
            continue
        attribute = mesh.attributes.get(name) or mesh.attributes.new(name, kind, "POINT")
        if kind == "FLOAT_VECTOR":
            values = np.column_stack([columns[s] for s in sources]).astype(np.float32).ravel()
            attribute.data.foreach_set("vector", values)
        else:
            dtype = np.int32 if kind == "INT" else np.float32
            attribute.data.foreach_set("value", columns[sources[0]].astype(dtype))
    mesh.update()
    obj["snowsim_frame_file"] = path


@bpy.app.handlers.persistent
def snowsim_frame_change(scene, depsgraph=None):
    """Shows, on every object loaded from a run, the frame at or before the scene's frame."""
    for obj in scene.objects:
        run_dir = obj.get("snowsim_run")
        if not run_dir or obj.type != "MESH":
            continue
        files = frame_files(run_dir, "ply")
        if not files:
            continue
        earlier = [k for k in files if k <= scene.frame_current]
        path = files[earlier[-1] if earlier else next(iter(files))]
        if obj.get("snowsim_frame_file") != path:
            show_frame(obj, path)


def register_handler():
    handlers = bpy.app.handlers.frame_change_post
    for h in [h for h in handlers if getattr(h, "__name__", "") == HANDLER_NAME]:
        handlers.remove(h)
    handlers.append(snowsim_frame_change)


def turn_to_z_up(obj, up):
    """snowsim's y-up coordinates stand on Blender's z-up ground: +90 degrees about x,
    (x, y, z) -> (x, -z, y)."""
    obj.rotation_euler = (math.pi / 2, 0, 0) if up == "y" else (0, 0, 0)


def load_particles(run_dir, scene):
    files = frame_files(run_dir, "ply")
    if not files:
        raise ValueError(run_dir + ": no frame_NNNNN.ply files (was the run made with --no-ply?)")
    first = next(iter(files.values()))
    mesh = bpy.data.meshes.new("snowsim_particles")
    obj = bpy.data.objects.new("snowsim_particles", mesh)
    scene.collection.objects.link(obj)
    obj["snowsim_run"] = run_dir
    turn_to_z_up(obj, read_ply(first)[1])
    show_frame(obj, first)
    return obj, files


def load_volume(run_dir, scene, up):
    files = frame_files(run_dir, "vdb")
    if not files:
        raise ValueError(run_dir + ": no frame_NNNNN.vdb files (run snowsim with --vdb)")
    first_frame, first = next(iter(files.items()))
    volume = bpy.data.volumes.new("snowsim_volume")
    volume.filepath = first
    volume.is_sequence = len(files) > 1
    # Blender reads file number (frame - frame_start + 1 + frame_offset): file k at frame k.
    volume.frame_start = first_frame
    volume.frame_offset = first_frame - 1
    volume.frame_duration = len(files)
    obj = bpy.data.objects.new("snowsim_volume", volume)
    scene.collection.objects.link(obj)
    turn_to_z_up(obj, up)
    return obj


def load_run(run_dir, with_volume=False):
    run_dir = os.path.abspath(run_dir)
    scene = bpy.context.scene
    with open(os.path.join(run_dir, "run.json")) as f:
        run = json.load(f)
    particles, files = load_particles(run_dir, scene)
    # The frame rate as an integer over a base, as Blender keeps it (50 fps: 50 / 1).
    fps = float(run["fps"])
    scene.render.fps = max(1, round(fps))
    scene.render.fps_base = scene.render.fps / fps
    scene.frame_start = next(iter(files))
    scene.frame_end = next(reversed(files))
    if with_volume:
        load_volume(run_dir, scene, read_ply(next(iter(files.values())))[1])
    # Colliders: run.json's "colliders" hold the scene's colliders at t = 0; a per-frame collider
    # transforms file, once snowsim writes one, is the place to animate them from.
    register_handler()
    scene.frame_set(scene.frame_start)
    return particles


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    paths = [a for a in argv if not a.startswith("--")]
    run_dir = paths[0] if paths else RUN_DIR
    if not run_dir:
        raise SystemExit("usage: blender --python scripts/blender_load_run.py -- RUN_DIR [--vdb]")
    load_run(run_dir, with_volume="--vdb" in argv)


if __name__ == "__main__":
    main()

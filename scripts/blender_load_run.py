"""Loads a snowsim run into Blender (3.4 or later; tested with Debian's 3.4) as one animated object.

    blender --python scripts/blender_load_run.py -- RUN_DIR [--vdb]
    blender -b --python-exit-code 1 --python scripts/blender_load_run.py --python-expr
        "import bpy, os; bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath('run.blend'))"
        -- RUN_DIR --vdb

(the second, on one line, without a display: the loaded run saved to run.blend; a run that
cannot be loaded ends Blender with exit code 1 and saves nothing)

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
A Geometry Nodes modifier, `snowsim_points` ("Mesh to Points" with Radius = Named Attribute
"pscale"), draws them as points, which Cycles renders as spheres (Blender 3's EEVEE draws no
points). snowsim's y-up frames get the object turned +90 degrees about x, so the snow
stands on Blender's z-up ground; frames written with --z-up need no turn.

With --vdb, the run's frame_NNNNN.vdb files (snowsim run --vdb) become a volume object,
`snowsim_volume`, with the grids `density` and `velocity`, turned the same way.

The run's colliders (colliders.json: boxes, spheres, planes, drums and meshes, posed at every
frame) become objects under an empty, `snowsim_colliders`, turned the same way, keyframed frame by
frame. Loaded into Blender's unsaved startup scene, the default cube goes and the camera is
aimed at the snow. Loading the same run again updates its objects rather than adding more.

A saved .blend file opened later needs the frame handler again (Blender does not store Python
handlers in files): run this script with no run directory, which registers it and loads nothing.
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
    """The vertex columns of a binary little-endian PLY: a dict of numpy arrays."""
    with open(path, "rb") as f:
        if f.readline().strip() != b"ply":
            raise ValueError(path + ": not a PLY file")
        fields, in_vertex = [], False
        while True:
            words = f.readline().decode("ascii", "replace").split()
            if not words:
                continue
            if words[0] == "end_header":
                break
            if words[0] == "format" and words[1] != "binary_little_endian":
                raise ValueError(path + ": only binary_little_endian PLY is read")
            if words[0] == "element":
                in_vertex = words[1] == "vertex"
                if in_vertex:
                    count = int(words[2])
            if words[0] == "property" and in_vertex:
                fields.append((words[2], PLY_TYPES[words[1]]))
        vertices = np.fromfile(f, dtype=np.dtype(fields), count=count)
    return {name: vertices[name] for name, _ in fields}


def ply_comment(path, key):
    """The value of a frame's `comment snowsim KEY VALUE` header line, or None."""
    with open(path, "rb") as f:
        for line in f:
            words = line.decode("ascii", "replace").split()
            if words[:3] == ["comment", "snowsim", key] and len(words) > 3:
                return words[3]
            if words[:1] == ["end_header"]:
                return None
    return None


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
    columns = read_ply(path)
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


def fail(message):
    """Without a display: one line and exit code 1, Blender ending before it saves anything. In
    Blender's window: an error Blender reports, the window left open."""
    if not bpy.app.background:
        raise RuntimeError("blender_load_run.py: " + message)
    print("blender_load_run.py: " + message, file=sys.stderr)
    raise SystemExit(1)


def object_of_run(name, run_dir, kind):
    """The object `name` loaded from run_dir before, if any (so that loading again updates it)."""
    for obj in bpy.data.objects:
        if obj.get("snowsim_run") == run_dir and obj.name.startswith(name) and obj.type == kind:
            return obj
    return None


def load_particles(run_dir, scene, files, up):
    first = next(iter(files.values()))
    obj = object_of_run("snowsim_particles", run_dir, "MESH")
    if obj is None:
        obj = bpy.data.objects.new("snowsim_particles", bpy.data.meshes.new("snowsim_particles"))
        scene.collection.objects.link(obj)
        obj["snowsim_run"] = run_dir
    turn_to_z_up(obj, up)
    show_frame(obj, first)
    if "snowsim_points" not in obj.modifiers:
        modifier = obj.modifiers.new("snowsim_points", "NODES")
        modifier.node_group = points_node_group()
    return obj


def points_node_group():
    """Geometry Nodes that draw each vertex as a point of radius pscale (Cycles renders spheres)."""
    group = bpy.data.node_groups.get("snowsim_points")
    if group:
        return group
    group = bpy.data.node_groups.new("snowsim_points", "GeometryNodeTree")
    if hasattr(group, "interface"):  # Blender 4.0 on
        group.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
        group.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    else:
        group.inputs.new("NodeSocketGeometry", "Geometry")
        group.outputs.new("NodeSocketGeometry", "Geometry")
    nodes, links = group.nodes, group.links
    given, result = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    to_points = nodes.new("GeometryNodeMeshToPoints")
    radius = nodes.new("GeometryNodeInputNamedAttribute")
    radius.data_type = "FLOAT"
    radius.inputs["Name"].default_value = "pscale"
    links.new(given.outputs["Geometry"], to_points.inputs["Mesh"])
    # The node has an output per data type, of which the float one is enabled.
    value = next(o for o in radius.outputs if o.enabled and o.type == "VALUE")
    links.new(value, to_points.inputs["Radius"])
    links.new(to_points.outputs["Points"], result.inputs["Geometry"])
    return group


def load_volume(run_dir, scene, files, up):
    first_frame, first = next(iter(files.items()))
    obj = object_of_run("snowsim_volume", run_dir, "VOLUME")
    if obj is None:
        obj = bpy.data.objects.new("snowsim_volume", bpy.data.volumes.new("snowsim_volume"))
        scene.collection.objects.link(obj)
        obj["snowsim_run"] = run_dir
    volume = obj.data
    volume.filepath = first
    volume.is_sequence = len(files) > 1
    # Blender reads file number (frame - frame_start + 1 + frame_offset): file k at frame k.
    volume.frame_start = first_frame
    volume.frame_offset = first_frame - 1
    volume.frame_duration = len(files)
    turn_to_z_up(obj, up)
    return obj


def collider_mesh(collider, name):
    """A mesh of the collider's shape in its local frame, or None for a shape not drawn."""
    import bmesh
    shape, mesh = collider["shape"], bpy.data.meshes.new(name)
    b = bmesh.new()
    if shape == "box":
        bmesh.ops.create_cube(b, size=1.0)
        bmesh.ops.scale(b, vec=collider["size"], verts=b.verts)
    elif shape == "sphere":
        bmesh.ops.create_uvsphere(b, u_segments=48, v_segments=24, radius=collider["radius"])
    elif shape == "drum":  # a hollow cylinder about local z: its wall, open at both ends
        bmesh.ops.create_cone(b, segments=64, radius1=collider["radius"],
                              radius2=collider["radius"], depth=collider["size"][2],
                              cap_ends=False)
    elif shape == "plane":  # a square of 4 m through the point, facing along the normal
        normal = collider["normal"]
        bmesh.ops.create_grid(b, x_segments=1, y_segments=1, size=2.0)
        from mathutils import Vector
        turn = Vector((0, 0, 1)).rotation_difference(Vector(normal))
        bmesh.ops.rotate(b, verts=b.verts, cent=(0, 0, 0), matrix=turn.to_matrix())
    else:
        b.free()
        bpy.data.meshes.remove(mesh)
        return None
    b.to_mesh(mesh)
    b.free()
    return mesh


def load_colliders(run_dir, scene, up):
    """colliders.json's colliders, keyframed at each frame, under one empty turned like the snow;
    returns the shapes it could not draw."""
    path = os.path.join(run_dir, "colliders.json")
    if not os.path.exists(path):
        return []
    with open(path) as f:
        frames = json.load(f)["frames"]
    parent = object_of_run("snowsim_colliders", run_dir, "EMPTY")
    if parent is None:
        parent = bpy.data.objects.new("snowsim_colliders", None)
        scene.collection.objects.link(parent)
        parent["snowsim_run"] = run_dir
    turn_to_z_up(parent, up)
    skipped = []
    for i, collider in enumerate(frames[0]["colliders"] if frames else []):
        name = "snowsim_collider_%d" % i
        obj = next((c for c in parent.children if c.get("snowsim_collider") == i), None)
        if obj is None:
            if collider["shape"] == "mesh":
                obj = import_mesh(collider, name)
            else:
                mesh = collider_mesh(collider, name)
                obj = bpy.data.objects.new(name, mesh) if mesh else None
                if obj:
                    scene.collection.objects.link(obj)
            if obj is None:
                skipped.append(collider["shape"])
                continue
            obj.parent = parent
            obj["snowsim_collider"] = i
        obj.rotation_mode = "QUATERNION"
        obj.animation_data_clear()
        for frame in frames:
            pose = frame["colliders"][i]
            obj.location = pose["position"]
            obj.rotation_quaternion = pose["rotation"]
            obj.keyframe_insert("location", frame=frame["frame"])
            obj.keyframe_insert("rotation_quaternion", frame=frame["frame"])
    return skipped


def import_mesh(collider, name):
    """A mesh collider's file (OBJ, STL or PLY) with its coordinates as they are (snowsim reads
    them so), scaled as the scene scales it; None if Blender cannot import it."""
    path = collider["mesh"]
    ops = bpy.ops
    # Blender 4 replaced the STL and PLY importers by wm.stl_import and wm.ply_import.
    importers = {
        ".obj": lambda: ops.wm.obj_import(filepath=path, forward_axis="Y", up_axis="Z"),
        ".stl": (lambda: ops.wm.stl_import(filepath=path, forward_axis="Y", up_axis="Z"))
        if hasattr(ops.wm, "stl_import")
        else (lambda: ops.import_mesh.stl(filepath=path, axis_forward="Y", axis_up="Z")),
        ".ply": (lambda: ops.wm.ply_import(filepath=path, forward_axis="Y", up_axis="Z"))
        if hasattr(ops.wm, "ply_import") else (lambda: ops.import_mesh.ply(filepath=path)),
    }
    importer = importers.get(os.path.splitext(path)[1].lower())
    if importer is None or not os.path.exists(path):
        return None
    importer()
    parts = list(bpy.context.selected_objects)
    if not parts:
        return None
    obj = parts[0]
    if len(parts) > 1:  # a file of several objects: one collider
        bpy.context.view_layer.objects.active = obj
        bpy.ops.object.join()
    obj.name = name
    obj.rotation_euler = (0, 0, 0)
    obj.scale = [collider.get("scale", 1.0)] * 3
    return obj


def frame_startup_scene(scene, particles, last_frame):
    """In Blender's unsaved startup scene: the default cube goes, the camera looks at the snow of
    the first frame (in the mesh now) and of the last."""
    if bpy.data.filepath:
        return
    scene.render.engine = "CYCLES"  # EEVEE of Blender 3 draws no points
    cube = bpy.data.objects.get("Cube")
    if cube and cube.type == "MESH" and len(cube.data.vertices) == 8:
        bpy.data.objects.remove(cube)
    camera = scene.camera
    if camera is None or not len(particles.data.vertices):
        return
    from mathutils import Vector
    bpy.context.view_layer.update()
    first = np.empty(3 * len(particles.data.vertices), np.float32)
    particles.data.vertices.foreach_get("co", first)
    last = read_ply(last_frame)
    local = np.vstack([first.reshape(-1, 3), np.column_stack([last["x"], last["y"], last["z"]])])
    world = local @ np.array(particles.matrix_world.to_3x3()).T
    low = Vector(world.min(axis=0)) + particles.matrix_world.translation
    high = Vector(world.max(axis=0)) + particles.matrix_world.translation
    centre, reach = (low + high) / 2, max((high - low).length / 2, 0.01)
    direction = Vector((0.55, -1.0, 0.45)).normalized()
    distance = 2.2 * reach / math.tan(camera.data.angle / 2)
    camera.location = centre + distance * direction
    camera.rotation_mode = "QUATERNION"
    camera.rotation_quaternion = (-direction).to_track_quat("-Z", "Y")
    camera.data.clip_start = distance / 1000
    camera.data.clip_end = distance * 100


def load_run(run_dir, with_volume=False):
    run_dir = os.path.abspath(run_dir)
    if not os.path.isdir(run_dir):
        fail(run_dir + ": no such directory (the run's -o)")
    files = frame_files(run_dir, "ply")
    if not files:
        fail(run_dir + ": no frame_NNNNN.ply files (was the run made with --no-ply?)")
    volumes = frame_files(run_dir, "vdb") if with_volume else {}
    if with_volume and not volumes:
        fail(run_dir + ": no frame_NNNNN.vdb files (run snowsim with --vdb)")
    # The frame rate from run.json; a run killed before it wrote one: from the frames' times.
    run_json = os.path.join(run_dir, "run.json")
    if os.path.exists(run_json):
        with open(run_json) as f:
            fps = float(json.load(f)["fps"])
    else:
        fps = frame_rate_of(list(files.values()))
    scene = bpy.context.scene
    up = ply_comment(next(iter(files.values())), "up") or "y"
    particles = load_particles(run_dir, scene, files, up)
    # The frame rate as an integer over a base, as Blender keeps it (50 fps: 50 / 1).
    scene.render.fps = max(1, round(fps))
    scene.render.fps_base = scene.render.fps / fps
    scene.frame_start = next(iter(files))
    scene.frame_end = next(reversed(files))
    if with_volume:
        load_volume(run_dir, scene, volumes, up)
    for shape in load_colliders(run_dir, scene, up):
        print("blender_load_run.py: a %s collider is not drawn" % shape, file=sys.stderr)
    register_handler()
    scene.frame_set(scene.frame_start)
    frame_startup_scene(scene, particles, next(reversed(files.values())))
    return particles


def frame_rate_of(paths):
    """Frames per second from the times of the first two frames (else 24)."""
    times = [float(t) for t in (ply_comment(p, "time") for p in paths[:2]) if t is not None]
    return 1 / (times[1] - times[0]) if len(times) == 2 and times[1] > times[0] else 24.0


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    paths = [a for a in argv if not a.startswith("--")]
    run_dir = paths[0] if paths else RUN_DIR
    if not run_dir:  # a saved file opened again: its objects need the handler, nothing more
        register_handler()
        return
    load_run(run_dir, with_volume="--vdb" in argv)


if __name__ == "__main__":
    main()

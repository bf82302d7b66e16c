"""Loads a snowsim run into Blender (3.4 or later; tested with Debian's 3.4) as one animated object.

    blender --python scripts/blender_load_run.py -- RUN_DIR [--vdb] [--bake]
    blender -b --python-exit-code 1 --python scripts/blender_load_run.py --python-expr
        "import bpy, os; bpy.ops.wm.save_as_mainfile(filepath=os.path.abspath('run.blend'))"
        -- RUN_DIR --vdb

(the second, on one line, without a display: the loaded run saved to run.blend; a run that
cannot be loaded, or an unknown option, ends Blender with exit code 1 and saves nothing)

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

With --bake, each frame's PLY becomes its own mesh object, `snowsim_particles_NNNNN`, under an
empty `snowsim_particles`, visible from its frame until the next (keyframed hide_viewport and
hide_render): every frame is in the file, which plays with no script, at about 44 bytes per
particle and frame.

With --vdb, the run's frame_NNNNN.vdb files (snowsim run --vdb) become a volume object,
`snowsim_volume`, with the grids `density` and `velocity`, turned the same way.

A run made with --surface has surface_NNNNN.ply files: without --bake they become one mesh
object, `snowsim_surface`, shaded smooth, turned the same way, whose vertices and triangles the
same handler swaps in from each frame's file; with --bake, a mesh object per frame,
`snowsim_surface_NNNNN`, under an empty `snowsim_surface`, keyframed as the particles are.

The run's colliders (colliders.json: boxes, spheres, planes, drums and meshes, posed at every
frame) become objects under an empty, `snowsim_colliders`, turned the same way, keyframed frame by
frame. The domain's floor becomes a plane, `snowsim_ground`, at Blender's z = 0. Loaded into
Blender's unsaved startup scene, the default cube goes, the camera takes the scene's placed camera
(run.json's resolved_scene) or frames the snow from its preset's side, or another that no collider
blocks, and Cycles renders without a denoiser (Debian's Blender has none). Loading the same run
again updates its objects rather than adding more.

Blender does not store Python handlers in files: without --bake, the file keeps this script as a
text block, `snowsim_frame_change.py`, registered to run when the file opens, which it does only
where auto-run of Python scripts is allowed (Preferences > Save & Load > Auto Run Python Scripts,
the "Allow Execution" button Blender shows, or `blender -y`); else the file shows its first frame
throughout, until this script is run with no run directory (which registers the handler).
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
# The command line's options after the run directory.
OPTIONS = {
    "--vdb": "the run's VDB frames as a volume object",
    "--bake": "every frame's particles and surface kept in the file: a saved file plays with "
              "no script",
}
# The text block of a loaded file: this script, set to register the handler only, which Blender
# runs when it opens the file if auto-run of Python scripts is allowed.
TEXT_NAME = "snowsim_frame_change.py"
REGISTER_ONLY = globals().get("REGISTER_ONLY", False)


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
    words = ply_comment_words(path, key)
    return words[0] if words else None


def frame_files(run_dir, extension, prefix="frame_"):
    """{snowsim frame number: path} of the run's PREFIXNNNNN.EXT files (frame_, surface_)."""
    files = {}
    for name in os.listdir(run_dir):
        stem, ext = os.path.splitext(name)
        number = stem[len(prefix):]
        if ext == "." + extension and stem.startswith(prefix) and number.isdigit():
            files[int(number)] = os.path.join(run_dir, name)
    return dict(sorted(files.items()))


def read_surface_ply(path):
    """A surface_NNNNN.ply (snowsim run --surface): its vertex positions and triangles."""
    with open(path, "rb") as f:
        counts, properties = {}, []
        while True:
            words = f.readline().decode("ascii").split()
            if words == ["end_header"]:
                break
            if words and words[0] == "element":
                counts[words[1]] = int(words[2])
            if words and words[0] == "property" and words[1] != "list":
                properties.append((words[2], PLY_TYPES[words[1]]))
        vertices = np.fromfile(f, dtype=np.dtype(properties), count=counts["vertex"])
        faces = np.fromfile(f, dtype=np.dtype([("n", "u1"), ("v", "<u4", (3,))]),
                            count=counts["face"])
    if len(faces) and (faces["n"] != 3).any():
        raise ValueError(path + ": only triangles are read")
    return np.column_stack([vertices["x"], vertices["y"], vertices["z"]]), faces["v"]


def show_surface(obj, path):
    """Puts the surface mesh at `path` into the object's mesh."""
    positions, triangles = read_surface_ply(path)
    mesh = obj.data
    mesh.clear_geometry()
    mesh.vertices.add(len(positions))
    mesh.vertices.foreach_set("co", positions.astype(np.float32).ravel())
    mesh.loops.add(3 * len(triangles))
    mesh.loops.foreach_set("vertex_index", triangles.astype(np.int32).ravel())
    mesh.polygons.add(len(triangles))
    mesh.polygons.foreach_set("loop_start", np.arange(0, 3 * len(triangles), 3, dtype=np.int32))
    mesh.polygons.foreach_set("loop_total", np.full(len(triangles), 3, dtype=np.int32))
    mesh.update(calc_edges=True)
    mesh.polygons.foreach_set("use_smooth", np.ones(len(triangles), dtype=bool))
    obj["snowsim_surface_file"] = path


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
        if run_dir and "snowsim_surface_file" in obj:
            surfaces = frame_files(run_dir, "ply", "surface_")
            earlier = [k for k in surfaces if k <= scene.frame_current]
            if surfaces:
                path = surfaces[earlier[-1] if earlier else next(iter(surfaces))]
                if obj.get("snowsim_surface_file") != path:
                    show_surface(obj, path)
            continue
        # The particles: a run's mesh that shows a frame (not its ground).
        if not run_dir or obj.type != "MESH" or "snowsim_frame_file" not in obj:
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


def install_text_block():
    """Keeps this script in the file as a text block that runs on opening it: Blender does not
    store Python handlers in files."""
    path = globals().get("__file__", "")
    if os.path.isfile(path):
        with open(path) as f:
            source = f.read()
    else:  # run from Blender's Text Editor: the text block it ran from
        text = bpy.data.texts.get(os.path.basename(path))
        if text is None:
            print("blender_load_run.py: the file will need this script to play", file=sys.stderr)
            return
        source = text.as_string()
    text = bpy.data.texts.get(TEXT_NAME) or bpy.data.texts.new(TEXT_NAME)
    text.clear()
    text.write("# Written by blender_load_run.py. Run when the file opens (with auto-run of Python\n"
               "# scripts allowed), it registers the handler that shows each frame's PLY.\n"
               "REGISTER_ONLY = True\n" + source)
    text.use_module = True


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


def run_object(name, run_dir, scene, kind):
    """The run's object `name`, made and linked the first time."""
    obj = object_of_run(name, run_dir, kind)
    if obj is None:
        data = {"MESH": bpy.data.meshes, "VOLUME": bpy.data.volumes}.get(kind)
        obj = bpy.data.objects.new(name, data.new(name) if data is not None else None)
        scene.collection.objects.link(obj)
        obj["snowsim_run"] = run_dir
    return obj


def load_particles(run_dir, scene, files, up):
    first = next(iter(files.values()))
    obj = run_object("snowsim_particles", run_dir, scene, "MESH")
    turn_to_z_up(obj, up)
    show_frame(obj, first)
    if "snowsim_points" not in obj.modifiers:
        modifier = obj.modifiers.new("snowsim_points", "NODES")
        modifier.node_group = points_node_group()
    return obj


def bake_particles(run_dir, scene, files, up):
    """--bake: each frame's particles as a mesh object under the empty `snowsim_particles`,
    visible from its frame until the next one (keyframed), so the file plays without a script."""

    def fill(obj, path):
        show_frame(obj, path)
        obj.modifiers.new("snowsim_points", "NODES").node_group = points_node_group()

    return bake_sequence("snowsim_particles", run_dir, scene, files, up, fill)


def bake_sequence(name, run_dir, scene, files, up, fill):
    """Each of `files` as a mesh object NAME_NNNNN under the empty NAME, filled by fill(obj, path)
    and visible from its frame until the next one (keyframed hide_viewport and hide_render)."""
    parent = run_object(name, run_dir, scene, "EMPTY")
    turn_to_z_up(parent, up)
    remove_objects(list(parent.children))
    frames = list(files)
    for i, (frame, path) in enumerate(files.items()):
        frame_name = "%s_%05d" % (name, frame)
        obj = bpy.data.objects.new(frame_name, bpy.data.meshes.new(frame_name))
        scene.collection.objects.link(obj)
        obj.parent = parent
        obj["snowsim_frame"] = frame
        fill(obj, path)
        keys = [(frame, False)]
        if frame != frames[0]:
            keys.insert(0, (frames[0], True))
        if i + 1 < len(frames):
            keys.append((frames[i + 1], True))
        for key, hidden in keys:
            obj.hide_viewport = obj.hide_render = hidden
            obj.keyframe_insert("hide_viewport", frame=key)
            obj.keyframe_insert("hide_render", frame=key)
        for curve in obj.animation_data.action.fcurves:
            for point in curve.keyframe_points:
                point.interpolation = "CONSTANT"
    return parent


def remove_objects(objects):
    for obj in objects:
        remove_objects(list(obj.children))
        data = obj.data
        bpy.data.objects.remove(obj)
        if data is not None and data.users == 0 and isinstance(data, bpy.types.Mesh):
            bpy.data.meshes.remove(data)


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
    obj = run_object("snowsim_volume", run_dir, scene, "VOLUME")
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
    parent = run_object("snowsim_colliders", run_dir, scene, "EMPTY")
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


def load_ground(run_dir, scene, first_file):
    """The domain's floor (snowsim's y = 0, Blender's z = 0) as a plane, `snowsim_ground`,
    reaching past the grid by its largest side so that a camera above it sees ground behind."""
    cells = [float(c) for c in (ply_comment_words(first_file, "cells") or ["1", "1", "1"])]
    h = float(ply_comment(first_file, "cell_size") or 0.01)
    width, depth = cells[0] * h, (cells[2] if len(cells) > 2 and cells[2] > 0 else cells[0]) * h
    margin = max(width, depth)
    obj = run_object("snowsim_ground", run_dir, scene, "MESH")
    mesh = obj.data
    mesh.clear_geometry()
    # snowsim's x and z as Blender's x and -y.
    x0, x1, y0, y1 = -margin, width + margin, -depth - margin, margin
    mesh.from_pydata([(x0, y0, 0), (x1, y0, 0), (x1, y1, 0), (x0, y1, 0)], [], [(0, 1, 2, 3)])
    mesh.update()
    if not mesh.materials:
        material = bpy.data.materials.get("snowsim_ground") or bpy.data.materials.new(
            "snowsim_ground")
        material.diffuse_color = (0.25, 0.26, 0.28, 1)  # darker than the snow, which stands out
        material.use_nodes = True
        shader = material.node_tree.nodes.get("Principled BSDF")
        if shader:
            shader.inputs["Base Color"].default_value = material.diffuse_color
            shader.inputs["Roughness"].default_value = 0.9
        mesh.materials.append(material)
    return obj


def ply_comment_words(path, key):
    """All the values of a frame's `comment snowsim KEY ...` line, or None."""
    with open(path, "rb") as f:
        for line in f:
            words = line.decode("ascii", "replace").split()
            if words[:3] == ["comment", "snowsim", key]:
                return words[3:]
            if words[:1] == ["end_header"]:
                return None
    return None


def to_blender(p):
    """A point of snowsim's y-up world in Blender's z-up world: (x, y, z) -> (x, -z, y)."""
    from mathutils import Vector
    return Vector((p[0], -p[2], p[1]))


# From the snow towards the camera in Blender's world: snowsim's presets (render/camera.cpp)
# turned z up, then the same from the other sides, for a view a collider blocks.
PRESET_DIRECTIONS = {
    "three_quarter": (0.6, -1, 0.5), "front": (0, -1, 0.25), "side": (1, 0, 0.25), "top": (0, 0, 1),
}
OTHER_DIRECTIONS = [(0.55, -1, 0.45), (-0.6, -1, 0.5), (0.6, 1, 0.5), (-0.6, 1, 0.5),
                    (-1, 0, 0.25), (0, 1, 0.25)]


def frame_startup_scene(scene, run, files):
    """In Blender's unsaved startup scene: the default cube goes, the camera takes the scene's
    placed camera or frames the snow of the first and last frames from a side no collider
    blocks, and Cycles renders without a denoiser (Debian's Blender has none)."""
    if bpy.data.filepath:
        return
    scene.render.engine = "CYCLES"  # EEVEE of Blender 3 draws no points
    scene.cycles.samples = 64
    scene.cycles.use_denoising = False
    scene.cycles.use_preview_denoising = False
    for layer in scene.view_layers:
        if hasattr(layer, "cycles"):
            layer.cycles.use_denoising = False
    if "image" in run:
        scene.render.resolution_x, scene.render.resolution_y = run["image"]
        scene.render.resolution_percentage = 100
    cube = bpy.data.objects.get("Cube")
    if cube and cube.type == "MESH" and len(cube.data.vertices) == 8:
        bpy.data.objects.remove(cube)
    camera = scene.camera
    if camera is None:
        return
    from mathutils import Matrix, Vector
    placed = run.get("resolved_scene", {}).get("render", {}).get("camera", {})
    camera.data.sensor_fit = "VERTICAL"
    camera.data.angle = math.radians(placed.get("fov", 35))
    up = Vector((0, 0, 1))
    if "eye" in placed:
        eye, target = to_blender(placed["eye"]), to_blender(placed["target"])
        up = to_blender(placed.get("up", (0, 1, 0)))
    else:
        low, high = snow_box(files)
        target = (low + high) / 2
        eye = clear_view(scene, camera, low, high, placed.get("preset"))
        if placed.get("preset") == "top":
            up = Vector((0, 1, 0))
    forward = (target - eye).normalized()
    right = forward.cross(up).normalized()
    camera.location = eye
    camera.rotation_mode = "QUATERNION"
    camera.rotation_quaternion = Matrix((right, right.cross(forward), -forward)).transposed() \
        .to_quaternion()
    distance = (target - eye).length
    camera.data.clip_start = distance / 1000
    camera.data.clip_end = distance * 100


def snow_box(files):
    """The lowest and highest corners, in Blender's world, of the first and last frames' snow."""
    points = []
    for path in {next(iter(files.values())), next(reversed(files.values()))}:
        columns = read_ply(path)
        xyz = np.column_stack([columns["x"], columns["y"], columns["z"]]).astype(np.float64)
        if ply_comment(path, "up") != "z":
            xyz = np.column_stack([xyz[:, 0], -xyz[:, 2], xyz[:, 1]])
        pad = float(columns["pscale"].max()) if "pscale" in columns and len(xyz) else 0.0
        points += [xyz.min(axis=0) - pad, xyz.max(axis=0) + pad]
    from mathutils import Vector
    return Vector(np.min(points, axis=0)), Vector(np.max(points, axis=0))


def clear_view(scene, camera, low, high, preset):
    """The eye that frames the box (its eight corners in the image with a 10% margin) from the
    preset's direction, or else from the first direction where the colliders and the ground hide
    none of the box's centre and corners at the first and last frames (the fewest if all do)."""
    from mathutils import Vector
    centre = (low + high) / 2
    corners = [Vector((a[0], b[1], c[2])) for a in (low, high) for b in (low, high)
               for c in (low, high)]
    aspect = scene.render.resolution_x / scene.render.resolution_y
    tan_v = math.tan(camera.data.angle / 2) / 1.1
    tan_h = tan_v * aspect
    directions = [PRESET_DIRECTIONS[preset]] if preset in PRESET_DIRECTIONS else []
    directions += OTHER_DIRECTIONS + list(PRESET_DIRECTIONS.values())
    best, fewest = None, None
    for d in directions:
        back = Vector(d).normalized()
        world_up = Vector((0, 1, 0)) if abs(back.z) > 0.99 else Vector((0, 0, 1))
        right = world_up.cross(back).normalized()
        up = back.cross(right)
        distance = max([1e-3] + [(c - centre).dot(back) + max(abs((c - centre).dot(right)) / tan_h,
                                                               abs((c - centre).dot(up)) / tan_v)
                                 for c in corners])
        eye = centre + distance * back
        hidden = sum(hidden_points(scene, eye, [centre] + corners, frame)
                     for frame in (scene.frame_start, scene.frame_end))
        if fewest is None or hidden < fewest:
            best, fewest = eye, hidden
        if hidden == 0:
            break
    scene.frame_set(scene.frame_start)
    return best


def hidden_points(scene, eye, points, frame):
    """How many of the points a face (a collider's, the ground's) hides from the eye at the frame."""
    scene.frame_set(frame)
    depsgraph = bpy.context.evaluated_depsgraph_get()
    hidden = 0
    for p in points:
        # Stopping short of the point: snow on the ground touches it.
        hidden += blocker(scene, depsgraph, eye, p, 0.98) is not None
    return hidden


def blocker(scene, depsgraph, eye, point, reach=1.0):
    """The first object other than the snow's surface between the eye and `reach` of the way to
    the point, else None: the snow's own surface does not hide the snow."""
    start, towards = eye, point - eye
    end = eye + towards * reach
    direction = towards.normalized()
    while True:
        left = (end - start).dot(direction)
        if left <= 0:
            return None
        hit, location, _, _, obj, _ = scene.ray_cast(depsgraph, start, direction, distance=left)
        if not hit:
            return None
        if not obj.name.startswith("snowsim_surface"):
            return obj
        start = location + direction * 1e-5


def load_run(run_dir, with_volume=False, bake=False):
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
    run = {}
    if os.path.exists(run_json):
        with open(run_json) as f:
            run = json.load(f)
        fps = float(run["fps"])
    else:
        fps = frame_rate_of(list(files.values()))
    scene = bpy.context.scene
    first = next(iter(files.values()))
    up = ply_comment(first, "up") or "y"
    # Loaded the other way before: that way's particles go.
    remove_objects([o for o in [object_of_run("snowsim_particles", run_dir, "EMPTY" if not bake
                                              else "MESH")] if o])
    if bake:
        particles = bake_particles(run_dir, scene, files, up)
    else:
        particles = load_particles(run_dir, scene, files, up)
    # The frame rate as an integer over a base, as Blender keeps it (50 fps: 50 / 1).
    scene.render.fps = max(1, round(fps))
    scene.render.fps_base = scene.render.fps / fps
    scene.frame_start = next(iter(files))
    scene.frame_end = next(reversed(files))
    if with_volume:
        load_volume(run_dir, scene, volumes, up)
    surfaces = frame_files(run_dir, "ply", "surface_")
    remove_objects([o for o in [object_of_run("snowsim_surface", run_dir, "EMPTY" if not bake
                                              else "MESH")] if o])
    if surfaces and bake:
        bake_sequence("snowsim_surface", run_dir, scene, surfaces, up, show_surface)
    elif surfaces:
        surface = run_object("snowsim_surface", run_dir, scene, "MESH")
        turn_to_z_up(surface, up)
        show_surface(surface, next(iter(surfaces.values())))
    for shape in load_colliders(run_dir, scene, up):
        print("blender_load_run.py: a %s collider is not drawn" % shape, file=sys.stderr)
    load_ground(run_dir, scene, first)
    register_handler()
    if not bake:
        install_text_block()
    scene.frame_set(scene.frame_start)
    frame_startup_scene(scene, run, files)
    return particles


def frame_rate_of(paths):
    """Frames per second from the times of the first two frames (else 24)."""
    times = [float(t) for t in (ply_comment(p, "time") for p in paths[:2]) if t is not None]
    return 1 / (times[1] - times[0]) if len(times) == 2 and times[1] > times[0] else 24.0


def main():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    # A misspelt option would otherwise load the run without what it asked for.
    for a in argv:
        if a.startswith("-") and a not in OPTIONS:
            fail("unknown option %s (known: %s)" % (a, ", ".join(OPTIONS)))
    paths = [a for a in argv if not a.startswith("-")]
    run_dir = paths[0] if paths else RUN_DIR
    if REGISTER_ONLY or not run_dir:  # a saved file opened again: the handler, nothing more
        register_handler()
        return
    load_run(run_dir, with_volume="--vdb" in argv, bake="--bake" in argv)


if __name__ == "__main__":
    main()

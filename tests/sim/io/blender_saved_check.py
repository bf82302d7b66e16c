"""Run by export_test.cpp in a fresh Blender on a .blend the loader saved, without the loader:
writes to the JSON file $SNOWSIM_BLENDER_REPORT what the file shows at its first and last frames
(the snow's vertices in Blender's world), where its camera sees the snow, its ground and its
render settings."""

import json
import os

import bpy
import numpy as np
from bpy_extras.object_utils import world_to_camera_view
from mathutils import Vector


def shown_snow(scene):
    """The world positions of the snow shown at the scene's frame: the vertices of the visible
    meshes loaded from the run (one live object, or a baked one per frame)."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    points = []
    for obj in scene.objects:
        if obj.type != "MESH" or obj.hide_render or not obj.name.startswith("snowsim_particles"):
            continue
        mesh = obj.original.data
        co = np.zeros(len(mesh.vertices) * 3, dtype=np.float64)
        mesh.vertices.foreach_get("co", co)
        m = np.array(obj.evaluated_get(depsgraph).matrix_world)
        co = co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3]
        points.append(co)
    return np.vstack(points) if points else np.zeros((0, 3))


scene = bpy.context.scene
report = {"frames": {}, "texts": [t.name for t in bpy.data.texts]}
for frame in (scene.frame_start, scene.frame_end):
    scene.frame_set(frame)
    snow = shown_snow(scene)
    entry = {"count": len(snow), "positions": snow.ravel().tolist()}
    # The surface meshes shown (a baked file's one per frame): their names and vertices.
    surfaces = [o for o in scene.objects if o.type == "MESH" and not o.hide_render and
                o.name.startswith("snowsim_surface")]
    entry["surfaces"] = {o.name: len(o.data.vertices) for o in surfaces}
    camera = scene.camera
    if camera and len(snow):
        centre = Vector(snow.mean(axis=0))
        entry["centre"] = list(centre)
        entry["in_view"] = list(world_to_camera_view(scene, camera, centre))
        # Whether a face (a collider's, the ground's; not the snow's own surface) lies between
        # the camera and the centre.
        eye = camera.matrix_world.translation
        direction = (centre - eye).normalized()
        start, entry["hidden_by"] = eye, ""
        while True:
            left = (centre - start).dot(direction)
            hit = scene.ray_cast(bpy.context.evaluated_depsgraph_get(), start, direction,
                                 distance=max(left, 0.0))
            if left <= 0 or not hit[0] or not hit[4].name.startswith("snowsim_surface"):
                entry["hidden_by"] = hit[4].name if hit[0] else ""
                break
            start = hit[1] + direction * 1e-5
    report["frames"][str(frame)] = entry
ground = bpy.data.objects.get("snowsim_ground")
if ground:
    corners = [ground.matrix_world @ Vector(c) for c in ground.bound_box]
    report["ground"] = {"min": [min(c[a] for c in corners) for a in range(3)],
                        "max": [max(c[a] for c in corners) for a in range(3)]}
report["engine"] = scene.render.engine
report["denoising"] = bool(scene.cycles.use_denoising) if scene.render.engine == "CYCLES" else False
with open(os.environ["SNOWSIM_BLENDER_REPORT"], "w") as f:
    json.dump(report, f)

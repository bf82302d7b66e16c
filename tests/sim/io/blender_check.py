"""Run by export_test.cpp after scripts/blender_load_run.py, in the same Blender: writes what
Blender holds of the loaded run to the JSON file $SNOWSIM_BLENDER_REPORT, for the test to compare
with the run's files."""

import json
import os

import bpy
import numpy as np


def point_attributes(mesh):
    found = {}
    for a in mesh.attributes:
        if a.domain != "POINT" or a.name == "position":
            continue
        width = 3 if a.data_type == "FLOAT_VECTOR" else 1
        values = np.zeros(len(a.data) * width, dtype=np.int32 if a.data_type == "INT" else np.float32)
        a.data.foreach_get("vector" if width == 3 else "value", values)
        found[a.name] = {"type": a.data_type, "min": float(values.min()), "max": float(values.max())}
    return found


scene = bpy.context.scene
report = {
    "objects": [{"name": o.name, "type": o.type, "from_run": "snowsim_run" in o} for o in scene.objects],
    "frame_start": scene.frame_start,
    "frame_end": scene.frame_end,
    "fps": scene.render.fps / scene.render.fps_base,
    "frames": {},
}
particles = bpy.data.objects["snowsim_particles"]
report["particles_rotation"] = list(particles.rotation_euler)
report["particles_modifiers"] = [m.name for m in particles.modifiers]
report["points_radius"] = [n.inputs["Name"].default_value
                           for m in particles.modifiers if m.type == "NODES"
                           for n in m.node_group.nodes if n.type == "INPUT_ATTRIBUTE"]
report["colliders"] = {
    o.name: {"location": list(o.matrix_world.translation), "dimensions": list(o.dimensions),
             "keyframes": len(o.animation_data.action.fcurves[0].keyframe_points)
             if o.animation_data and o.animation_data.action else 0}
    for o in scene.objects if o.name.startswith("snowsim_collider_")}
for frame in (scene.frame_start, scene.frame_end):
    scene.frame_set(frame)
    mesh = particles.data
    positions = np.zeros(len(mesh.vertices) * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", positions)
    report["frames"][str(frame)] = {
        "count": len(mesh.vertices),
        "positions": positions.tolist(),
        "attributes": point_attributes(mesh),
    }
volume_object = bpy.data.objects.get("snowsim_volume")
if volume_object:
    volume = volume_object.data
    volume.grids.load()
    # The volume's own bound_box is OpenVDB's leaf-node box (8 voxels a side); the surface where
    # density > 0.001 kg/m^3, meshed in the volume's space, shows the voxels' extent.
    surface = bpy.data.objects.new("density_surface", bpy.data.meshes.new("density_surface"))
    scene.collection.objects.link(surface)
    surface.matrix_world = volume_object.matrix_world
    to_mesh = surface.modifiers.new("to_mesh", "VOLUME_TO_MESH")
    to_mesh.object = volume_object
    to_mesh.grid_name = "density"
    to_mesh.threshold = 0.001
    evaluated = surface.evaluated_get(bpy.context.evaluated_depsgraph_get()).data
    corners = np.zeros(len(evaluated.vertices) * 3, dtype=np.float32)
    evaluated.vertices.foreach_get("co", corners)
    corners = corners.reshape(-1, 3)
    report["volume"] = {
        "file": volume.grids.frame_filepath,
        "grids": {g.name: g.data_type for g in volume.grids},
        "error": volume.grids.error_message,
        "rotation": list(volume_object.rotation_euler),
        "surface_vertices": len(corners),
        "density_min": corners.min(axis=0).tolist() if len(corners) else [],
        "density_max": corners.max(axis=0).tolist() if len(corners) else [],
    }
with open(os.environ["SNOWSIM_BLENDER_REPORT"], "w") as f:
    json.dump(report, f)

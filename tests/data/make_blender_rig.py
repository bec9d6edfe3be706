"""Make tests/data/blender_rig.glb and blender_rig.json with Blender (run: blender -b --python THIS_FILE).

An armature of six bones pointing in different directions (so every bone has a rest rotation), under an armature
object that is moved, turned and scaled, with a skinned mesh, two actions ("Wave", keyed every 3rd frame and
sampled by the exporter, and "Hold", two keys) exported with Blender's default glTF settings.  The JSON holds,
for some frames of "Wave", every bone's head in world space as Blender evaluates it (Blender's Z-up metres), so
the test checks motionrep's reading against Blender's own pose.
"""

import json
import math
import sys
from pathlib import Path

import bpy
from mathutils import Vector

out = Path(sys.argv[sys.argv.index("--") + 1]) if "--" in sys.argv else Path(__file__).with_name("blender_rig")
bpy.ops.wm.read_factory_settings(use_empty=True)
scene = bpy.context.scene
scene.render.fps = 30
scene.frame_start, scene.frame_end = 0, 30

arm_data = bpy.data.armatures.new("RigData")
rig = bpy.data.objects.new("Rig", arm_data)
scene.collection.objects.link(rig)
rig.location = (0.5, -0.25, 0.1)
rig.rotation_euler = (0.0, 0.0, math.radians(30))
rig.scale = (0.8, 0.8, 0.8)
bpy.context.view_layer.objects.active = rig
bpy.ops.object.mode_set(mode="EDIT")
bones = {}
for name, parent, head, tail, roll in [
    ("Hips", None, (0, 0, 1.0), (0, 0, 1.2), 0.0),
    ("Spine", "Hips", (0, 0, 1.2), (0, 0.05, 1.6), 0.3),
    ("Head", "Spine", (0, 0.05, 1.6), (0, 0.05, 1.85), 0.0),
    ("Arm.L", "Spine", (0.15, 0.05, 1.55), (0.45, 0.1, 1.5), -0.4),
    ("Leg.L", "Hips", (0.1, 0, 1.0), (0.12, 0.02, 0.55), 0.2),
    ("Leg.R", "Hips", (-0.1, 0, 1.0), (-0.12, 0.02, 0.55), -0.2),
]:
    b = arm_data.edit_bones.new(name)
    b.head, b.tail, b.roll = Vector(head), Vector(tail), roll
    if parent:
        b.parent = bones[parent]
    bones[name] = b
bpy.ops.object.mode_set(mode="OBJECT")

# a skinned box, so the file has a mesh, a skin and vertex weights as an artist's would
bpy.ops.mesh.primitive_cube_add(size=0.3, location=(0, 0, 1.3))
body = bpy.context.active_object
body.parent = rig
mod = body.modifiers.new("Armature", "ARMATURE")
mod.object = rig
group = body.vertex_groups.new(name="Spine")
group.add([v.index for v in body.data.vertices], 1.0, "REPLACE")

rig.animation_data_create()
for action_name, keys in [("Wave", range(0, 31, 3)), ("Hold", (0, 30))]:
    action = bpy.data.actions.new(action_name)
    rig.animation_data.action = action
    for f in keys:
        t = f / 30.0
        pb = rig.pose.bones
        pb["Hips"].location = (0.3 * t, 0.05 * math.sin(6 * t), 0.0) if action_name == "Wave" else (0, 0, 0)
        for name, amp, axis in [("Hips", 15, 2), ("Spine", 20, 0), ("Head", 25, 1), ("Arm.L", 60, 2),
                                ("Leg.L", 35, 0), ("Leg.R", -35, 0)]:
            bone = pb[name]
            bone.rotation_mode = "XYZ"
            angles = [0.0, 0.0, 0.0]
            angles[axis] = math.radians(amp * math.sin(2 * math.pi * t) if action_name == "Wave" else amp / 3)
            bone.rotation_euler = angles
            bone.keyframe_insert("rotation_euler", frame=f)
        pb["Hips"].keyframe_insert("location", frame=f)
    rig.animation_data.action = None
    track = rig.animation_data.nla_tracks.new()
    track.strips.new(action_name, 0, action)
    track.name = action_name

bpy.ops.export_scene.gltf(filepath=str(out.with_suffix(".glb")), export_format="GLB")

# Blender's own pose of "Wave", as the exporter sampled it
rig.animation_data.action = bpy.data.actions["Wave"]
for track in rig.animation_data.nla_tracks:
    track.mute = True
heads = {}
for f in (0, 7, 15, 22, 30):
    scene.frame_set(f)
    heads[f] = {b.name: list(rig.matrix_world @ b.head) for b in rig.pose.bones}
out.with_suffix(".json").write_text(json.dumps({"blender": bpy.app.version_string, "fps": 30, "clip": "Wave",
                                                "heads_z_up": heads}, indent=1))

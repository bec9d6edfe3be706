"""Export a BVH file to FBX with Debian's Blender 3.4: its BVH importer, then its FBX exporter.

Run: ``blender -b --factory-startup --python make_blender_fbx.py -- IN.bvh OUT.fbx [POSE.json]``.  The tests run it on a small
synthetic BVH (tests/test_io_fbx.py regenerates that BVH and made tests/data/blender_walk.fbx this way) and, in a
slow real-data test, on the clips of ../shared/data.

Settings: the BVH is imported at scale 1 (one BVH unit = one Blender unit), each bone keeping its BVH rotation
order, the scene at the clip's frame rate; the FBX exporter writes the armature alone, baked on every frame with
no key simplification (``bake_anim_simplify_factor=0``) and no leaf bones, at scale 1 with Blender's default axes
(-Z forward, Y up: the BVH's own axes back).  Blender 3.4's BVH importer opens the file with mode ``'rU'``, which
Python 3.11 removed: ``builtins.open`` is wrapped to drop the ``U`` for the import.

With ``POSE.json``, Blender's own pose of the imported armature is written too: per frame, every bone's head in
world space, turned back to the BVH's Y up (Blender's ``(x, y, z)`` is the BVH's ``(x, -z, y)``).  Blender poses
in float32: the tests compare the FBX file's error with Blender's own.
"""

import builtins
import json
import sys

import bpy

args = sys.argv[sys.argv.index("--") + 1:]
source, target = args[0], args[1]
pose_path = args[2] if len(args) > 2 else None

_open = builtins.open


def _open_without_u(file, mode="r", *rest, **kwargs):
    if isinstance(mode, str) and "U" in mode:
        mode = mode.replace("U", "") or "r"
    return _open(file, mode, *rest, **kwargs)


bpy.ops.wm.read_factory_settings(use_empty=True)
builtins.open = _open_without_u
try:
    bpy.ops.import_anim.bvh(filepath=source, global_scale=1.0, rotate_mode="NATIVE", use_fps_scale=False,
                            update_scene_fps=True, update_scene_duration=True)
finally:
    builtins.open = _open
scene = bpy.context.scene
# the scene spans the keys exactly (the importer only ever extends the scene; a 1-key action's frame_range is 2)
keys = [k.co[0] for c in bpy.context.object.animation_data.action.fcurves for k in c.keyframe_points]
scene.frame_start, scene.frame_end = int(round(min(keys))), int(round(max(keys)))
bpy.ops.export_scene.fbx(filepath=target, object_types={"ARMATURE"}, add_leaf_bones=False, bake_anim=True,
                         bake_anim_use_all_actions=False, bake_anim_use_nla_strips=False,
                         bake_anim_simplify_factor=0.0, bake_anim_force_startend_keying=True,
                         global_scale=1.0, apply_unit_scale=False, apply_scale_options="FBX_SCALE_UNITS")
if pose_path:
    rig = bpy.context.object
    pose = []
    for frame in range(scene.frame_start, scene.frame_end + 1):
        scene.frame_set(frame)
        pose.append({b.name: [(rig.matrix_world @ b.head)[i] for i in (0, 2, 1)] for b in rig.pose.bones})
    for frame in pose:
        for head in frame.values():
            head[2] = -head[2]
    with open(pose_path, "w") as fh:
        json.dump(pose, fh)

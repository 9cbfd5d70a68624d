"""Import a BVH file in Blender (``bpy``) as a user would, and print the world position of every
bone's head at the given BVH frames as JSON (run in a subprocess by the tests, with a Python that
has ``bpy``).

Usage: python blender_bvh_import.py FILE.bvh FRAME [FRAME ...]
Blender turns BVH's y-up into its z-up (axis_up Y, axis_forward -Z) and the centimetres into
metres (global_scale 0.01); BVH frame k is Blender frame k + 1.
"""

import json
import sys

import bpy

path, frames = sys.argv[1], [int(f) for f in sys.argv[2:]]
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_anim.bvh(filepath=path, axis_forward="-Z", axis_up="Y", rotate_mode="NATIVE", global_scale=0.01,
                        update_scene_duration=True)
armature = next(o for o in bpy.context.scene.objects if o.type == "ARMATURE")
result = {}
for frame in frames:
    bpy.context.scene.frame_set(frame + 1)
    result[frame] = {bone.name: list(armature.matrix_world @ bone.head) for bone in armature.pose.bones}
print("BONES " + json.dumps(result))

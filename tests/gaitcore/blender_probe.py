"""Runs inside Blender's Python (the ``bpy`` module), never inside pytest.

    python tests/gaitcore/blender_probe.py CLIP.bvh CLIP.glb OUT_DIR

Imports the BVH and the GLB the way docs/blender.md says (the settings of the one-click
result), then writes ``OUT_DIR/blender.json`` with what Blender made of them: bone counts,
frame ranges, the scene's frame rate and, for every bone and frame, its head and tail and its
rotation from the rest pose, in Gait Studio's axes (Y up). It also renders the middle frame
with the Workbench engine to ``OUT_DIR/blender.png`` and re-exports the BVH as
``OUT_DIR/reexported.bvh`` (Blender writes it Z up). Only the standard library and bpy are
used: the comparison with Gait Studio's own numbers is done by the test, in the project's
interpreter.
"""

import json
import sys
from pathlib import Path

import bpy
from mathutils import Matrix, Vector

TO_OURS = Matrix(((1, 0, 0), (0, 0, 1), (0, -1, 0)))
"""Blender's Z-up world to Gait Studio's Y-up (the importers map our Y to Blender's Z)."""


def armature_motion(arm, frames) -> dict:
    """Heads, tails and rotations from rest of every bone at every frame, our axes."""
    scene = bpy.context.scene
    out = {"bones": [b.name for b in arm.pose.bones], "heads": [], "tails": [], "rotations": []}
    world = arm.matrix_world
    for f in frames:
        scene.frame_set(f)
        heads, tails, rots = [], [], []
        for pb in arm.pose.bones:
            heads.append(list(TO_OURS @ (world @ pb.head)))
            tails.append(list(TO_OURS @ (world @ pb.tail)))
            delta = (world @ pb.matrix @ pb.bone.matrix_local.inverted() @ world.inverted())
            rot = TO_OURS @ delta.to_3x3() @ TO_OURS.transposed()
            rots.append([list(row) for row in rot])
        out["heads"].append(heads)
        out["tails"].append(tails)
        out["rotations"].append(rots)
    return out


def make_cyclic(action) -> None:
    """What Graph Editor > Channel > Extrapolation Mode > Make Cyclic does to every curve
    (the BVH importer's own Loop option leaves armature curves alone in Blender 4.5)."""
    for layer in action.layers:
        for strip in layer.strips:
            for bag in strip.channelbags:
                for curve in bag.fcurves:
                    curve.modifiers.new("CYCLES")
                    curve.update()
    action.update_tag()  # as the operator does; without it the pose ignores the modifiers


def import_bvh(path: str, report: dict) -> object:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_anim.bvh(filepath=path, update_scene_fps=True, update_scene_duration=True)
    scene = bpy.context.scene
    arm = next(o for o in scene.objects if o.type == "ARMATURE")
    make_cyclic(arm.animation_data.action)
    first, last = (int(round(v)) for v in arm.animation_data.action.frame_range)
    report["bvh"] = {"n_bones": len(arm.data.bones), "action_range": [first, last],
                     "fps": scene.render.fps, "fps_base": scene.render.fps_base,
                     "scene_range": [scene.frame_start, scene.frame_end],
                     # past the last frame the Cycles modifiers play on
                     "motion": armature_motion(arm, range(first, last + 3))}
    return arm


def import_glb(path: str, report: dict) -> None:
    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=path)
    scene = bpy.context.scene
    arm = next(o for o in scene.objects if o.type == "ARMATURE")
    first, last = (int(round(v)) for v in arm.animation_data.action.frame_range)
    skinned = [o for o in scene.objects if o.type == "MESH" and o.find_armature() is arm]
    report["glb"] = {"n_bones": len(arm.data.bones), "action_range": [first, last],
                     "n_skinned": len(skinned),
                     "motion": armature_motion(arm, range(first, last + 1))}


def render(path: Path, frame: int) -> None:
    """The skinned bones at ``frame`` over a green ground, side view, with Workbench."""
    scene = bpy.context.scene
    scene.frame_set(frame)
    scene.render.engine = "BLENDER_WORKBENCH"
    scene.render.resolution_x, scene.render.resolution_y = 640, 360
    scene.display.shading.light = "STUDIO"
    scene.display.shading.color_type = "OBJECT"
    scene.world = bpy.data.worlds.new("sky")
    scene.world.color = (0.8, 0.85, 0.9)
    arm = next(o for o in scene.objects if o.type == "ARMATURE")
    heads = [arm.matrix_world @ pb.head for pb in arm.pose.bones]
    centre = sum(heads, Vector()) / len(heads)
    camera = bpy.data.objects.new("side", bpy.data.cameras.new("side"))
    scene.collection.objects.link(camera)
    camera.data.type = "ORTHO"
    camera.data.ortho_scale = 4.0
    camera.location = (centre.x, centre.y - 8.0, centre.z + 1.4)  # our +Z side, a bit above
    camera.rotation_euler = (1.396, 0.0, 0.0)  # 10 degrees down
    scene.camera = camera
    floor = bpy.data.meshes.new("floor")
    x, y = centre.x, centre.y
    floor.from_pydata([(x - 3, y - 1, 0), (x + 3, y - 1, 0), (x + 3, y + 1, 0), (x - 3, y + 1, 0)],
                      [], [(0, 1, 2, 3)])
    ground = bpy.data.objects.new("ground", floor)
    ground.color = (0.35, 0.6, 0.3, 1.0)
    scene.collection.objects.link(ground)
    for mesh in (o for o in scene.objects if o.type == "MESH" and o is not ground):
        mesh.color = (0.55, 0.4, 0.3, 1.0)
    scene.render.filepath = str(path)
    bpy.ops.render.render(write_still=True)


def main(bvh: str, glb: str, out_dir: str) -> None:
    out = Path(out_dir)
    report = {"blender": bpy.app.version_string}
    import_bvh(bvh, report)
    bpy.ops.export_anim.bvh(filepath=str(out / "reexported.bvh"),
                            frame_start=report["bvh"]["action_range"][0],
                            frame_end=report["bvh"]["action_range"][1], rotate_mode="NATIVE")
    import_glb(glb, report)
    first, last = report["glb"]["action_range"]
    render(out / "blender.png", (first + last) // 2)
    (out / "blender.json").write_text(json.dumps(report))


if __name__ == "__main__":
    main(*sys.argv[-3:])

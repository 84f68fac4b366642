"""Renders a crumple glTF export in Blender (a third party's importer and renderer): the animation's middle and
last frames, a camera following one body. Run with Blender's own Python:

  blender -b -P tools/blender-render.py -- EXPORT.gltf OUT_PREFIX [BODY]

writes OUT_PREFIX_mid.png and OUT_PREFIX_end.png (Cycles on the CPU, 640 x 360) and prints what the importer
found: the animations, the followed body's key frames and its place at the first, middle and last frame (glTF's
y up is Blender's z up: Blender's (x, y, z) is glTF's (x, -z, y)). BODY defaults to "car"."""
import sys

import numpy

numpy.bool = bool  # Debian 12's Blender 3.4 glTF importer still names np.bool, which numpy 1.24 removed

import bpy  # noqa: E402
import mathutils  # noqa: E402

args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
if len(args) < 2 or args[0] in ("-h", "--help"):
    print(__doc__)
    sys.exit(0 if args and args[0] in ("-h", "--help") else 2)
path, prefix = args[0], args[1]
name = args[2] if len(args) > 2 else "car"

bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=path)
scene = bpy.context.scene
body = bpy.data.objects.get(name)
if body is None or body.animation_data is None or body.animation_data.action is None:
    sys.exit("%s: no animated body named %s (export with --animate)" % (path, name))
frames = sorted({int(k.co[0]) for fc in body.animation_data.action.fcurves for k in fc.keyframe_points})
print("animations: %d; %s: %d key frames, frames %d..%d at %d fps" %
      (len(bpy.data.actions), name, len(frames), frames[0], frames[-1], scene.render.fps))
middle = (frames[0] + frames[-1]) // 2
for f in (frames[0], middle, frames[-1]):
    scene.frame_set(f)
    print("frame %d: %s at (%.2f, %.2f, %.2f)" % ((f, name) + tuple(body.matrix_world.translation)))

camera = bpy.data.objects.new("camera", bpy.data.cameras.new("camera"))
scene.collection.objects.link(camera)
scene.camera = camera
sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", "SUN"))
scene.collection.objects.link(sun)
sun.rotation_euler = (0.7, 0.2, 0.8)
sun.data.energy = 3.0
world = bpy.data.worlds.new("sky")
scene.world = world
world.use_nodes = True
world.node_tree.nodes["Background"].inputs[0].default_value = (0.6, 0.7, 0.85, 1)
world.node_tree.nodes["Background"].inputs[1].default_value = 0.8
scene.render.engine = "CYCLES"
scene.cycles.device = "CPU"
scene.cycles.samples = 24
scene.cycles.use_denoising = False
scene.render.resolution_x, scene.render.resolution_y = 640, 360
for f, suffix in ((middle, "mid"), (frames[-1], "end")):
    scene.frame_set(f)
    target = body.matrix_world.translation.copy()
    camera.location = target + mathutils.Vector((6.0, -7.0, 3.0))
    camera.rotation_euler = (target - camera.location).to_track_quat("-Z", "Y").to_euler()
    scene.render.filepath = "%s_%s.png" % (prefix, suffix)
    bpy.ops.render.render(write_still=True)
    print("wrote", scene.render.filepath)

# Renders an exported school in Blender (Cycles on the CPU, 16 samples) at a time, from the
# front and above, framing every joint. Run by hand with `pip install bpy==4.2.0` (Python 3.11):
#   python tools/blender-render.py school.glb 5 school.png
import sys, math
import bpy, mathutils
glb, t, out = sys.argv[1], float(sys.argv[2]), sys.argv[3]
bpy.ops.wm.read_factory_settings(use_empty=True)
sc = bpy.context.scene
sc.render.fps = 60
bpy.ops.import_scene.gltf(filepath=glb)
sc.frame_set(int(t * 60))
bpy.context.view_layer.update()
pts = []
for ob in sc.objects:
    if ob.type == 'ARMATURE':
        pts += [ob.matrix_world @ pb.head for pb in ob.pose.bones]
c = sum(pts, mathutils.Vector()) / len(pts)
r = max((p - c).length for p in pts)
cam = bpy.data.objects.new("cam", bpy.data.cameras.new("cam"))
sc.collection.objects.link(cam)
d = mathutils.Vector((0.35, -1.0, 0.45)).normalized()
cam.location = c + d * r * 1.5
cam.rotation_euler = (-d).to_track_quat('-Z', 'Y').to_euler()
cam.data.lens = 40
sc.camera = cam
sun = bpy.data.objects.new("sun", bpy.data.lights.new("sun", 'SUN'))
sun.data.energy = 3.0
sun.rotation_euler = (math.radians(30), math.radians(10), 0)
sc.collection.objects.link(sun)
world = bpy.data.worlds.new("w")
world.use_nodes = True
world.node_tree.nodes["Background"].inputs[0].default_value = (0.02, 0.08, 0.14, 1)
world.node_tree.nodes["Background"].inputs[1].default_value = 1.5
sc.world = world
sc.render.engine = 'CYCLES'
sc.cycles.device = 'CPU'
sc.cycles.samples = 16
sc.render.resolution_x, sc.render.resolution_y = 960, 540
sc.render.filepath = out
bpy.ops.render.render(write_still=True)
print("rendered", out)

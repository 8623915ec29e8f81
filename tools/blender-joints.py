# Imports an exported school into Blender (its own glTF importer) and compares every bone
# head's world position at a time with `shoal inspect --at T --json`. Not part of the tests
# (Blender is not in CI): run by hand with Blender as a Python module, `pip install bpy==4.2.0`
# (Python 3.11):
#   shoal inspect school.shoalrun --at 2.5 --json > at.json
#   python tools/blender-joints.py school.glb at.json 2.5
import json, sys
import bpy
glb, ins_path, t = sys.argv[1], sys.argv[2], float(sys.argv[3])
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.context.scene.render.fps = 60
bpy.ops.import_scene.gltf(filepath=glb)
frame = t * 60
bpy.context.scene.frame_set(int(frame), subframe=frame - int(frame))
bpy.context.view_layer.update()
heads = {}
for ob in bpy.context.scene.objects:
    if ob.type != 'ARMATURE':
        continue
    for pb in ob.pose.bones:
        p = ob.matrix_world @ pb.head
        heads[pb.name] = (p.x, p.z, -p.y)  # Blender Z-up back to glTF Y-up
ins = json.load(open(ins_path))
worst, n, missing = 0.0, 0, 0
for f in ins['at']['fish']:
    L = f['body_length']
    for j in f['joints']:
        h = heads.get(j['node'])
        if h is None:
            missing += 1
            continue
        d = sum((a - b) ** 2 for a, b in zip(h, j['pos'])) ** 0.5 / L
        worst = max(worst, d)
        n += 1
print(f"blender {bpy.app.version_string}: t={t} s, {n} joints compared, {missing} missing, worst {worst:.3g} L")

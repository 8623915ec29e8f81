// Plays a glTF animation back with three.js (GLTFLoader + AnimationMixer), independently of
// shoal, and prints every joint's world position at the given times as JSON:
//   {"times": [t, ...], "joints": [{"node": "fish_3_spine_1", "pos": [[x, y, z], ...]}, ...]}
// one position per time. Joints are the bones of every skinned mesh (what skinning uses).
// Usage: node tools/threejs-joints.mjs FILE.glb|FILE.gltf T...
// Exits 1 if the file cannot be loaded or has no animation, 2 on bad usage.
import fs from "node:fs";
import path from "node:path";
import * as THREE from "three";
import { GLTFLoader } from "three/examples/jsm/loaders/GLTFLoader.js";

const [file, ...timeArgs] = process.argv.slice(2);
const times = timeArgs.map(Number);
if (!file || times.length === 0 || times.some((t) => !Number.isFinite(t))) {
  console.error("usage: node tools/threejs-joints.mjs FILE.glb|FILE.gltf T...");
  process.exit(2);
}

/**
 * `file` as GLB bytes: a .glb as it is; a .gltf with its one external buffer packed in (three.js
 * fetches external buffers through browser APIs node lacks).
 */
function glbBytes(file) {
  const bytes = fs.readFileSync(file);
  if (!file.endsWith(".gltf")) return bytes;
  const json = JSON.parse(bytes.toString("utf8"));
  if ((json.buffers ?? []).length !== 1 || !json.buffers[0].uri) {
    throw new Error("a .gltf with exactly one external buffer is expected");
  }
  const bin = fs.readFileSync(path.resolve(path.dirname(file), decodeURIComponent(json.buffers[0].uri)));
  delete json.buffers[0].uri;
  const pad = (b, fill) => Buffer.concat([b, Buffer.alloc((4 - (b.length % 4)) % 4, fill)]);
  const text = pad(Buffer.from(JSON.stringify(json)), 0x20);
  const data = pad(bin, 0);
  const header = Buffer.alloc(12);
  header.write("glTF", 0);
  header.writeUInt32LE(2, 4);
  header.writeUInt32LE(12 + 8 + text.length + 8 + data.length, 8);
  const chunk = (len, type) => {
    const c = Buffer.alloc(8);
    c.writeUInt32LE(len, 0);
    c.write(type, 4);
    return c;
  };
  return Buffer.concat([header, chunk(text.length, "JSON"), text, chunk(data.length, "BIN\0"), data]);
}

/** Loads `file` with GLTFLoader. */
export async function load(file) {
  const bytes = glbBytes(file);
  const data = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
  const loader = new GLTFLoader();
  return new Promise((resolve, reject) => loader.parse(data, "", resolve, reject));
}

let gltf;
try {
  gltf = await load(file);
} catch (err) {
  console.error(`${file}: three.js could not load it: ${err.message ?? err}`);
  process.exit(1);
}
if (gltf.animations.length === 0) {
  console.error(`${file}: no animation`);
  process.exit(1);
}
const mixer = new THREE.AnimationMixer(gltf.scene);
for (const clip of gltf.animations) {
  const action = mixer.clipAction(clip);
  action.setLoop(THREE.LoopOnce, 1);
  action.clampWhenFinished = true;
  action.play();
}
const bones = new Map();
gltf.scene.traverse((o) => {
  if (o.isSkinnedMesh) for (const b of o.skeleton.bones) bones.set(b.name, b);
});
const joints = [...bones.keys()].sort().map((node) => ({ node, pos: [] }));
const v = new THREE.Vector3();
for (const t of times) {
  mixer.setTime(t);
  gltf.scene.updateMatrixWorld(true);
  for (const j of joints) {
    bones.get(j.node).getWorldPosition(v);
    j.pos.push([v.x, v.y, v.z]);
  }
}
process.stdout.write(JSON.stringify({ times, joints }));

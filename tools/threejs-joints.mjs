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

/** Loads `file` with GLTFLoader, resolving a .gltf's external buffers from disk. */
export async function load(file) {
  const bytes = fs.readFileSync(file);
  let data = bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength);
  const manager = new THREE.LoadingManager();
  // A .gltf names its .bin by URI: hand three.js the file's bytes as a data URI.
  manager.setURLModifier((url) => {
    if (url.startsWith("data:")) return url;
    const full = path.resolve(path.dirname(file), decodeURIComponent(url));
    const b64 = fs.readFileSync(full).toString("base64");
    return `data:application/octet-stream;base64,${b64}`;
  });
  const loader = new GLTFLoader(manager);
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

// Draws an exported school (`shoal export`) at a time as three.js poses it, outside shoal: the
// file is loaded by three.js's GLTFLoader, posed by its AnimationMixer, and every vertex skinned
// by three.js (SkinnedMesh.applyBoneTransform, its CPU skinning). There is no WebGL under node,
// so the triangles are then filled by the small z-buffer rasterizer below (Lambert shading of
// the vertex colours) and written as a PNG.
// Usage: node tools/render-export.mjs FILE.glb T OUT.png [WIDTH HEIGHT]
import fs from "node:fs";
import zlib from "node:zlib";
import * as THREE from "three";
import { GLTFLoader } from "three/examples/jsm/loaders/GLTFLoader.js";

const [file, tArg, out, wArg, hArg] = process.argv.slice(2);
const t = Number(tArg);
const W = Number(wArg ?? 960);
const H = Number(hArg ?? 540);
if (!file || !out || !Number.isFinite(t)) {
  console.error("usage: node tools/render-export.mjs FILE.glb T OUT.png [WIDTH HEIGHT]");
  process.exit(2);
}

const bytes = fs.readFileSync(file);
const gltf = await new Promise((resolve, reject) =>
  new GLTFLoader().parse(
    bytes.buffer.slice(bytes.byteOffset, bytes.byteOffset + bytes.byteLength),
    "",
    resolve,
    reject,
  ),
);
const mixer = new THREE.AnimationMixer(gltf.scene);
for (const clip of gltf.animations) {
  const a = mixer.clipAction(clip);
  a.setLoop(THREE.LoopOnce, 1);
  a.clampWhenFinished = true;
  a.play();
}
mixer.setTime(t);
gltf.scene.updateMatrixWorld(true);

// Every triangle in world space, with a colour per vertex.
const tris = [];
const v = new THREE.Vector3();
gltf.scene.traverse((o) => {
  if (!o.isMesh || o.geometry.index === null) return;
  const g = o.geometry;
  const pos = g.attributes.position;
  const col = g.attributes.color;
  const base = o.material.color ?? new THREE.Color(1, 1, 1);
  if (o.isSkinnedMesh) o.skeleton.update();
  const world = new Float32Array(pos.count * 3);
  for (let i = 0; i < pos.count; i++) {
    v.fromBufferAttribute(pos, i);
    if (o.isSkinnedMesh) o.applyBoneTransform(i, v);
    v.applyMatrix4(o.matrixWorld);
    world.set([v.x, v.y, v.z], i * 3);
  }
  const idx = g.index.array;
  for (let k = 0; k < idx.length; k += 3) {
    const ids = [idx[k], idx[k + 1], idx[k + 2]];
    const rgb = [0, 0, 0];
    for (const i of ids) {
      rgb[0] += (col ? col.getX(i) : 1) * base.r / 3;
      rgb[1] += (col ? col.getY(i) : 1) * base.g / 3;
      rgb[2] += (col ? col.getZ(i) : 1) * base.b / 3;
    }
    tris.push({ p: ids.map((i) => [world[i * 3], world[i * 3 + 1], world[i * 3 + 2]]), rgb });
  }
});

// A camera looking at the school from the front, slightly above, framing every fish vertex.
const box = new THREE.Box3();
gltf.scene.traverse((o) => {
  if (o.isBone) box.expandByPoint(o.getWorldPosition(new THREE.Vector3()));
});
const centre = box.getCenter(new THREE.Vector3());
const radius = box.getSize(new THREE.Vector3()).length() / 2;
const camera = new THREE.PerspectiveCamera(40, W / H, 1, 1e5);
camera.position.copy(centre).add(new THREE.Vector3(0.35, 0.45, 1).normalize().multiplyScalar(radius * 1.5));
camera.lookAt(centre);
camera.updateMatrixWorld(true);
const light = new THREE.Vector3(0.3, 1, 0.5).normalize();

const rgb = new Uint8Array(W * H * 3);
for (let y = 0; y < H; y++) {
  const s = y / H;
  for (let x = 0; x < W; x++) {
    rgb.set([18 + 20 * s, 52 + 40 * s, 84 + 30 * s].map(Math.round), (y * W + x) * 3);
  }
}
const depth = new Float32Array(W * H).fill(Infinity);
const a = new THREE.Vector3();
const b = new THREE.Vector3();
const n = new THREE.Vector3();
const toSrgb = (c) => Math.round(255 * Math.pow(Math.min(1, Math.max(0, c)), 1 / 2.2));
for (const tri of tris) {
  a.fromArray(tri.p[1]).sub(v.fromArray(tri.p[0]));
  b.fromArray(tri.p[2]).sub(v.fromArray(tri.p[0]));
  n.crossVectors(a, b).normalize();
  const shade = 0.25 + 0.75 * Math.abs(n.dot(light));
  const colour = tri.rgb.map((c) => toSrgb(c * shade));
  const s = tri.p.map((p) => {
    const q = new THREE.Vector3(...p).project(camera);
    return [(q.x * 0.5 + 0.5) * W, (0.5 - q.y * 0.5) * H, q.z];
  });
  if (s.some((q) => q[2] < -1 || q[2] > 1)) continue;
  const [x0, y0, x1, y1] = [
    Math.max(0, Math.floor(Math.min(s[0][0], s[1][0], s[2][0]))),
    Math.max(0, Math.floor(Math.min(s[0][1], s[1][1], s[2][1]))),
    Math.min(W - 1, Math.ceil(Math.max(s[0][0], s[1][0], s[2][0]))),
    Math.min(H - 1, Math.ceil(Math.max(s[0][1], s[1][1], s[2][1]))),
  ];
  const area = (s[1][0] - s[0][0]) * (s[2][1] - s[0][1]) - (s[2][0] - s[0][0]) * (s[1][1] - s[0][1]);
  if (Math.abs(area) < 1e-9) continue;
  for (let y = y0; y <= y1; y++) {
    for (let x = x0; x <= x1; x++) {
      const px = x + 0.5;
      const py = y + 0.5;
      const w0 = ((s[1][0] - px) * (s[2][1] - py) - (s[2][0] - px) * (s[1][1] - py)) / area;
      const w1 = ((s[2][0] - px) * (s[0][1] - py) - (s[0][0] - px) * (s[2][1] - py)) / area;
      const w2 = 1 - w0 - w1;
      if (w0 < 0 || w1 < 0 || w2 < 0) continue;
      const z = w0 * s[0][2] + w1 * s[1][2] + w2 * s[2][2];
      const at = y * W + x;
      if (z >= depth[at]) continue;
      depth[at] = z;
      rgb.set(colour, at * 3);
    }
  }
}

// PNG: 8-bit RGB, one zlib stream of filter-0 rows.
const crcTable = Array.from({ length: 256 }, (_, k) => {
  let c = k;
  for (let i = 0; i < 8; i++) c = c & 1 ? 0xedb88320 ^ (c >>> 1) : c >>> 1;
  return c >>> 0;
});
const crc32 = (buf) => {
  let c = 0xffffffff;
  for (const x of buf) c = crcTable[(c ^ x) & 0xff] ^ (c >>> 8);
  return (c ^ 0xffffffff) >>> 0;
};
const chunk = (type, data) => {
  const len = Buffer.alloc(4);
  len.writeUInt32BE(data.length);
  const td = Buffer.concat([Buffer.from(type), data]);
  const crc = Buffer.alloc(4);
  crc.writeUInt32BE(crc32(td));
  return Buffer.concat([len, td, crc]);
};
const ihdr = Buffer.alloc(13);
ihdr.writeUInt32BE(W, 0);
ihdr.writeUInt32BE(H, 4);
ihdr.set([8, 2, 0, 0, 0], 8);
const raw = Buffer.alloc(H * (W * 3 + 1));
for (let y = 0; y < H; y++) raw.set(rgb.subarray(y * W * 3, (y + 1) * W * 3), y * (W * 3 + 1) + 1);
fs.writeFileSync(
  out,
  Buffer.concat([
    Buffer.from([0x89, 0x50, 0x4e, 0x47, 0x0d, 0x0a, 0x1a, 0x0a]),
    chunk("IHDR", ihdr),
    chunk("IDAT", zlib.deflateSync(raw)),
    chunk("IEND", Buffer.alloc(0)),
  ]),
);
console.log(`${out}: ${tris.length} triangles at ${t} s, ${W}×${H}`);

// cull.wgsl — culling and level of detail on the GPU (crates/render/src/renderer/cull_pass.rs):
// the arithmetic of crates/render/src/lod.rs (Frustum::intersects, MeshBounds::world_sphere,
// ShadowProjection::project, LodSelector::select) per fish and prop, so the CPU records the same
// draws whatever the fish count. Three entry points, dispatched in order after the pose pass:
//   cs_count   (one invocation per record): its fish and shadow bucket (one per mesh and level,
//              then two per mesh: near and outline shadows) and its slot in each, by atomicAdd;
//              the frame's fish counts.
//   cs_offsets (one invocation): each bucket's first instance (a prefix sum), written where the
//              draws read it (the draw-base uniform, one entry per bucket at `base_stride`), and
//              each draw's indirect arguments (its part's index range, its bucket's count).
//   cs_scatter (one invocation per record): its instance into each of its buckets.
// Indirect draws start at instance 0 (first_instance needs INDIRECT_FIRST_INSTANCE): the
// vertex shader adds its draw's base (fish.wgsl, group 2).
//
// Bindings (group 0):
//   @binding(0) records: array<Record> (storage, read) — fish, then props
//   @binding(1) tables: array<vec4<u32>> (storage, read) — 4 per mesh (MeshInfo), then 1 per
//               draw at params.counts.w: (bucket, first index, index count, 0)
//   @binding(2) params: CullParams (uniform)
//   @binding(3) palette: array<mat4x4<f32>> (storage, read) — a record's entry 0 is its joint 0
//   @binding(4) state: array<atomic<u32>> (storage, read_write) — STATS counters, then one
//               count per bucket, one first instance per bucket, 4 per record (its buckets and
//               slots); cleared to 0 before cs_count
//   @binding(5) instances: array<Instance> (storage, read_write) — the draws' instances
//   @binding(6) draw_bases: array<u32> (storage, read_write) — the draw-base uniform
//   @binding(7) args: array<u32> (storage, read_write) — 5 per draw (draw_indexed_indirect)
// Standalone: nothing is prepended or appended.

struct Record {
    palette_offset: u32,
    flags: u32,
    mesh: u32,
    // 1 for a fish, 0 for a prop (props are drawn but not counted as fish).
    is_fish: u32,
    tint: vec4<f32>,
};

// InstanceRaw in crates/render/src/renderer/mod.rs, as fish.wgsl reads it.
struct Instance {
    palette_offset: u32,
    flags: u32,
    _pad0: u32,
    _pad1: u32,
    tint: vec4<f32>,
};

struct CullParams {
    // The view's six planes (n, d), n pointing inside (Frustum in lod.rs).
    planes: array<vec4<f32>, 6>,
    // xyz: eye; w: pixels per length unit at unit distance.
    eye_ppu: vec4<f32>,
    // x: tolerance, pixels; y: shadow plane height; zw: shadow shift per unit of height (x, z).
    lod_shadow: vec4<f32>,
    // x: the shadow projection's stretch; y: 1 when shadows are drawn; z: BEND_MARGIN;
    // w: NEAR_SHADOW_LOD.
    shadow: vec4<f32>,
    // x: records; y: buckets; z: draws; w: where the draws start in `tables`.
    counts: vec4<u32>,
    // x: u32s between two buckets' entries in `draw_bases`.
    base_stride: vec4<u32>,
};

@group(0) @binding(0) var<storage, read> records: array<Record>;
@group(0) @binding(1) var<storage, read> tables: array<vec4<u32>>;
@group(0) @binding(2) var<uniform> params: CullParams;
@group(0) @binding(3) var<storage, read> palette: array<mat4x4<f32>>;
@group(0) @binding(4) var<storage, read_write> state: array<atomic<u32>>;
@group(0) @binding(5) var<storage, read_write> instances: array<Instance>;
@group(0) @binding(6) var<storage, read_write> draw_bases: array<u32>;
@group(0) @binding(7) var<storage, read_write> args: array<u32>;

// STATS in cull_pass.rs: fish drawn, culled, shadows, outline shadows, fish per level (5).
const STATS: u32 = 16u;
const DRAWN: u32 = 0u;
const CULLED_FISH: u32 = 1u;
const SHADOWS: u32 = 2u;
const OUTLINE: u32 = 3u;
const PER_LOD: u32 = 4u;
const MAX_LODS: u32 = 5u;
const NONE: u32 = 0xffffffffu;

fn first_instance_at(bucket: u32) -> u32 {
    return STATS + params.counts.y + bucket;
}

fn assignment_at(i: u32) -> u32 {
    return STATS + 2u * params.counts.y + 4u * i;
}

// Wholly outside one plane (a NaN compares false: never hidden).
fn outside(c: vec3<f32>, radius: f32) -> bool {
    for (var k = 0u; k < 6u; k = k + 1u) {
        if (dot(params.planes[k], vec4<f32>(c, 1.0)) < -radius) {
            return true;
        }
    }
    return false;
}

@compute @workgroup_size(64)
fn cs_count(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= params.counts.x) {
        return;
    }
    let r = records[i];
    // MeshInfo: bounds (centre, radius), then (first bucket, levels, first shadow bucket, 0),
    // then the levels' errors (two vec4s), all as bits.
    let bounds = bitcast<vec4<f32>>(tables[4u * r.mesh]);
    let info = tables[4u * r.mesh + 1u];
    let errors0 = bitcast<vec4<f32>>(tables[4u * r.mesh + 2u]);
    let errors1 = bitcast<vec4<f32>>(tables[4u * r.mesh + 3u]);
    let j = palette[r.palette_offset];
    let scale = sqrt(max(max(dot(j[0].xyz, j[0].xyz), dot(j[1].xyz, j[1].xyz)), dot(j[2].xyz, j[2].xyz)));
    let center = (j * vec4<f32>(bounds.xyz, 1.0)).xyz;
    let radius = bounds.w * scale * params.shadow.z;
    let in_view = !outside(center, radius);
    var shadow_in_view = false;
    if (params.shadow.y > 0.0) {
        let floor_y = params.lod_shadow.y;
        let h = max(center.y - floor_y, 0.0);
        let c = vec3<f32>(center.x - params.lod_shadow.z * h, floor_y, center.z - params.lod_shadow.w * h);
        shadow_in_view = !outside(c, radius * params.shadow.x);
    }
    var lod = 0u;
    if (in_view || shadow_in_view) {
        let distance = distance(center, params.eye_ppu.xyz) - radius;
        // `!(distance > 0)` also catches a NaN.
        if (distance > 0.0 && info.y > 1u) {
            let px_per_unit = params.eye_ppu.w * scale / distance;
            for (var k = 0u; k < min(info.y, MAX_LODS); k = k + 1u) {
                var e = errors0[min(k, 3u)];
                if (k >= 4u) {
                    e = errors1[k - 4u];
                }
                if (e * px_per_unit <= params.lod_shadow.x) {
                    lod = k;
                }
            }
        }
    }
    var draw = NONE;
    var draw_slot = 0u;
    var shade = NONE;
    var shade_slot = 0u;
    if (in_view) {
        draw = info.x + lod;
        draw_slot = atomicAdd(&state[STATS + draw], 1u);
        if (r.is_fish != 0u) {
            atomicAdd(&state[DRAWN], 1u);
            atomicAdd(&state[PER_LOD + lod], 1u);
        }
    } else if (r.is_fish != 0u) {
        atomicAdd(&state[CULLED_FISH], 1u);
    }
    if (shadow_in_view) {
        let far = lod > u32(params.shadow.w);
        shade = info.z + select(0u, 1u, far);
        shade_slot = atomicAdd(&state[STATS + shade], 1u);
        if (r.is_fish != 0u) {
            atomicAdd(&state[SHADOWS], 1u);
            if (far) {
                atomicAdd(&state[OUTLINE], 1u);
            }
        }
    }
    let at = assignment_at(i);
    atomicStore(&state[at], draw);
    atomicStore(&state[at + 1u], draw_slot);
    atomicStore(&state[at + 2u], shade);
    atomicStore(&state[at + 3u], shade_slot);
}

@compute @workgroup_size(1)
fn cs_offsets() {
    var start = 0u;
    for (var b = 0u; b < params.counts.y; b = b + 1u) {
        atomicStore(&state[first_instance_at(b)], start);
        draw_bases[b * params.base_stride.x] = start;
        start = start + atomicLoad(&state[STATS + b]);
    }
    for (var d = 0u; d < params.counts.z; d = d + 1u) {
        let t = tables[params.counts.w + d];
        args[5u * d] = t.z;
        args[5u * d + 1u] = atomicLoad(&state[STATS + t.x]);
        args[5u * d + 2u] = t.y;
        args[5u * d + 3u] = 0u;
        args[5u * d + 4u] = 0u;
    }
}

@compute @workgroup_size(64)
fn cs_scatter(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= params.counts.x) {
        return;
    }
    let r = records[i];
    let inst = Instance(r.palette_offset, r.flags, 0u, 0u, r.tint);
    let at = assignment_at(i);
    for (var k = 0u; k < 2u; k = k + 1u) {
        let bucket = atomicLoad(&state[at + 2u * k]);
        if (bucket != NONE) {
            let slot = atomicLoad(&state[at + 2u * k + 1u]);
            instances[atomicLoad(&state[first_instance_at(bucket)]) + slot] = inst;
        }
    }
}

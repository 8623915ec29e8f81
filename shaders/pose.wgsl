// pose.wgsl — the pose stage on the GPU (src/world/pose/gpu.rs): one invocation per fish runs
// its species' program — the model steps, then the palette slots — from the fish's root and
// yaws, into the palette buffer the fish draws read, in the layout the CPU stage writes.
//
// Bindings (group 0):
//   @binding(0) fish: array<FishPose> (storage, read) — one record per fish
//   @binding(1) programs: array<Program> (storage, read) — one per species
//   @binding(2) model_steps: array<ModelStep> (storage, read) — every program's, in order
//   @binding(3) slot_steps: array<SlotStep> (storage, read) — every program's, in order
//   @binding(4) params: PoseParams (uniform) — the number of fish
//   @binding(5) palette: array<mat4x4<f32>> (storage, read_write) — the fish's palettes
// Standalone: nothing is prepended or appended.

struct FishPose {
    // xyz: root position; w: heading, radians (counter-clockwise from above, 0 faces +x).
    pos_heading: vec4<f32>,
    pitch: f32,
    program: u32,
    palette_offset: u32,
    _pad: u32,
    // The driven joints' yaws, four to a vector.
    yaw: array<vec4<f32>, 4>,
};

struct Program {
    model_to_body: mat4x4<f32>,
    first_model: u32,
    num_models: u32,
    first_slot: u32,
    num_slots: u32,
};

// model[k] = (parent < 0 ? placement : model[parent]) · (a + cos θ·b + sin θ·c).
struct ModelStep {
    a: mat4x4<f32>,
    b: mat4x4<f32>,
    c: mat4x4<f32>,
    parent: i32,
    // Index into the yaws, or 0xffffffff for a joint that is not driven.
    yaw_slot: u32,
    _pad0: u32,
    _pad1: u32,
};

// A slot: (left < 0 ? placement : model[left]) · rhs when product is 1, else the placement.
struct SlotStep {
    rhs: mat4x4<f32>,
    left: i32,
    product: u32,
    _pad0: u32,
    _pad1: u32,
};

struct PoseParams {
    num_fish: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
};

// GPU_POSE_MAX_MODELS in src/world/pose/gpu.rs: a larger species is posed on the CPU.
const MAX_MODELS: u32 = 32u;
const NOT_DRIVEN: u32 = 0xffffffffu;

@group(0) @binding(0) var<storage, read> fish: array<FishPose>;
@group(0) @binding(1) var<storage, read> programs: array<Program>;
@group(0) @binding(2) var<storage, read> model_steps: array<ModelStep>;
@group(0) @binding(3) var<storage, read> slot_steps: array<SlotStep>;
@group(0) @binding(4) var<uniform> params: PoseParams;
@group(0) @binding(5) var<storage, read_write> palette: array<mat4x4<f32>>;

@compute @workgroup_size(64)
fn cs_pose(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= params.num_fish) {
        return;
    }
    let f = fish[i];
    let p = programs[f.program];
    // Placement: translation to the root, heading about +y, pitch about the body's z, then the
    // rig's model → body transform.
    let ch = cos(f.pos_heading.w);
    let sh = sin(f.pos_heading.w);
    let cp = cos(f.pitch);
    let sp = sin(f.pitch);
    let placement = mat4x4<f32>(
        vec4<f32>(cp * ch, sp, -cp * sh, 0.0),
        vec4<f32>(-sp * ch, cp, sp * sh, 0.0),
        vec4<f32>(sh, 0.0, ch, 0.0),
        vec4<f32>(f.pos_heading.xyz, 1.0),
    ) * p.model_to_body;

    var model: array<mat4x4<f32>, MAX_MODELS>;
    let num_models = min(p.num_models, MAX_MODELS);
    for (var k = 0u; k < num_models; k = k + 1u) {
        let s = model_steps[p.first_model + k];
        var local = s.a;
        if (s.yaw_slot != NOT_DRIVEN) {
            let theta = f.yaw[s.yaw_slot / 4u][s.yaw_slot % 4u];
            local = s.a + s.b * cos(theta) + s.c * sin(theta);
        }
        var parent = placement;
        if (s.parent >= 0) {
            parent = model[u32(s.parent)];
        }
        model[k] = parent * local;
    }
    for (var k = 0u; k < p.num_slots; k = k + 1u) {
        let s = slot_steps[p.first_slot + k];
        var entry = placement;
        if (s.product != 0u) {
            var left = placement;
            if (s.left >= 0) {
                left = model[u32(s.left)];
            }
            entry = left * s.rhs;
        }
        palette[f.palette_offset + k] = entry;
    }
}

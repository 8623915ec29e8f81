// pose.wgsl — the pose stage on the GPU (crates/core/src/world/pose/gpu.rs): one invocation per fish
// samples its body shape from the motion player's terms (crates/core/src/motion/player/shape.rs: the paper's
// equations (3)-(7) at the head and each joints_x sample, cross-faded between two motions),
// turns it into the driven joints' yaws (crates/core/src/motion/body.rs, curve_to_yaw), then runs its
// species' program — the model steps, then the palette slots — into the palette buffer the fish
// draws read, in the layout the CPU stage writes. crates/core/src/skin/pose_program.rs (shape_yaws,
// run_program) is this file's arithmetic on the CPU.
//
// Bindings (group 0):
//   @binding(0) fish: array<FishPose> (storage, read) — one record per fish
//   @binding(1) programs: array<Program> (storage, read) — one per species
//   @binding(2) model_steps: array<ModelStep> (storage, read) — every program's, in order
//   @binding(3) slot_steps: array<SlotStep> (storage, read) — every program's, in order
//   @binding(4) params: PoseParams (uniform) — the number of fish
//   @binding(5) palette: array<mat4x4<f32>> (storage, read_write) — the fish's palettes
//   @binding(6) samples: array<ShapeSample> (storage, read) — every program's, in order
// Standalone: nothing is prepended or appended.

// One motion's turn terms (MotionTerms in crates/core/src/motion/player/shape.rs).
struct MotionShape {
    // 0: no turn term; 1: normal turn, eq. (5); 2: quick or serial turn, eq. (6).
    kind: u32,
    d: f32,
    ip: f32,
    bend: f32,
    omega_t: f32,
    wavelength: f32,
    stroke_end: f32,
    _pad: u32,
};

struct FishPose {
    // xyz: root position; w: heading, radians (counter-clockwise from above, 0 faces +x).
    pos_heading: vec4<f32>,
    pitch: f32,
    program: u32,
    palette_offset: u32,
    _pad: u32,
    // x: the swim wave's phase; y: its speed gain; z: the current motion's blend weight.
    wave: vec4<f32>,
    current: MotionShape,
    previous: MotionShape,
};

struct Program {
    model_to_body: mat4x4<f32>,
    first_model: u32,
    num_models: u32,
    first_slot: u32,
    num_slots: u32,
    first_sample: u32,
    num_samples: u32,
    f: f32,
    _pad: u32,
};

// One midline sample: the wave table's constants, its distance from the snout and the power
// weight of the driven joint there.
struct ShapeSample {
    xp: f32,
    amp: f32,
    swim_sin: f32,
    swim_cos: f32,
    xl: f32,
    power: f32,
    _pad0: f32,
    _pad1: f32,
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

// GPU_POSE_MAX_MODELS in crates/core/src/world/pose/gpu.rs: a larger species is posed on the CPU.
const MAX_MODELS: u32 = 32u;
const NOT_DRIVEN: u32 = 0xffffffffu;
// GPU_POSE_MAX_YAWS and GPU_POSE_MAX_SAMPLES in crates/core/src/skin/pose_program.rs.
const MAX_YAWS: u32 = 16u;
const MAX_SAMPLES: u32 = 18u;
const TAU: f32 = 6.2831853;

@group(0) @binding(0) var<storage, read> fish: array<FishPose>;
@group(0) @binding(1) var<storage, read> programs: array<Program>;
@group(0) @binding(2) var<storage, read> model_steps: array<ModelStep>;
@group(0) @binding(3) var<storage, read> slot_steps: array<SlotStep>;
@group(0) @binding(4) var<uniform> params: PoseParams;
@group(0) @binding(5) var<storage, read_write> palette: array<mat4x4<f32>>;
@group(0) @binding(6) var<storage, read> samples: array<ShapeSample>;

// Whether x is finite, from its bits (the compiler may assume no NaNs in float compares).
fn finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

// The paper's F (positive to the fish's right) of motion m at sample s, travelling being the
// sample's sin(2*pi*x'/lambda - phase): shape() in crates/core/src/motion/player/shape.rs.
fn motion_shape(m: MotionShape, f: f32, gain: f32, s: ShapeSample, travelling: f32) -> f32 {
    let swim = s.amp * gain * travelling;
    if (m.kind == 0u || m.ip == 0.0 || s.xp <= 0.0) {
        return swim;
    }
    var t = 0.0;
    if (m.kind == 1u) {
        t = s.amp * (travelling + m.d) * f;
    } else {
        let theta = m.omega_t - TAU * s.xp / m.wavelength;
        if (theta >= 0.0 && theta <= m.stroke_end) {
            t = s.amp * m.bend * f * m.d * abs(sin(theta));
        }
    }
    return swim * (1.0 - m.ip) + t * m.ip;
}

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

    // The body's shape at each sample, and from it the driven joints' yaws: segment k runs
    // from sample k to k + 1 at angle theta_k; yaw k = power * (theta_{k+1} - theta_k).
    var yaw: array<f32, MAX_YAWS>;
    for (var k = 0u; k < MAX_YAWS; k = k + 1u) {
        yaw[k] = 0.0;
    }
    let sin_phi = sin(f.wave.x);
    let cos_phi = cos(f.wave.x);
    let num_samples = min(p.num_samples, MAX_SAMPLES);
    var prev_lat = 0.0;
    var prev_xl = 0.0;
    var prev_theta = 0.0;
    var prev_power = 0.0;
    for (var i = 0u; i < num_samples; i = i + 1u) {
        let s = samples[p.first_sample + i];
        let travelling = s.swim_sin * cos_phi - s.swim_cos * sin_phi;
        var shape = motion_shape(f.current, p.f, f.wave.y, s, travelling);
        if (f.wave.z < 1.0) {
            shape = shape * f.wave.z
                + motion_shape(f.previous, p.f, f.wave.y, s, travelling) * (1.0 - f.wave.z);
        }
        var lat = -shape;
        if (!finite(lat)) {
            lat = 0.0;
        }
        if (i > 0u) {
            let theta = atan2(lat - prev_lat, s.xl - prev_xl);
            if (i >= 2u) {
                let y = prev_power * (theta - prev_theta);
                if (finite(y)) {
                    yaw[i - 2u] = y;
                }
            }
            prev_theta = theta;
        }
        prev_lat = lat;
        prev_xl = s.xl;
        prev_power = s.power;
    }

    var model: array<mat4x4<f32>, MAX_MODELS>;
    let num_models = min(p.num_models, MAX_MODELS);
    for (var k = 0u; k < num_models; k = k + 1u) {
        let s = model_steps[p.first_model + k];
        var local = s.a;
        if (s.yaw_slot != NOT_DRIVEN) {
            let theta = yaw[min(s.yaw_slot, MAX_YAWS - 1u)];
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

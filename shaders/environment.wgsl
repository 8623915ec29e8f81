// environment.wgsl — the water background (full-screen triangle) and the sand floor.
//
// Bindings (group 0):
//   @binding(0) globals: Globals (uniform, from common.wgsl)
// Vertex buffers: none (both passes generate their vertices from vertex_index).
// Prepended: common.wgsl.

struct BackgroundOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) ndc: vec2<f32>,
};

@vertex
fn vs_background(@builtin(vertex_index) index: u32) -> BackgroundOut {
    let uv = vec2<f32>(f32((index << 1u) & 2u), f32(index & 2u));
    let ndc = uv * 2.0 - 1.0;
    var out: BackgroundOut;
    out.clip = vec4<f32>(ndc, 1.0, 1.0);
    out.ndc = ndc;
    return out;
}

@fragment
fn fs_background(in: BackgroundOut) -> @location(0) vec4<f32> {
    let far = globals.inv_view_proj * vec4<f32>(in.ndc, 1.0, 1.0);
    let near = globals.inv_view_proj * vec4<f32>(in.ndc, 0.0, 1.0);
    let dir = normalize(far.xyz / far.w - near.xyz / near.w);
    var color = water_color(dir);
    // Light shafts: faint bright streaks when looking up towards the surface.
    let t = globals.eye_time.w;
    let shaft = sin(dir.x * 23.0 + t * 0.3) * sin(dir.z * 17.0 - t * 0.2);
    color = color + globals.water_shallow.rgb * max(shaft, 0.0) * 0.12 * clamp(dir.y + 0.2, 0.0, 1.0);
    return vec4<f32>(color, 1.0);
}

struct FloorOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world_pos: vec3<f32>,
};

// Two triangles covering the tank floor, extended by a margin so the sand fades into fog.
@vertex
fn vs_floor(@builtin(vertex_index) index: u32) -> FloorOut {
    var corners = array<vec2<f32>, 6>(
        vec2<f32>(0.0, 0.0), vec2<f32>(1.0, 0.0), vec2<f32>(1.0, 1.0),
        vec2<f32>(0.0, 0.0), vec2<f32>(1.0, 1.0), vec2<f32>(0.0, 1.0),
    );
    let c = corners[index];
    let lo = globals.tank_min_fog.xz;
    let hi = globals.tank_max_caustic.xz;
    let margin = (hi - lo) * 0.5;
    let xz = mix(lo - margin, hi + margin, c);
    let world = vec3<f32>(xz.x, globals.tank_min_fog.y, xz.y);
    var out: FloorOut;
    out.clip = globals.view_proj * vec4<f32>(world, 1.0);
    out.world_pos = world;
    return out;
}

fn hash2(p: vec2<f32>) -> f32 {
    return fract(sin(dot(p, vec2<f32>(127.1, 311.7))) * 43758.5453);
}

fn value_noise(p: vec2<f32>) -> f32 {
    let i = floor(p);
    let f = fract(p);
    let u = f * f * (3.0 - 2.0 * f);
    let a = hash2(i);
    let b = hash2(i + vec2<f32>(1.0, 0.0));
    let c = hash2(i + vec2<f32>(0.0, 1.0));
    let d = hash2(i + vec2<f32>(1.0, 1.0));
    return mix(mix(a, b, u.x), mix(c, d, u.x), u.y);
}

@fragment
fn fs_floor(in: FloorOut) -> @location(0) vec4<f32> {
    let p = in.world_pos.xz;
    // Sand: ripples warped by low-frequency noise, plus fine grain.
    let warp = value_noise(p * 0.02) * 6.0;
    let ripple = sin(p.x * 0.11 + p.y * 0.04 + warp) * 0.5 + 0.5;
    let grain = value_noise(p * 0.9) * 0.5 + value_noise(p * 0.23) * 0.5;
    let sand = vec3<f32>(0.66, 0.5, 0.27) * (0.78 + 0.14 * ripple + 0.16 * grain);
    let lo = globals.tank_min_fog.xz;
    let hi = globals.tank_max_caustic.xz;
    // Outside the tank walls the floor darkens so the tank footprint reads clearly.
    let inside = step(lo.x, p.x) * step(p.x, hi.x) * step(lo.y, p.y) * step(p.y, hi.y);
    let light = max(globals.light_dir.y, 0.0) * 0.85 + 0.2;
    var color = sand * light * mix(0.45, 1.0, inside);
    color = color + vec3<f32>(0.75, 0.8, 0.6) * caustics(in.world_pos) * 0.3 * inside;
    return vec4<f32>(apply_fog(color, in.world_pos), 1.0);
}

// common.wgsl — shared by every scene shader (prepended by the renderer; not a module alone).
//
// Bindings it declares (group 0, shared by all scene pipelines):
//   @group(0) @binding(0) globals: Globals (uniform) — camera, time, tank, fog, light.
//
// Functions: water_color(dir), fog(color, world_pos), caustics(world_pos).

struct Globals {
    view_proj: mat4x4<f32>,
    inv_view_proj: mat4x4<f32>,
    // xyz: camera eye (world); w: scene time in seconds (drives caustics).
    eye_time: vec4<f32>,
    // xyz: tank min corner (floor at y); w: fog density per length unit.
    tank_min_fog: vec4<f32>,
    // xyz: tank max corner (surface at y); w: caustic strength (0 turns them off).
    tank_max_caustic: vec4<f32>,
    // xyz: direction *towards* the sun (normalised); w: unused.
    light_dir: vec4<f32>,
    // rgb: deep water colour (linear); a: unused.
    water_deep: vec4<f32>,
    // rgb: shallow water colour near the surface (linear); a: unused.
    water_shallow: vec4<f32>,
};

@group(0) @binding(0) var<uniform> globals: Globals;

// Water colour seen along a view direction: brighter towards the surface, deep blue below.
fn water_color(dir: vec3<f32>) -> vec3<f32> {
    let up = clamp(dir.y * 0.5 + 0.5, 0.0, 1.0);
    return mix(globals.water_deep.rgb, globals.water_shallow.rgb, pow(up, 1.6));
}

// Colour at `world_pos` after travelling through water to the eye: exponential fog towards the
// water colour along the view ray, plus attenuation with depth below the surface.
fn apply_fog(color: vec3<f32>, world_pos: vec3<f32>) -> vec3<f32> {
    let to_pos = world_pos - globals.eye_time.xyz;
    let dist = length(to_pos);
    let depth = max(globals.tank_max_caustic.y - world_pos.y, 0.0);
    let height = max(globals.tank_max_caustic.y - globals.tank_min_fog.y, 1.0);
    // Deeper surfaces receive less light and look bluer.
    let depth_att = mix(vec3<f32>(1.0), vec3<f32>(0.72, 0.86, 0.95), clamp(depth / height, 0.0, 1.0));
    let lit = color * depth_att;
    let f = 1.0 - exp(-dist * globals.tank_min_fog.w);
    return mix(lit, water_color(to_pos / max(dist, 1e-4)), clamp(f, 0.0, 1.0));
}

// Soft animated caustics projected straight down from the surface: bright thin ridges where two
// warped sine fields cross. Returns an additive light factor in [0, ~1].
fn caustics(world_pos: vec3<f32>) -> f32 {
    let t = globals.eye_time.w;
    let p = world_pos.xz * 0.045;
    var acc = 0.0;
    var q = p;
    for (var i = 0; i < 3; i = i + 1) {
        let fi = f32(i);
        q = q + vec2<f32>(sin(q.y * 1.7 + t * (0.6 + 0.2 * fi)), cos(q.x * 1.3 - t * (0.5 + 0.15 * fi))) * 0.55;
        let v = sin(q.x * 2.1 + fi) * sin(q.y * 2.3 - fi * 0.7);
        acc = acc + pow(1.0 - abs(v), 6.0);
    }
    return clamp(acc / 3.0, 0.0, 1.0) * globals.tank_max_caustic.w;
}

// fish.wgsl — GPU-skinned, instanced fish (one draw per species) and their planar shadows.
//
// Bindings (group 0):
//   @binding(0) globals: Globals (uniform, from common.wgsl)
//   @binding(1) palette: array<mat4x4<f32>> (storage, read) — all fish's joint palettes
// Bindings (group 1, one per species: its glTF material, see src/render/material.rs):
//   @binding(0) base_color_tex: texture_2d<f32> — Rgba8UnormSrgb with mips (1×1 white if none)
//   @binding(1) base_color_sampler: sampler — the glTF sampler's wrap and filters
//   @binding(2) material: MaterialParams (uniform) — alpha mode, cutoff, flags, emissive
// Vertex buffers:
//   slot 0 (per vertex, 64 B): position f32x3 @0, normal f32x3 @1, colour f32x4 @2
//                              (base colour factor × COLOR_0, linear), joints u16x4 @3,
//                              weights f32x4 @4
//   slot 1 (per instance, 32 B): palette_offset u32 @5, flags u32 @6 (bit 0: selected),
//                                tint f32x4 @7 (rgb multiplies the material, a unused)
//   slot 2 (per vertex, 8 B): base colour texture coordinates f32x2 @8 (glTF: v down)
// Prepended: common.wgsl. Appended: skinning.wgsl.

@group(0) @binding(1) var<storage, read> palette: array<mat4x4<f32>>;

struct MaterialParams {
    // 0 OPAQUE, 1 MASK (discard below alpha_cutoff), 2 BLEND (drawn blended, second pass).
    alpha_mode: u32,
    alpha_cutoff: f32,
    // bit 0: unlit (KHR_materials_unlit).
    flags: u32,
    _pad: u32,
    // rgb: emissiveFactor (linear), added after lighting; a unused.
    emissive: vec4<f32>,
};

@group(1) @binding(0) var base_color_tex: texture_2d<f32>;
@group(1) @binding(1) var base_color_sampler: sampler;
@group(1) @binding(2) var<uniform> material: MaterialParams;

// The material's base colour at `uv` times the vertex colour; alpha as the mode says.
// Returns alpha < 0 where a MASK material is cut away.
fn base_color(vertex_color: vec4<f32>, uv: vec2<f32>) -> vec4<f32> {
    let c = vertex_color * textureSample(base_color_tex, base_color_sampler, uv);
    if (material.alpha_mode == 1u) {
        return select(vec4<f32>(c.rgb, 1.0), vec4<f32>(c.rgb, -1.0), c.a < material.alpha_cutoff);
    }
    if (material.alpha_mode == 2u) {
        return c;
    }
    return vec4<f32>(c.rgb, 1.0);
}

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) color: vec4<f32>,
    @location(3) joints: vec4<u32>,
    @location(4) weights: vec4<f32>,
    @location(5) palette_offset: u32,
    @location(6) flags: u32,
    @location(7) tint: vec4<f32>,
    @location(8) uv: vec2<f32>,
};

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world_pos: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) color: vec4<f32>,
    @location(3) @interpolate(flat) flags: u32,
    @location(4) uv: vec2<f32>,
};

@vertex
fn vs_main(in: VertexIn) -> VertexOut {
    let m = skin_matrix(in.palette_offset, in.joints, in.weights);
    let world = m * vec4<f32>(in.position, 1.0);
    let n = (m * vec4<f32>(in.normal, 0.0)).xyz;
    var out: VertexOut;
    out.clip = globals.view_proj * world;
    out.world_pos = world.xyz;
    out.normal = n;
    out.color = vec4<f32>(in.color.rgb * in.tint.rgb, in.color.a);
    out.flags = in.flags;
    out.uv = in.uv;
    return out;
}

@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    let base = base_color(in.color, in.uv);
    if (base.a < 0.0) {
        discard;
    }
    var n = normalize(in.normal);
    // Fins are single sheets: light their back faces with the flipped normal.
    if (!front_facing) {
        n = -n;
    }
    let l = globals.light_dir.xyz;
    let v = normalize(globals.eye_time.xyz - in.world_pos);
    // Wrapped diffuse keeps the shadow side readable underwater.
    let diffuse = clamp((dot(n, l) + 0.35) / 1.35, 0.0, 1.0);
    let h = normalize(l + v);
    let spec = pow(max(dot(n, h), 0.0), 40.0) * 0.35;
    // Ambient: sky-ish from above, darker from the floor.
    let ambient = mix(globals.water_deep.rgb * 0.9, globals.water_shallow.rgb * 0.8, n.y * 0.5 + 0.5);
    let caustic = caustics(in.world_pos) * max(n.y, 0.0) * 0.6;
    let sun = vec3<f32>(1.0, 0.96, 0.88);
    var color = base.rgb * (ambient * 0.45 + sun * (diffuse * 1.05 + caustic)) + vec3<f32>(spec);
    if ((material.flags & 1u) != 0u) {
        color = base.rgb;
    }
    color = color + material.emissive.rgb;
    // A faint rim light separates fish from the water.
    let rim = pow(1.0 - max(dot(n, v), 0.0), 3.0);
    color = color + globals.water_shallow.rgb * rim * 0.25;
    if ((in.flags & 1u) != 0u) {
        color = color + vec3<f32>(1.0, 0.8, 0.2) * (0.25 + rim * 1.2);
    }
    if (material.alpha_mode == 2u) {
        return vec4<f32>(apply_fog(color, in.world_pos), base.a);
    }
    return vec4<f32>(apply_fog(color, in.world_pos), 1.0);
}

// Planar shadows: the same skinned fish squashed onto the sand along the light direction, drawn
// with a multiplicative blend (the sand is darkened, never replaced). Fainter the higher the
// fish swims, so the shadow also reads as a depth cue.
struct ShadowOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) shade: f32,
    @location(1) color: vec4<f32>,
    @location(2) uv: vec2<f32>,
};

@vertex
fn vs_shadow(in: VertexIn) -> ShadowOut {
    let m = skin_matrix(in.palette_offset, in.joints, in.weights);
    let world = (m * vec4<f32>(in.position, 1.0)).xyz;
    let floor_y = globals.tank_min_fog.y + 0.3;
    let l = globals.light_dir.xyz;
    let height = max(world.y - floor_y, 0.0);
    let on_floor = world - l * (height / max(l.y, 0.2));
    var out: ShadowOut;
    out.clip = globals.view_proj * vec4<f32>(on_floor.x, floor_y, on_floor.z, 1.0);
    let tank_h = max(globals.tank_max_caustic.y - globals.tank_min_fog.y, 1.0);
    out.shade = mix(0.55, 0.9, clamp(height / tank_h, 0.0, 1.0));
    out.color = in.color;
    out.uv = in.uv;
    return out;
}

@fragment
fn fs_shadow(in: ShadowOut) -> @location(0) vec4<f32> {
    // Cut-away (MASK) parts cast no shadow; blended parts a fainter one.
    let a = base_color(in.color, in.uv).a;
    if (a <= 0.0) {
        discard;
    }
    return vec4<f32>(vec3<f32>(mix(1.0, in.shade, a)), 1.0);
}

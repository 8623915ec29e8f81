// fish.wgsl — GPU-skinned, instanced fish (one draw per species, material and level of detail)
// and their planar shadows.
//
// Bindings (group 0):
//   @binding(0) globals: Globals (uniform, from common.wgsl)
//   @binding(1) palette: array<mat4x4<f32>> (storage, read) — all fish's joint palettes
// Bindings (group 1, one per material of a species: its glTF material, see
// crates/render/src/material.rs); every texture has a 1×1 stand-in that leaves the factors as they are:
//   @binding(0) base_color_tex: texture_2d<f32> — Rgba8UnormSrgb with mips (white if none)
//   @binding(1) base_color_sampler: sampler — the glTF sampler's wrap and filters
//   @binding(2) material: MaterialParams (uniform) — alpha mode, cutoff, flags, factors
//   @binding(3, 4) normal_tex, normal_sampler — tangent-space normals, Rgba8Unorm
//   @binding(5, 6) mr_tex, mr_sampler — roughness in G, metallic in B, Rgba8Unorm
//   @binding(7, 8) occlusion_tex, occlusion_sampler — occlusion in R, Rgba8Unorm
//   @binding(9, 10) emissive_tex, emissive_sampler — Rgba8UnormSrgb
// Vertex buffers:
//   slot 0 (per vertex, 64 B): position f32x3 @0, normal f32x3 @1, colour f32x4 @2
//                              (base colour factor × COLOR_0, linear), joints u16x4 @3,
//                              weights f32x4 @4
//   slot 1: none (the instances are read from group 2, below)
//   slot 2 (per vertex, 24 B): texture coordinates f32x2 @8 (glTF: v down), tangent f32x4 @9
//                              (xyz, w = bitangent sign; zero when the mesh has none)
// Bindings (group 2, the draws' instances; see crates/render/src/renderer/cull_pass.rs):
//   @binding(0) instances: array<Instance> (storage, read) — every draw's, grouped by draw
//   @binding(1) draw: DrawBase (uniform, dynamic offset per draw) — the draw's first instance
//   A draw's instance k is instances[draw.first + k]: the draws start at instance 0, so the
//   same holds for indirect draws written by the culling pass (cull.wgsl) without
//   INDIRECT_FIRST_INSTANCE.
// Prepended: common.wgsl. Appended: skinning.wgsl.

@group(0) @binding(1) var<storage, read> palette: array<mat4x4<f32>>;

struct Instance {
    palette_offset: u32,
    // bit 0: selected.
    flags: u32,
    _pad0: u32,
    _pad1: u32,
    // rgb multiplies the material; a unused.
    tint: vec4<f32>,
};

struct DrawBase {
    first: u32,
    _pad0: u32,
    _pad1: u32,
    _pad2: u32,
};

@group(2) @binding(0) var<storage, read> instances: array<Instance>;
@group(2) @binding(1) var<uniform> draw: DrawBase;

struct MaterialParams {
    // 0 OPAQUE, 1 MASK (discard below alpha_cutoff), 2 BLEND (drawn blended, second pass).
    alpha_mode: u32,
    alpha_cutoff: f32,
    // bit 0: unlit (KHR_materials_unlit); bits 1–4: the material has a normal map (and the mesh
    // tangents), a metallic-roughness, an occlusion, an emissive texture.
    flags: u32,
    // normalTexture.scale.
    normal_scale: f32,
    // rgb: emissiveFactor (linear), times the emissive texture, added after lighting; a unused.
    emissive: vec4<f32>,
    // metallicFactor, roughnessFactor (times the texture's B and G), occlusionTexture.strength.
    metallic: f32,
    roughness: f32,
    occlusion_strength: f32,
    _pad: f32,
};

@group(1) @binding(0) var base_color_tex: texture_2d<f32>;
@group(1) @binding(1) var base_color_sampler: sampler;
@group(1) @binding(2) var<uniform> material: MaterialParams;
@group(1) @binding(3) var normal_tex: texture_2d<f32>;
@group(1) @binding(4) var normal_sampler: sampler;
@group(1) @binding(5) var mr_tex: texture_2d<f32>;
@group(1) @binding(6) var mr_sampler: sampler;
@group(1) @binding(7) var occlusion_tex: texture_2d<f32>;
@group(1) @binding(8) var occlusion_sampler: sampler;
@group(1) @binding(9) var emissive_tex: texture_2d<f32>;
@group(1) @binding(10) var emissive_sampler: sampler;

const PI: f32 = 3.14159265;

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

// The shading normal: the interpolated normal, bent by the normal map where the material has
// one and the mesh a tangent (glTF: n = normalize(T·x + B·y + N·z), B = (N × T)·w, x and y
// times the normal scale). `mapped` is the normal map's texel, sampled by the caller.
fn shading_normal(normal: vec3<f32>, tangent: vec4<f32>, mapped: vec4<f32>) -> vec3<f32> {
    let n = normalize(normal);
    let t_raw = tangent.xyz - n * dot(n, tangent.xyz);
    if ((material.flags & 2u) == 0u || dot(t_raw, t_raw) < 1e-12) {
        return n;
    }
    let t = normalize(t_raw);
    let b = cross(n, t) * select(1.0, -1.0, tangent.w < 0.0);
    let m = mapped.xyz * 2.0 - vec3<f32>(1.0);
    let local = vec3<f32>(m.xy * material.normal_scale, m.z);
    let bent = t * local.x + b * local.y + n * local.z;
    return select(n, normalize(bent), dot(bent, bent) > 1e-12);
}

struct VertexIn {
    @location(0) position: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) color: vec4<f32>,
    @location(3) joints: vec4<u32>,
    @location(4) weights: vec4<f32>,
    @builtin(instance_index) instance: u32,
    @location(8) uv: vec2<f32>,
    @location(9) tangent: vec4<f32>,
};

struct VertexOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) world_pos: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) color: vec4<f32>,
    @location(3) @interpolate(flat) flags: u32,
    @location(4) uv: vec2<f32>,
    @location(5) tangent: vec4<f32>,
};

@vertex
fn vs_main(in: VertexIn) -> VertexOut {
    let inst = instances[draw.first + in.instance];
    let m = skin_matrix(inst.palette_offset, in.joints, in.weights);
    let world = m * vec4<f32>(in.position, 1.0);
    let n = (m * vec4<f32>(in.normal, 0.0)).xyz;
    var out: VertexOut;
    out.clip = globals.view_proj * world;
    out.world_pos = world.xyz;
    out.normal = n;
    out.color = vec4<f32>(in.color.rgb * inst.tint.rgb, in.color.a);
    out.flags = inst.flags;
    out.uv = in.uv;
    out.tangent = vec4<f32>((m * vec4<f32>(in.tangent.xyz, 0.0)).xyz, in.tangent.w);
    return out;
}

@fragment
fn fs_main(in: VertexOut, @builtin(front_facing) front_facing: bool) -> @location(0) vec4<f32> {
    // Every texture is sampled up front, in uniform control flow (the flags are uniform), and
    // only where the material has it: the stand-ins would give the same values, at the cost of
    // a sample per map on a software rasterizer.
    let base = base_color(in.color, in.uv);
    var mapped = vec4<f32>(0.5, 0.5, 1.0, 1.0);
    if ((material.flags & 2u) != 0u) {
        mapped = textureSample(normal_tex, normal_sampler, in.uv);
    }
    var mr = vec4<f32>(1.0);
    if ((material.flags & 4u) != 0u) {
        mr = textureSample(mr_tex, mr_sampler, in.uv);
    }
    var occlusion = 1.0;
    if ((material.flags & 8u) != 0u) {
        occlusion = textureSample(occlusion_tex, occlusion_sampler, in.uv).r;
    }
    var emissive_texel = vec3<f32>(1.0);
    if ((material.flags & 16u) != 0u) {
        emissive_texel = textureSample(emissive_tex, emissive_sampler, in.uv).rgb;
    }
    if (base.a < 0.0) {
        discard;
    }
    var n = shading_normal(in.normal, in.tangent, mapped);
    // Fins are single sheets: light their back faces with the flipped normal (the whole
    // tangent frame flips, so the normal map's bend does too).
    if (!front_facing) {
        n = -n;
    }
    let l = globals.light_dir.xyz;
    let v = normalize(globals.eye_time.xyz - in.world_pos);
    // glTF metallic-roughness: metallic in B, roughness in G, times the factors.
    let metallic = clamp(material.metallic * mr.b, 0.0, 1.0);
    let roughness = clamp(material.roughness * mr.g, 0.03, 1.0);
    let ao = 1.0 + material.occlusion_strength * (occlusion - 1.0);
    let diffuse_color = base.rgb * (1.0 - metallic);
    let f0 = mix(vec3<f32>(0.04), base.rgb, metallic);
    // Wrapped diffuse keeps the shadow side readable underwater.
    let diffuse = clamp((dot(n, l) + 0.35) / 1.35, 0.0, 1.0);
    // Ambient: sky-ish from above, darker from the floor; occluded by the occlusion map.
    let ambient = mix(globals.water_deep.rgb * 0.9, globals.water_shallow.rgb * 0.8, n.y * 0.5 + 0.5);
    let caustic = caustics(in.world_pos) * max(n.y, 0.0) * 0.6;
    let sun = vec3<f32>(1.0, 0.96, 0.88);
    // The sun's highlight: glTF's specular BRDF (GGX distribution, its height-correlated Smith
    // visibility, Schlick Fresnel) at the sun's strength, which the diffuse term gets as
    // 1.05 · π (a Lambert surface of albedo 1 reflects 1.05 of the sun).
    let h = normalize(l + v);
    let nl = max(dot(n, l), 0.0);
    let nv = max(dot(n, v), 1e-3);
    let nh = max(dot(n, h), 0.0);
    let vh = max(dot(v, h), 0.0);
    let a = roughness * roughness;
    let a2 = a * a;
    let dd = nh * nh * (a2 - 1.0) + 1.0;
    let distribution = a2 / (PI * dd * dd);
    let vis = 0.5 / max(nl * sqrt(nv * nv * (1.0 - a2) + a2) + nv * sqrt(nl * nl * (1.0 - a2) + a2), 1e-5);
    let fresnel = f0 + (vec3<f32>(1.0) - f0) * pow(1.0 - vh, 5.0);
    let specular = fresnel * (distribution * vis * nl * 1.05 * PI);
    // What the surface mirrors: the water along the reflected ray, rougher surfaces less of it
    // at grazing angles (Schlick with roughness), occluded like the ambient light.
    let fe = f0 + (max(vec3<f32>(1.0 - roughness), f0) - f0) * pow(1.0 - nv, 5.0);
    let mirrored = water_color(reflect(-v, n)) * fe * ao;
    var color = diffuse_color * (ambient * 0.45 * ao + sun * (diffuse * 1.05 + caustic))
        + specular * sun + mirrored;
    if ((material.flags & 1u) != 0u) {
        color = base.rgb;
    }
    color = color + material.emissive.rgb * emissive_texel;
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
    let inst = instances[draw.first + in.instance];
    let m = skin_matrix(inst.palette_offset, in.joints, in.weights);
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

// lines.wgsl — coloured line segments: tank edges (depth tested) and debug overlays (drawn on top).
//
// Bindings (group 0):
//   @binding(0) globals: Globals (uniform, from common.wgsl)
// Vertex buffers:
//   slot 0 (per vertex, 28 B): position f32x3 @0 (world), colour f32x4 @1 (linear RGBA)
// Prepended: common.wgsl.

struct LineIn {
    @location(0) position: vec3<f32>,
    @location(1) color: vec4<f32>,
};

struct LineOut {
    @builtin(position) clip: vec4<f32>,
    @location(0) color: vec4<f32>,
    @location(1) world_pos: vec3<f32>,
};

@vertex
fn vs_line(in: LineIn) -> LineOut {
    var out: LineOut;
    out.clip = globals.view_proj * vec4<f32>(in.position, 1.0);
    out.color = in.color;
    out.world_pos = in.position;
    return out;
}

// Tank edges sit in the water, so they fog like everything else.
@fragment
fn fs_line_fogged(in: LineOut) -> @location(0) vec4<f32> {
    return vec4<f32>(apply_fog(in.color.rgb, in.world_pos), in.color.a);
}

// Overlays are diagnostics: drawn unfogged so they stay readable.
@fragment
fn fs_line_overlay(in: LineOut) -> @location(0) vec4<f32> {
    return in.color;
}

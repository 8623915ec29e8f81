// skin_readback.wgsl — runs the renderer's skinning function over a mesh's vertices and writes
// the skinned positions out, so tests can compare GPU skinning with a CPU reference.
//
// Bindings (group 0):
//   @binding(0) vertices: array<u32> (storage, read) — the mesh vertex buffer, 16 words a vertex:
//               position f32×3 [0..3], normal f32×3 [3..6], colour f32×4 [6..10],
//               joints u16×4 packed in two words [10..12], weights f32×4 [12..16]
//   @binding(1) palette: array<mat4x4<f32>> (storage, read)
//   @binding(2) params: ReadbackParams (uniform) — palette offset and vertex count
//   @binding(3) out_positions: array<vec4<f32>> (storage, read_write) — w = 1
// Appended: skinning.wgsl.

struct ReadbackParams {
    palette_offset: u32,
    num_vertices: u32,
    _pad0: u32,
    _pad1: u32,
};

@group(0) @binding(0) var<storage, read> vertices: array<u32>;
@group(0) @binding(1) var<storage, read> palette: array<mat4x4<f32>>;
@group(0) @binding(2) var<uniform> params: ReadbackParams;
@group(0) @binding(3) var<storage, read_write> out_positions: array<vec4<f32>>;

@compute @workgroup_size(64)
fn cs_skin(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.x;
    if (i >= params.num_vertices) {
        return;
    }
    let b = i * 16u;
    let position = vec3<f32>(bitcast<f32>(vertices[b]), bitcast<f32>(vertices[b + 1u]), bitcast<f32>(vertices[b + 2u]));
    let j01 = vertices[b + 10u];
    let j23 = vertices[b + 11u];
    let joints = vec4<u32>(j01 & 0xffffu, j01 >> 16u, j23 & 0xffffu, j23 >> 16u);
    let weights = vec4<f32>(
        bitcast<f32>(vertices[b + 12u]), bitcast<f32>(vertices[b + 13u]),
        bitcast<f32>(vertices[b + 14u]), bitcast<f32>(vertices[b + 15u]));
    let m = skin_matrix(params.palette_offset, joints, weights);
    out_positions[i] = m * vec4<f32>(position, 1.0);
}

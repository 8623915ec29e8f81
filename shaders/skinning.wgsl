// skinning.wgsl — the one linear-blend-skinning function (paper eq. 1), shared by the fish vertex
// shader (fish.wgsl) and the read-back compute shader (skin_readback.wgsl); appended to each.
//
// Bindings it expects the including shader to declare:
//   palette: array<mat4x4<f32>> (storage, read) — every fish's joint palette for the frame,
//            each fish's joints contiguous; palette[i] = world × model × inverse bind matrix.
//
// v' = Σ_n w_n · (M_n · v) = (Σ_n w_n · M_n) · v, so one blended matrix serves position and
// normal alike (normals are renormalised by the caller).

fn skin_matrix(base: u32, joints: vec4<u32>, weights: vec4<f32>) -> mat4x4<f32> {
    return palette[base + joints.x] * weights.x
         + palette[base + joints.y] * weights.y
         + palette[base + joints.z] * weights.z
         + palette[base + joints.w] * weights.w;
}

//! A procedural skinned fish: a test fixture for GPU tests that need a mesh without asset files.
//!
//! Model space: the head (snout tip) is at the origin, the body runs along −x to the tail tip at
//! x = −length, +y is up (the fish faces +x, its left is −z). `num_joints` joints sit evenly on
//! the vertebral column at x_j = −j · length / num_joints; joint 0 is the root at the snout.
//!
//! ```text
//!   snout                                         tail
//!   x=0 ── j0 ── j1 ── j2 ── … ── j(n−1) ──────── x=−length
//! ```
//! A vertex at column position t (in joint spacings from the snout) is weighted between the two
//! joints whose bone middles bracket it, so each bone's middle follows its joint rigidly and the
//! skin blends across joints.

use glam::{Mat4, Quat, Vec3};

use super::MeshUpload;

/// An owned skinned mesh plus its skeleton's bind pose.
#[derive(Debug, Clone, PartialEq)]
pub struct TestFish {
    /// Body length, length units.
    pub length: f32,
    /// Bind-pose positions, model space.
    pub positions: Vec<[f32; 3]>,
    /// Normals, model space.
    pub normals: Vec<[f32; 3]>,
    /// Linear RGBA per vertex.
    pub colors: Vec<[f32; 4]>,
    /// Joint indices per vertex.
    pub joints: Vec<[u16; 4]>,
    /// Weights per vertex (sum 1).
    pub weights: Vec<[f32; 4]>,
    /// Triangle list.
    pub indices: Vec<u32>,
    /// Inverse bind matrix of each joint.
    pub inverse_bind: Vec<Mat4>,
}

impl TestFish {
    /// A laterally compressed, deep-bodied fish (porgy-like) with `num_joints` (≥ 1) joints,
    /// `rings` cross-sections (≥ 3) of `segments` vertices (≥ 3) each, plus caudal and dorsal fins.
    pub fn new(length: f32, num_joints: usize, rings: usize, segments: usize) -> Self {
        let num_joints = num_joints.max(1);
        let rings = rings.max(3);
        let segments = segments.max(3);
        let seg_len = length / num_joints as f32;
        let mut fish = TestFish {
            length,
            positions: Vec::new(),
            normals: Vec::new(),
            colors: Vec::new(),
            joints: Vec::new(),
            weights: Vec::new(),
            indices: Vec::new(),
            inverse_bind: (0..num_joints)
                .map(|j| Mat4::from_translation(Vec3::new(j as f32 * seg_len, 0.0, 0.0)))
                .collect(),
        };
        let body_end = 0.86_f32;
        let profile = |u: f32| {
            let s = (std::f32::consts::PI * (u / 0.92).min(1.0)).sin().max(0.0);
            let head = (u / 0.08).min(1.0).sqrt();
            let h = length * 0.2 * s.powf(0.8) * head + length * 0.012;
            let w = length * 0.07 * s.powf(0.6) * head + length * 0.006;
            (h, w)
        };
        let dark = [0.018, 0.022, 0.028];
        let silver = [0.5, 0.52, 0.56];
        let fin = [0.05, 0.055, 0.065];
        // Body rings; ring 0 collapses to the snout tip.
        for i in 0..rings {
            let u = body_end * i as f32 / (rings - 1) as f32;
            let (h, w) = if i == 0 { (0.0, 0.0) } else { profile(u) };
            for k in 0..segments {
                let theta = std::f32::consts::TAU * k as f32 / segments as f32;
                let (sin, cos) = theta.sin_cos();
                let p = Vec3::new(-u * length, h * cos, w * sin);
                // Dark back, silver flanks and belly, faint vertical bands.
                let top = shoal_core::math::smoothstep_between(-0.2, 0.75, cos);
                let band = 0.9 + 0.1 * (u * 38.0).sin();
                let mut c = lerp3(silver, dark, top);
                c = [c[0] * band, c[1] * band, c[2] * band];
                // Eye: a dark disc high on the head, both sides.
                let eye = Vec3::new(-0.085 * length, 0.055 * length, 0.0);
                if (Vec3::new(p.x, p.y, 0.0) - eye).length() < 0.022 * length {
                    c = [0.005, 0.005, 0.005];
                }
                fish.push_vertex(p, [c[0], c[1], c[2], 1.0], seg_len);
            }
        }
        for i in 0..rings - 1 {
            for k in 0..segments {
                let a = (i * segments + k) as u32;
                let b = (i * segments + (k + 1) % segments) as u32;
                let c = a + segments as u32;
                let d = b + segments as u32;
                fish.push_tri_outward(a, c, b);
                fish.push_tri_outward(b, c, d);
            }
        }
        // Caudal fin: forked, two triangles per lobe, from the peduncle to the tail tip.
        let (ph, _) = profile(body_end);
        let x0 = -body_end * length;
        let x1 = -length;
        let fin_pts = [
            Vec3::new(x0, ph * 0.9, 0.0),
            Vec3::new(x0, -ph * 0.9, 0.0),
            Vec3::new(x1, length * 0.2, 0.0),
            Vec3::new(x1 + 0.07 * length, 0.0, 0.0),
            Vec3::new(x1, -length * 0.2, 0.0),
        ];
        let base = fish.positions.len() as u32;
        for p in fin_pts {
            fish.push_vertex(p, [fin[0], fin[1], fin[2], 1.0], seg_len);
        }
        fish.indices.extend_from_slice(&[
            base,
            base + 2,
            base + 3,
            base,
            base + 3,
            base + 1,
            base + 1,
            base + 3,
            base + 4,
        ]);
        // Dorsal fin: a low sail along the back.
        let base = fish.positions.len() as u32;
        let n_dorsal = 8;
        for i in 0..=n_dorsal {
            let u = 0.28 + 0.5 * i as f32 / n_dorsal as f32;
            let (h, _) = profile(u);
            let rise = length * 0.085 * (std::f32::consts::PI * i as f32 / n_dorsal as f32).sin();
            fish.push_vertex(
                Vec3::new(-u * length, h * 0.97, 0.0),
                [fin[0], fin[1], fin[2], 1.0],
                seg_len,
            );
            fish.push_vertex(
                Vec3::new(-u * length, h + rise, 0.0),
                [fin[0], fin[1], fin[2], 1.0],
                seg_len,
            );
        }
        for i in 0..n_dorsal as u32 {
            let a = base + 2 * i;
            fish.indices
                .extend_from_slice(&[a, a + 2, a + 1, a + 1, a + 2, a + 3]);
        }
        fish.compute_normals();
        fish
    }

    /// The standard test fish: 50 units long, 8 joints, about 1,100 triangles.
    pub fn demo() -> Self {
        Self::new(50.0, 8, 28, 20)
    }

    fn push_vertex(&mut self, p: Vec3, color: [f32; 4], seg_len: f32) {
        let n = self.inverse_bind.len();
        let t = -p.x / seg_len;
        let s = t - 0.5;
        let j0 = s.floor().clamp(0.0, (n - 1) as f32) as usize;
        let j1 = (j0 + 1).min(n - 1);
        let f = (s - j0 as f32).clamp(0.0, 1.0);
        let (joints, weights) = if j1 == j0 {
            ([j0 as u16, 0, 0, 0], [1.0, 0.0, 0.0, 0.0])
        } else {
            ([j0 as u16, j1 as u16, 0, 0], [1.0 - f, f, 0.0, 0.0])
        };
        self.positions.push(p.to_array());
        self.normals.push([0.0; 3]);
        self.colors.push(color);
        self.joints.push(joints);
        self.weights.push(weights);
    }

    /// Adds a body triangle wound so its normal points away from the column (the x axis).
    fn push_tri_outward(&mut self, a: u32, b: u32, c: u32) {
        let [pa, pb, pc] = [a, b, c].map(|i| Vec3::from(self.positions[i as usize]));
        let n = (pb - pa).cross(pc - pa);
        if n.length_squared() < 1e-12 {
            return;
        }
        let centroid = (pa + pb + pc) / 3.0;
        let out = Vec3::new(0.0, centroid.y, centroid.z);
        if n.dot(out) >= 0.0 {
            self.indices.extend_from_slice(&[a, b, c]);
        } else {
            self.indices.extend_from_slice(&[a, c, b]);
        }
    }

    fn compute_normals(&mut self) {
        let mut acc = vec![Vec3::ZERO; self.positions.len()];
        for t in self.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3::from(self.positions[i as usize]));
            let n = (b - a).cross(c - a);
            for &i in t {
                acc[i as usize] += n;
            }
        }
        for (dst, n) in self.normals.iter_mut().zip(acc) {
            *dst = n.normalize_or(Vec3::Y).to_array();
        }
    }

    /// Number of joints.
    pub fn num_joints(&self) -> usize {
        self.inverse_bind.len()
    }

    /// The mesh as a renderer upload.
    pub fn upload(&self) -> MeshUpload<'_> {
        MeshUpload {
            label: "procedural fish",
            positions: &self.positions,
            normals: &self.normals,
            colors: &self.colors,
            joints: &self.joints,
            weights: &self.weights,
            indices: &self.indices,
            uvs: &[],
            tangents: &[],
            materials: &[],
            parts: &[],
        }
    }

    /// Writes the skinning palette (`root × model_j × inverse_bind_j`) for local joint yaws
    /// (radians; positive swings the body behind that joint towards the fish's left, −z) into
    /// `out`. `yaws` and `out` have [`TestFish::num_joints`] entries.
    pub fn palette(&self, root: Mat4, yaws: &[f32], out: &mut [Mat4]) {
        let seg_len = self.length / self.num_joints() as f32;
        let mut model = Mat4::IDENTITY;
        for (j, (dst, inv)) in out.iter_mut().zip(&self.inverse_bind).enumerate() {
            let offset = if j == 0 { 0.0 } else { -seg_len };
            let yaw = yaws.get(j).copied().unwrap_or(0.0);
            model *= Mat4::from_rotation_translation(
                Quat::from_rotation_y(-yaw),
                Vec3::new(offset, 0.0, 0.0),
            );
            *dst = root * model * *inv;
        }
    }
}

fn lerp3(a: [f32; 3], b: [f32; 3], t: f32) -> [f32; 3] {
    [
        a[0] + (b[0] - a[0]) * t,
        a[1] + (b[1] - a[1]) * t,
        a[2] + (b[2] - a[2]) * t,
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_sum_to_one_and_joints_in_range() {
        let f = TestFish::demo();
        for (w, j) in f.weights.iter().zip(&f.joints) {
            assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
            assert!(j.iter().all(|&j| (j as usize) < f.num_joints()));
        }
        assert!(f.indices.iter().all(|&i| (i as usize) < f.positions.len()));
    }

    #[test]
    fn rest_palette_is_identity() {
        let f = TestFish::demo();
        let mut out = vec![Mat4::ZERO; f.num_joints()];
        f.palette(Mat4::IDENTITY, &vec![0.0; f.num_joints()], &mut out);
        for m in out {
            assert!(m.abs_diff_eq(Mat4::IDENTITY, 1e-5), "{m:?}");
        }
    }

    #[test]
    fn positive_root_yaw_swings_tail_to_the_left() {
        let f = TestFish::demo();
        let mut out = vec![Mat4::ZERO; f.num_joints()];
        let mut yaws = vec![0.0; f.num_joints()];
        yaws[0] = 0.3;
        f.palette(Mat4::IDENTITY, &yaws, &mut out);
        let tail = out[f.num_joints() - 1].transform_point3(Vec3::new(-f.length, 0.0, 0.0));
        assert!(tail.z < -0.25 * f.length * 0.3, "tail at {tail:?}");
    }
}

//! Rigid props drawn through the fish pipeline: rocks (the world's sphere obstacles) and food
//! pellets. Each prop is a one-joint mesh; its transform goes into the palette buffer after the
//! fish palettes, so props cost no extra pipeline.

use glam::Vec3;

use super::MeshUpload;

/// An owned one-joint mesh (every vertex on joint 0 with weight 1).
#[derive(Debug, Clone, PartialEq)]
pub struct PropMesh {
    /// Debug label.
    pub label: &'static str,
    /// Positions, unit-sized model space.
    pub positions: Vec<[f32; 3]>,
    /// Normals.
    pub normals: Vec<[f32; 3]>,
    /// Linear RGBA per vertex.
    pub colors: Vec<[f32; 4]>,
    /// All `[0, 0, 0, 0]`.
    pub joints: Vec<[u16; 4]>,
    /// All `[1, 0, 0, 0]`.
    pub weights: Vec<[f32; 4]>,
    /// Triangle list.
    pub indices: Vec<u32>,
}

impl PropMesh {
    /// The mesh as a renderer upload.
    pub fn upload(&self) -> MeshUpload<'_> {
        MeshUpload {
            label: self.label,
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

    /// A lumpy grey-brown boulder of radius about 1 (it covers the world's obstacle sphere).
    pub fn rock() -> Self {
        Self::sphere("rock", 18, 12, |dir| {
            let lump = 0.12 * (dir.x * 5.1 + dir.z * 2.3).sin() * (dir.y * 4.7 - dir.x * 1.9).cos()
                + 0.06 * (dir.z * 11.0 + dir.y * 7.0).sin();
            let r = 1.0 + lump;
            let p = dir * r;
            let speck = 0.85 + 0.15 * (dir.x * 23.0).sin() * (dir.z * 19.0).cos();
            let moss = ((dir.y - 0.2) * 2.0).clamp(0.0, 1.0);
            let base = Vec3::new(0.3, 0.26, 0.2).lerp(Vec3::new(0.17, 0.22, 0.1), moss) * speck;
            (p, [base.x, base.y, base.z, 1.0])
        })
    }

    /// A small round food pellet of radius 1.
    pub fn pellet() -> Self {
        Self::sphere("food pellet", 10, 6, |dir| (dir, [0.55, 0.28, 0.08, 1.0]))
    }

    /// A UV sphere whose vertices `shape(direction)` places and colours.
    fn sphere(
        label: &'static str,
        segments: usize,
        rings: usize,
        shape: impl Fn(Vec3) -> (Vec3, [f32; 4]),
    ) -> Self {
        let mut m = PropMesh {
            label,
            positions: Vec::new(),
            normals: Vec::new(),
            colors: Vec::new(),
            joints: Vec::new(),
            weights: Vec::new(),
            indices: Vec::new(),
        };
        for i in 0..=rings {
            let theta = std::f32::consts::PI * i as f32 / rings as f32;
            for k in 0..=segments {
                let phi = std::f32::consts::TAU * k as f32 / segments as f32;
                let dir = Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                );
                let (p, c) = shape(dir);
                m.positions.push(p.to_array());
                m.normals.push([0.0; 3]);
                m.colors.push(c);
                m.joints.push([0; 4]);
                m.weights.push([1.0, 0.0, 0.0, 0.0]);
            }
        }
        let row = segments as u32 + 1;
        for i in 0..rings as u32 {
            for k in 0..segments as u32 {
                let a = i * row + k;
                let b = a + row;
                // Counter-clockwise seen from outside.
                m.indices.extend_from_slice(&[a, a + 1, b, a + 1, b + 1, b]);
            }
        }
        let mut acc = vec![Vec3::ZERO; m.positions.len()];
        for t in m.indices.chunks_exact(3) {
            let [a, b, c] = [t[0], t[1], t[2]].map(|i| Vec3::from(m.positions[i as usize]));
            let n = (b - a).cross(c - a);
            for &i in t {
                acc[i as usize] += n;
            }
        }
        for (dst, (n, p)) in m.normals.iter_mut().zip(acc.iter().zip(&m.positions)) {
            // Seam and pole vertices: fall back to the radial direction.
            *dst = n
                .try_normalize()
                .unwrap_or(Vec3::from(*p).normalize_or(Vec3::Y))
                .to_array();
        }
        m
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn props_are_one_joint_meshes_with_outward_normals() {
        for m in [PropMesh::rock(), PropMesh::pellet()] {
            assert!(m.joints.iter().all(|j| *j == [0; 4]));
            assert!(m.weights.iter().all(|w| *w == [1.0, 0.0, 0.0, 0.0]));
            let outward = m
                .positions
                .iter()
                .zip(&m.normals)
                .filter(|(p, n)| Vec3::from(**p).dot(Vec3::from(**n)) > 0.0)
                .count();
            assert!(
                outward * 10 >= m.positions.len() * 9,
                "{}: normals point inward",
                m.label
            );
        }
    }
}

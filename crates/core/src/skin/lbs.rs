//! Linear blend skinning, equation (1) of the paper, as allocation-free jobs over slices.
//!
//! V_c = Σ_n ω_n · M_{n,c} · M_{n,d}⁻¹ · V_d: the *palette* entry of joint n is its model matrix in
//! the current configuration C times its inverse bind (dress) pose, see [`palette`].

use glam::{Mat4, Vec3, Vec4};

use super::SkinError;

/// Writes the skinning palette: `out[j] = models[j] · inverse_bind_poses[j]` (M_{n,c}·M_{n,d}⁻¹).
///
/// All three slices have one entry per joint. Fails if their lengths differ. Never allocates.
pub fn palette(
    models: &[Mat4],
    inverse_bind_poses: &[Mat4],
    out: &mut [Mat4],
) -> Result<(), SkinError> {
    if models.len() != inverse_bind_poses.len() || models.len() != out.len() {
        return Err(SkinError::JobSlice {
            what: "palette",
            len: out.len(),
            expected: models.len().min(inverse_bind_poses.len()),
            detail: format!(
                "{} models, {} inverse bind poses, {} outputs",
                models.len(),
                inverse_bind_poses.len(),
                out.len()
            ),
        });
    }
    for ((o, m), ibm) in out.iter_mut().zip(models).zip(inverse_bind_poses) {
        *o = *m * *ibm;
    }
    Ok(())
}

/// Equation (1) on a CPU: skins positions and (optionally) normals with up to four influences per
/// vertex. The reference the GPU skinning must agree with.
///
/// Positions are transformed by the weighted sum of the palette matrices. Normals are transformed
/// by the cofactor (det · inverse-transpose) of that blend's upper 3×3, signed by its determinant,
/// then renormalized: exact for non-uniform scale, and no division per vertex. A normal whose
/// transform degenerates (zero length) is written as zero.
///
/// Weights are used as given (the loader makes them sum to 1); an influence with weight 0 is
/// skipped, so its joint index is never read. Never allocates.
#[derive(Debug)]
pub struct LinearBlendSkinningJob<'a> {
    /// Skinning matrices by joint, from [`palette`].
    pub palette: &'a [Mat4],
    /// Bind-shape (dress pose) positions V_d, one per vertex.
    pub positions_in: &'a [Vec3],
    /// Bind-shape normals, one per vertex, or empty to skip normals.
    pub normals_in: &'a [Vec3],
    /// Up to four joint indices (into `palette`) per vertex.
    pub joints: &'a [[u16; 4]],
    /// The matching weights ω_n per vertex.
    pub weights: &'a [[f32; 4]],
    /// Output: skinned positions V_c, one per vertex.
    pub positions_out: &'a mut [Vec3],
    /// Output: skinned unit normals, same length as `normals_in` (empty when that is empty).
    pub normals_out: &'a mut [Vec3],
}

impl LinearBlendSkinningJob<'_> {
    /// Checks every slice length: joints, weights and positions_out match positions_in;
    /// normals_in is empty or matches too, and normals_out matches normals_in.
    pub fn validate(&self) -> Result<(), SkinError> {
        let n = self.positions_in.len();
        let check = |what: &'static str, len: usize, expected: usize| {
            if len == expected {
                Ok(())
            } else {
                Err(SkinError::JobSlice {
                    what,
                    len,
                    expected,
                    detail: "one entry per vertex".into(),
                })
            }
        };
        check("joints", self.joints.len(), n)?;
        check("weights", self.weights.len(), n)?;
        check("positions_out", self.positions_out.len(), n)?;
        if !self.normals_in.is_empty() {
            check("normals_in", self.normals_in.len(), n)?;
        }
        check("normals_out", self.normals_out.len(), self.normals_in.len())?;
        Ok(())
    }

    /// Validates, then skins every vertex. Fails on the first joint index outside the palette.
    pub fn run(self) -> Result<(), SkinError> {
        self.validate()?;
        let with_normals = !self.normals_in.is_empty();
        for v in 0..self.positions_in.len() {
            let joints = self.joints[v];
            let weights = self.weights[v];
            let mut m = Mat4::ZERO;
            for k in 0..4 {
                let w = weights[k];
                if w == 0.0 {
                    continue;
                }
                let Some(p) = self.palette.get(usize::from(joints[k])) else {
                    return Err(SkinError::JointOutOfRange {
                        vertex: v,
                        joint: usize::from(joints[k]),
                        num_joints: self.palette.len(),
                    });
                };
                m += *p * w;
            }
            let pos = self.positions_in[v];
            self.positions_out[v] = (m * Vec4::new(pos.x, pos.y, pos.z, 1.0)).truncate();
            if with_normals {
                self.normals_out[v] = transform_normal(&m, self.normals_in[v]);
            }
        }
        Ok(())
    }
}

/// Transforms a normal by the cofactor of `m`'s upper 3×3 (signed by its determinant) and
/// renormalizes; zero when degenerate.
pub fn transform_normal(m: &Mat4, n: Vec3) -> Vec3 {
    let a = m.x_axis.truncate();
    let b = m.y_axis.truncate();
    let c = m.z_axis.truncate();
    let bc = b.cross(c);
    let det = a.dot(bc);
    let cof = bc * n.x + c.cross(a) * n.y + a.cross(b) * n.z;
    let signed = if det < 0.0 { -cof } else { cof };
    signed.normalize_or_zero()
}

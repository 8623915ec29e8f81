//! The fish a [`super::DemoScene`] draws: the procedural test fish, or a glTF asset (the
//! generated black porgy) bound with the species layer's rig. Either way the motion layer's
//! driven-joint yaws go in and a skinning palette comes out.

use glam::{Mat4, Vec3};

use super::MeshUpload;
use super::testmesh::TestFish;
use crate::motion::Body;
use crate::skeleton::{JointTransform, NO_PARENT};
use crate::skin::FishModel;
use crate::species::{SpeciesDesc, SpeciesRig};

/// A skinned fish and how to pose it.
#[derive(Debug, Clone)]
pub enum DemoRig {
    /// The procedural fish; its joints 1.. are the motion layer's driven joints.
    Procedural {
        /// The mesh and bind pose.
        fish: TestFish,
        /// `Body::evenly_spaced(num_joints)`.
        body: Body,
    },
    /// A glTF model bound by [`SpeciesRig::bind`].
    Asset {
        /// Species name (the mesh label).
        name: String,
        /// The model.
        model: Box<FishModel>,
        /// Its binding (driven joints, bend axes, model → body frame).
        rig: Box<SpeciesRig>,
        /// Body length, length units.
        length: f32,
    },
}

impl DemoRig {
    /// The procedural fish.
    pub fn procedural() -> Self {
        let fish = TestFish::demo();
        let body = Body::evenly_spaced(fish.num_joints());
        DemoRig::Procedural { fish, body }
    }

    /// Loads `path` (e.g. `assets/black_porgy.glb`) and binds it with `desc`.
    pub fn asset(desc: &SpeciesDesc, path: &std::path::Path) -> Result<Self, String> {
        let model = FishModel::load(path).map_err(|e| e.to_string())?;
        let rig = SpeciesRig::bind(desc, &model).map_err(|e| e.to_string())?;
        Ok(DemoRig::Asset {
            name: desc.name.clone(),
            model: Box::new(model),
            rig: Box::new(rig),
            length: desc.motion.l,
        })
    }

    /// The mesh to upload.
    pub fn upload(&self) -> MeshUpload<'_> {
        match self {
            DemoRig::Procedural { fish, .. } => fish.upload(),
            DemoRig::Asset { name, model, .. } => MeshUpload::from_skinned_mesh(name, &model.mesh),
        }
    }

    /// Body length, length units.
    pub fn length(&self) -> f32 {
        match self {
            DemoRig::Procedural { fish, .. } => fish.length,
            DemoRig::Asset { length, .. } => *length,
        }
    }

    /// The body the motion layer drives.
    pub fn body(&self) -> &Body {
        match self {
            DemoRig::Procedural { body, .. } => body,
            DemoRig::Asset { rig, .. } => &rig.body,
        }
    }

    /// Palette entries per fish.
    pub fn num_joints(&self) -> usize {
        match self {
            DemoRig::Procedural { fish, .. } => fish.num_joints(),
            DemoRig::Asset { model, .. } => model.skeleton.num_joints(),
        }
    }

    /// Scratch space for [`DemoRig::write_palette`].
    pub fn scratch(&self) -> PoseScratch {
        let n = self.num_joints();
        PoseScratch {
            yaws: vec![0.0; n],
            locals: vec![JointTransform::IDENTITY; n],
            models: vec![Mat4::IDENTITY; n],
        }
    }

    /// Writes the palette of a fish placed at `root` (world, root = head end of the column,
    /// +x forward) with the motion layer's driven-joint `yaw` into `out`
    /// ([`DemoRig::num_joints`] entries). Never allocates.
    pub fn write_palette(
        &self,
        root: Mat4,
        yaw: &[f32],
        scratch: &mut PoseScratch,
        out: &mut [Mat4],
    ) {
        match self {
            DemoRig::Procedural { fish, .. } => {
                scratch.yaws[0] = 0.0;
                let n = yaw.len().min(scratch.yaws.len() - 1);
                scratch.yaws[1..=n].copy_from_slice(&yaw[..n]);
                fish.palette(root, &scratch.yaws, out);
            }
            DemoRig::Asset { model, rig, .. } => {
                rig.pose(yaw, &mut scratch.locals);
                let job = model.skeleton.local_to_model(
                    root * rig.model_to_body,
                    &scratch.locals,
                    &mut scratch.models,
                );
                // Lengths match by construction (scratch sized from this skeleton).
                if job.run().is_ok() {
                    for ((o, m), ibm) in out
                        .iter_mut()
                        .zip(&scratch.models)
                        .zip(&model.inverse_bind_poses)
                    {
                        *o = *m * *ibm;
                    }
                }
            }
        }
    }

    /// Each joint's bind position (model space of the palette, i.e. where `palette[j]` maps it
    /// from) and its parent, for the skeleton overlay.
    pub fn bind_joints(&self) -> (Vec<Vec3>, Vec<u16>) {
        match self {
            DemoRig::Procedural { fish, .. } => {
                let n = fish.num_joints();
                let seg = fish.length / n as f32;
                let pos = (0..n)
                    .map(|j| Vec3::new(-(j as f32) * seg, 0.0, 0.0))
                    .collect();
                let parents = (0..n)
                    .map(|j| if j == 0 { NO_PARENT } else { (j - 1) as u16 })
                    .collect();
                (pos, parents)
            }
            DemoRig::Asset { model, .. } => (
                model
                    .inverse_bind_poses
                    .iter()
                    .map(|ibm| ibm.inverse().w_axis.truncate())
                    .collect(),
                model.skeleton.parents().to_vec(),
            ),
        }
    }
}

/// Reused buffers of [`DemoRig::write_palette`].
#[derive(Debug, Clone)]
pub struct PoseScratch {
    yaws: Vec<f32>,
    locals: Vec<JointTransform>,
    models: Vec<Mat4>,
}

//! The pose stage in its GPU form (issue 18): the renderer poses the fish itself from a few
//! numbers per fish, instead of the CPU writing every fish's palette every tick.
//!
//! Each species' [`PosePlan`] becomes a small program ([`GpuPosePrograms`], plain data in
//! [`crate::skin::pose_program`]) of the same steps
//! the CPU walks: its model steps (`model[k] = model[parent] · local`, the local transform written
//! `a + cos θ·b + sin θ·c`, so a driven joint's Rodrigues bend and a rest joint's constant
//! matrix are one formula) and its palette slots (`model[left] · rhs`, or the placement). Per
//! fish the world writes one [`GpuFishPose`] (position, heading, pitch, driven yaws, palette
//! offset: 96 bytes, against 64 bytes per palette slot posed on the CPU) and the slot-0 entry
//! the renderer culls with, its placement made the shader's way. `shaders/pose.wgsl`
//! runs the program once per fish into the palette buffer, in the layout the CPU stage writes;
//! the two agree to f32 rounding (`tests/render_pose.rs`).

use glam::{Mat4, Vec4};

use super::{Matrices, PlanMatrices, PosePlan, Transform};
use crate::motion::RootState;
use crate::skeleton::NO_PARENT;
use crate::skin::pose_program::{
    GPU_NOT_DRIVEN, GPU_POSE_MAX_MODELS, GpuFishPose, GpuModelStep, GpuPosePrograms, GpuProgram,
    GpuSlotStep, placement_rotation,
};
use crate::world::MAX_DRIVEN_JOINTS;

const _: () = assert!(MAX_DRIVEN_JOINTS == crate::skin::pose_program::GPU_POSE_MAX_YAWS);

/// The programs of `plans` (one per species, named by `names`). An error names the first species
/// whose skeleton needs more than [`GPU_POSE_MAX_MODELS`] model matrices.
pub fn programs(plans: &[PosePlan], names: &[&str]) -> Result<GpuPosePrograms, String> {
    let mut out = GpuPosePrograms::default();
    for (species, plan) in plans.iter().enumerate() {
        let program = match &plan.matrices {
            PlanMatrices::Affine(m) => plan.gpu_program(m, &mut out),
            PlanMatrices::General(m) => plan.gpu_program(m, &mut out),
        };
        let name = names.get(species).copied().unwrap_or("?");
        let program = program.map_err(|e| format!("species {name}: {e}"))?;
        out.programs.push(program);
    }
    Ok(out)
}

/// The pose pass's record of a fish at `root` with its driven joints' `yaw`.
pub fn fish_record(
    root: &RootState,
    yaw: &[f32; MAX_DRIVEN_JOINTS],
    program: u32,
    palette_offset: u32,
) -> GpuFishPose {
    crate::skin::pose_program::fish_pose(
        root.pos,
        root.heading,
        root.pitch,
        yaw,
        program,
        palette_offset,
    )
}

fn cols(m: Mat4) -> [[f32; 4]; 4] {
    m.to_cols_array_2d()
}

impl PosePlan {
    /// Appends this plan's steps to `out` and returns its program.
    fn gpu_program<T: Transform>(
        &self,
        m: &Matrices<T>,
        out: &mut GpuPosePrograms,
    ) -> Result<GpuProgram, String> {
        let schedule = &self.schedule;
        if schedule.models.len() > GPU_POSE_MAX_MODELS {
            return Err(format!(
                "its skeleton needs {} model matrices per fish; the GPU pose pass holds {}",
                schedule.models.len(),
                GPU_POSE_MAX_MODELS
            ));
        }
        // Joint → its model step's index (parents come first, so a parent's is known).
        let mut step_of_joint = vec![-1i32; self.num_joints()];
        let first_model = out.models.len() as u32;
        for (k, step) in schedule.models.iter().enumerate() {
            let j = usize::from(step.joint);
            step_of_joint[j] = k as i32;
            let parent = match step.parent {
                NO_PARENT => -1,
                p => step_of_joint[usize::from(p)],
            };
            let (a, b, c, yaw_slot) = match step.yaw_slot {
                super::NOT_DRIVEN => (m.rest[j].to_mat4(), Mat4::ZERO, Mat4::ZERO, GPU_NOT_DRIVEN),
                slot => {
                    let bend = &self.bends[j];
                    let linear = |m: glam::Mat3A, w: Vec4| {
                        Mat4::from_cols(
                            m.x_axis.extend(0.0),
                            m.y_axis.extend(0.0),
                            m.z_axis.extend(0.0),
                            w,
                        )
                    };
                    (
                        linear(bend.outer, bend.translation.extend(1.0)),
                        linear(bend.rest_minus_outer, Vec4::ZERO),
                        linear(bend.cross, Vec4::ZERO),
                        u32::from(slot),
                    )
                }
            };
            out.models.push(GpuModelStep {
                a: cols(a),
                b: cols(b),
                c: cols(c),
                parent,
                yaw_slot,
                _pad: [0; 2],
            });
        }
        let first_slot = out.slots.len() as u32;
        for step in &schedule.palette {
            let j = usize::from(step.joint);
            let left = match step.left {
                NO_PARENT => -1,
                p => step_of_joint[usize::from(p)],
            };
            out.slots.push(GpuSlotStep {
                rhs: cols(m.palette_rhs[j].to_mat4()),
                left,
                product: u32::from(step.product),
                _pad: [0; 2],
            });
        }
        Ok(GpuProgram {
            model_to_body: cols(m.model_to_body.to_mat4()),
            first_model,
            num_models: schedule.models.len() as u32,
            first_slot,
            num_slots: schedule.palette.len() as u32,
        })
    }

    /// Slot 0 of a fish's palette (joint 0's entry, which the renderer culls with) with the
    /// placement made as the pose pass makes it ([`placement_rotation`]): the CPU stage's slot 0
    /// to f32 rounding, for a third of its cost (no quaternions). Only joint 0's model is made
    /// (joint 0 is a root, as parents come before children).
    pub fn anchor(&self, root: &RootState, yaw: &[f32]) -> Mat4 {
        fn run<T: Transform>(
            plan: &PosePlan,
            m: &Matrices<T>,
            root: &RootState,
            yaw: &[f32],
        ) -> Mat4 {
            let rotation = placement_rotation(root.heading, root.pitch);
            let placement = T::from_linear_translation(rotation, root.pos.into()) * m.model_to_body;
            let Some(step) = plan.schedule.palette.first() else {
                return placement.to_mat4();
            };
            let j = usize::from(step.joint);
            match (step.product, step.left) {
                (false, _) => placement.to_mat4(),
                (true, NO_PARENT) => (placement * m.palette_rhs[j]).to_mat4(),
                (true, left) => {
                    let left = usize::from(left);
                    let local = plan.local(m, left, plan.yaw_slot[left], yaw);
                    (placement * local * m.palette_rhs[j]).to_mat4()
                }
            }
        }
        match &self.matrices {
            PlanMatrices::Affine(m) => run(self, m, root, yaw),
            PlanMatrices::General(m) => run(self, m, root, yaw),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::within;
    use super::*;
    use crate::skin::pose_program::run_program;
    use crate::world::{Species, SpeciesDesc};
    use glam::Vec3;

    fn shipped() -> Vec<Species> {
        let assets = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
        [SpeciesDesc::black_porgy(), SpeciesDesc::eel()]
            .into_iter()
            .map(|desc| Species::load(desc, &assets).expect("shipped species"))
            .collect()
    }

    #[test]
    fn programs_pose_the_shipped_fish_as_the_cpu_stage_does() {
        let species = shipped();
        let plans: Vec<PosePlan> = species
            .iter()
            .map(|s| PosePlan::new(&s.rig, &s.model))
            .collect();
        let programs = programs(&plans, &["black_porgy", "eel"]).unwrap();
        assert_eq!(programs.programs.len(), 2);
        for (k, plan) in plans.iter().enumerate() {
            let root = RootState {
                pos: Vec3::new(120.0, -40.0, 310.0),
                heading: 2.1,
                pitch: -0.3,
                speed: 1.0,
            };
            let mut yaw = [0.0f32; MAX_DRIVEN_JOINTS];
            for (i, y) in yaw.iter_mut().enumerate() {
                *y = 0.25 * ((i as f32) * 1.3).sin();
            }
            let mut cpu = vec![Mat4::ZERO; plan.num_joints()];
            plan.palette_of(&root, &yaw, &mut cpu);
            let fish = fish_record(&root, &yaw, k as u32, 0);
            let mut gpu = vec![Mat4::ZERO; plan.num_slots()];
            run_program(&programs, &fish, &mut gpu);
            for (j, &slot) in plan.slot_of_joint().iter().enumerate() {
                let g = &gpu[usize::from(slot)];
                assert!(
                    within(g, &cpu[j], 2e-5),
                    "species {k} joint {j}: program {g:?} against the CPU stage {:?}",
                    cpu[j]
                );
            }
            // The culling anchor is the CPU stage's slot 0 to rounding, and the program's.
            let anchor = plan.anchor(&root, &yaw);
            assert!(
                within(&anchor, &cpu[0], 2e-6),
                "{anchor:?} against {:?}",
                cpu[0]
            );
            assert!(
                within(&anchor, &gpu[0], 2e-6),
                "{anchor:?} against {:?}",
                gpu[0]
            );
            // A changed yaw changes the tail's entry: the program reads the yaws.
            let mut bent = fish;
            bent.yaw[2] += 0.4;
            let mut moved = vec![Mat4::ZERO; plan.num_slots()];
            run_program(&programs, &bent, &mut moved);
            assert!(moved.iter().zip(&gpu).any(|(a, b)| !within(a, b, 1e-3)));
        }
    }

    #[test]
    fn a_skeleton_too_big_for_the_pass_is_refused_by_name() {
        let species = shipped();
        let mut plan = PosePlan::new(&species[0].rig, &species[0].model);
        let step = plan.schedule.models[0];
        plan.schedule.models = vec![step; GPU_POSE_MAX_MODELS + 1];
        let err = programs(&[plan], &["big"]).unwrap_err();
        assert!(
            err.contains("species big") && err.contains("33 model matrices"),
            "{err}"
        );
    }

    #[test]
    fn non_finite_yaws_are_written_as_rest() {
        let root = RootState::default();
        let mut yaw = [0.1f32; MAX_DRIVEN_JOINTS];
        yaw[3] = f32::NAN;
        yaw[4] = f32::INFINITY;
        let f = fish_record(&root, &yaw, 0, 7);
        assert_eq!(f.yaw[3], 0.0);
        assert_eq!(f.yaw[4], 0.0);
        assert_eq!(f.yaw[5], 0.1);
        assert_eq!(f.palette_offset, 7);
        assert_eq!(std::mem::size_of::<GpuFishPose>(), 96);
    }
}

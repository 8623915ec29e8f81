//! The pose stage in its GPU form (issue 18): the renderer poses the fish itself from a few
//! numbers per fish, instead of the CPU writing every fish's palette every tick.
//!
//! Each species' [`PosePlan`] becomes a small program ([`GpuPosePrograms`], plain data in
//! [`crate::skin::pose_program`]) of the same steps
//! the CPU walks, after its body's midline samples (the motion player's wave table, the joints'
//! positions and power weights): its model steps (`model[k] = model[parent] · local`, the local transform written
//! `a + cos θ·b + sin θ·c`, so a driven joint's Rodrigues bend and a rest joint's constant
//! matrix are one formula) and its palette slots (`model[left] · rhs`, or the placement). Per
//! fish the world writes one [`GpuFishPose`] (position, heading, pitch, palette offset, and the
//! motion player's shape terms — phase, speed gain, blend weight, each motion's turn terms: 112
//! bytes, against 64 bytes per palette slot posed on the CPU) and the slot-0 entry the renderer
//! culls with, its placement made the shader's way. `shaders/pose.wgsl` samples the body's
//! shape, derives the driven joints' yaws and runs the program once per fish into the palette
//! buffer, in the layout the CPU stage writes; the two agree to f32 rounding
//! (`crates/app/tests/app/render_pose.rs`). So in GPU mode the motion stage moves the roots only: the body's
//! shape, most of that stage's cost, is the pass's.

use glam::{Mat4, Vec4};

use super::{Matrices, PlanMatrices, PosePlan, Transform};
use crate::motion::player::ShapeTerms;
use crate::motion::{Body, MotionParams, RootState, WaveTable};
use crate::skeleton::NO_PARENT;
use crate::skin::pose_program::{
    GPU_NOT_DRIVEN, GPU_POSE_MAX_MODELS, GPU_POSE_MAX_SAMPLES, GpuFishPose, GpuModelStep,
    GpuPosePrograms, GpuProgram, GpuShapeSample, GpuSlotStep, placement_rotation_of,
};
use crate::world::MAX_DRIVEN_JOINTS;

const _: () = assert!(MAX_DRIVEN_JOINTS == crate::skin::pose_program::GPU_POSE_MAX_YAWS);

/// What the pass's shape step needs of a species: its name (for errors), motion parameters,
/// body and the body wave's table (built for those two).
pub struct SpeciesShape<'a> {
    /// The species' name.
    pub name: &'a str,
    /// Its motion parameters.
    pub params: &'a MotionParams,
    /// Its body (midline samples, power weights).
    pub body: &'a Body,
    /// Its wave table.
    pub table: &'a WaveTable,
}

/// Why a species cannot be posed by the GPU pass (the pose stage then poses on the CPU).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ProgramsError {
    /// The world gave no body for the species at this index (a world bug).
    #[error("species {0}: no body for its pose program")]
    NoBody(usize),
    /// The species (by name) exceeds what the pass holds.
    #[error("species {species}: {limit}")]
    Limit {
        /// The species' name.
        species: String,
        /// What it exceeds.
        limit: ProgramLimit,
    },
}

/// What a species' skeleton or body exceeds in the GPU pose pass.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ProgramLimit {
    /// More model matrices per fish than the pass's [`GPU_POSE_MAX_MODELS`].
    #[error("its skeleton needs {needed} model matrices per fish; the GPU pose pass holds {max}")]
    Models {
        /// What the skeleton needs.
        needed: usize,
        /// What the pass holds.
        max: usize,
    },
    /// More midline samples than the pass's [`GPU_POSE_MAX_SAMPLES`], or a body whose driven
    /// joints and samples do not pair up.
    #[error(
        "its body has {driven} driven joints and {samples} midline samples; the GPU pose pass \
         holds {max} driven joints"
    )]
    Samples {
        /// The body's driven joints.
        driven: usize,
        /// The body's midline samples (`joints_x`).
        samples: usize,
        /// The driven joints the pass holds.
        max: usize,
    },
    /// The wave table does not match the species' parameters and body (a world bug).
    #[error("its wave table was built for other parameters")]
    StaleTable,
}

/// The programs of `plans`, one per species of `shapes`. An error names the first species whose
/// skeleton needs more than [`GPU_POSE_MAX_MODELS`] model matrices or whose body has more
/// midline samples than the pass holds.
pub fn programs(
    plans: &[PosePlan],
    shapes: &[SpeciesShape<'_>],
) -> Result<GpuPosePrograms, ProgramsError> {
    let mut out = GpuPosePrograms::default();
    for (species, plan) in plans.iter().enumerate() {
        let Some(shape) = shapes.get(species) else {
            return Err(ProgramsError::NoBody(species));
        };
        let program = match &plan.matrices {
            PlanMatrices::Affine(m) => plan.gpu_program(m, &mut out),
            PlanMatrices::General(m) => plan.gpu_program(m, &mut out),
        }
        .and_then(|program| shape_samples(shape, program, &mut out));
        let program = program.map_err(|limit| ProgramsError::Limit {
            species: shape.name.to_owned(),
            limit,
        })?;
        out.programs.push(program);
    }
    Ok(out)
}

/// Appends the body's midline samples (head first) to `out` and returns `program` with them.
fn shape_samples(
    shape: &SpeciesShape<'_>,
    mut program: GpuProgram,
    out: &mut GpuPosePrograms,
) -> Result<GpuProgram, ProgramLimit> {
    let body = shape.body;
    let n = body.joints_x.len() + 1;
    if n > GPU_POSE_MAX_SAMPLES || body.power.len() + 2 != n {
        return Err(ProgramLimit::Samples {
            driven: body.power.len(),
            samples: body.joints_x.len(),
            max: GPU_POSE_MAX_SAMPLES - 2,
        });
    }
    if !shape.table.matches(shape.params, body) {
        return Err(ProgramLimit::StaleTable);
    }
    program.first_sample = out.samples.len() as u32;
    program.num_samples = n as u32;
    program.f = shape.params.f;
    let l = shape.params.l;
    let xs = std::iter::once(0.0).chain(body.joints_x.iter().copied());
    for (i, ((xp, amp, (swim_sin, swim_cos)), x)) in shape.table.shape_samples().zip(xs).enumerate()
    {
        out.samples.push(GpuShapeSample {
            xp,
            amp,
            swim_sin,
            swim_cos,
            xl: x * l,
            // Sample i ≥ 1 is joint i − 1's position; the tail tip drives nothing.
            power: i
                .checked_sub(1)
                .and_then(|j| body.power.get(j))
                .copied()
                .unwrap_or(0.0),
            _pad: [0.0; 2],
        });
    }
    Ok(program)
}

/// The pose pass's record of a fish at `root` whose motion player's shape terms are `terms`.
pub(crate) fn fish_record(
    root: &RootState,
    terms: &ShapeTerms,
    program: u32,
    palette_offset: u32,
) -> GpuFishPose {
    GpuFishPose {
        pos_heading: root.pos.extend(root.heading).to_array(),
        pitch: root.pitch,
        program,
        palette_offset,
        _pad: 0,
        wave: [terms.phase, terms.gain, terms.weight, 0.0],
        current: terms.current,
        previous: terms.previous,
    }
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
    ) -> Result<GpuProgram, ProgramLimit> {
        let schedule = &self.schedule;
        if schedule.models.len() > GPU_POSE_MAX_MODELS {
            return Err(ProgramLimit::Models {
                needed: schedule.models.len(),
                max: GPU_POSE_MAX_MODELS,
            });
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
            first_sample: 0,
            num_samples: 0,
            f: 0.0,
            _pad: 0,
        })
    }

    /// Whether [`PosePlan::anchor`] reads a driven joint's yaw (slot 0 made from a driven
    /// joint's model); none of the shipped rigs does, so the GPU stage rarely needs a fish's
    /// yaws on the CPU.
    pub fn anchor_reads_yaw(&self) -> bool {
        self.schedule.palette.first().is_some_and(|step| {
            step.product
                && step.left != NO_PARENT
                && self.yaw_slot[usize::from(step.left)] != super::NOT_DRIVEN
        })
    }

    /// Slot 0 of a fish's palette (joint 0's entry, which the renderer culls with) with the
    /// placement made as the pose pass makes it ([`placement_rotation`]): the CPU stage's slot 0
    /// to f32 rounding, for a third of its cost (no quaternions). Only joint 0's model is made
    /// (joint 0 is a root, as parents come before children).
    pub fn anchor(&self, root: &RootState, yaw: &[f32]) -> Mat4 {
        self.anchor_with(root, root.heading.sin_cos(), yaw)
    }

    /// [`PosePlan::anchor`] with the heading's sine and cosine, `heading_sin_cos`, given
    /// (`root.heading.sin_cos()`, bitwise: the motion pass has them for the crowd columns).
    pub fn anchor_with(&self, root: &RootState, heading_sin_cos: (f32, f32), yaw: &[f32]) -> Mat4 {
        fn run<T: Transform>(
            plan: &PosePlan,
            m: &Matrices<T>,
            root: &RootState,
            heading_sin_cos: (f32, f32),
            yaw: &[f32],
        ) -> Mat4 {
            let rotation = placement_rotation_of(heading_sin_cos, root.pitch);
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
            PlanMatrices::Affine(m) => run(self, m, root, heading_sin_cos, yaw),
            PlanMatrices::General(m) => run(self, m, root, heading_sin_cos, yaw),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::within;
    use super::*;
    use crate::motion::player::MotionTerms;
    use crate::motion::{MotionPlayer, MotionRequest, Side, TurnKind};
    use crate::skin::pose_program::{run_program, shape_yaws};
    use crate::world::{Species, SpeciesDesc};
    use glam::Vec3;

    fn shipped() -> Vec<Species> {
        let assets = crate::source_root().join("assets");
        [SpeciesDesc::black_porgy(), SpeciesDesc::eel()]
            .into_iter()
            .map(|desc| Species::load(desc, &assets).expect("shipped species"))
            .collect()
    }

    fn shapes<'a>(species: &'a [Species], tables: &'a [WaveTable]) -> Vec<SpeciesShape<'a>> {
        species
            .iter()
            .zip(tables)
            .map(|(s, table)| SpeciesShape {
                name: &s.desc.name,
                params: &s.desc.motion,
                body: &s.rig.body,
                table,
            })
            .collect()
    }

    /// The shipped fish swimming, turning each way and cross-fading between motions: the
    /// program's yaws (the shader's shape step on the CPU) are the motion player's, and its
    /// palettes the CPU stage's, to f32 rounding.
    #[test]
    fn programs_pose_the_shipped_fish_as_the_motion_player_and_cpu_stage_do() {
        let species = shipped();
        let tables: Vec<WaveTable> = species
            .iter()
            .map(|s| WaveTable::new(&s.desc.motion, &s.rig.body))
            .collect();
        let plans: Vec<PosePlan> = species
            .iter()
            .map(|s| PosePlan::new(&s.rig, &s.model))
            .collect();
        let programs = programs(&plans, &shapes(&species, &tables)).unwrap();
        assert_eq!(programs.programs.len(), 2);
        let (mut blended, mut stroke_turns, mut normal_turns) = (0, 0, 0);
        for (k, (sp, plan)) in species.iter().zip(&plans).enumerate() {
            let (params, body) = (&sp.desc.motion, &sp.rig.body);
            let driven = body.power.len();
            let mut player = MotionPlayer::with_phase(0.7 + k as f32);
            let mut root = RootState {
                pos: Vec3::new(120.0, -40.0, 310.0),
                heading: 2.1,
                pitch: -0.3,
                speed: 0.0,
            };
            let mut lateral = vec![0.0; body.joints_x.len()];
            let mut yaw = [0.0f32; MAX_DRIVEN_JOINTS];
            player
                .push(MotionRequest::Swim { speed: params.s })
                .unwrap();
            let turns = [
                (TurnKind::Quick, Side::Left),
                (TurnKind::Normal, Side::Right),
                (TurnKind::Serial, Side::Left),
            ];
            for step in 0..600 {
                if step % 150 == 90 {
                    let (kind, side) = turns[(step / 150) % turns.len()];
                    let turn = MotionRequest::Turn {
                        kind,
                        angle: 1.2,
                        side,
                    };
                    player.interrupt(turn).unwrap();
                }
                player.step_with(
                    1.0 / 60.0,
                    params,
                    body,
                    &tables[k],
                    &mut root,
                    &mut lateral,
                    &mut yaw[..driven],
                );
                if step % 7 != 0 {
                    continue;
                }
                let terms = player.shape_terms(root.speed, params);
                blended += usize::from(terms.weight < 1.0);
                let turning = |kind| terms.current.kind == kind && terms.current.ip > 0.0;
                stroke_turns += usize::from(turning(MotionTerms::STROKE_TURN));
                normal_turns += usize::from(turning(MotionTerms::NORMAL_TURN));
                let fish = fish_record(&root, &terms, k as u32, 0);
                let derived = shape_yaws(&programs.programs[k], &programs.samples, &fish);
                for (j, (g, c)) in derived.iter().zip(&yaw).enumerate() {
                    assert!(
                        (g - c).abs() <= 2e-5 * (1.0 + c.abs()),
                        "species {k} step {step} joint {j}: shape step {g} against the player's {c}"
                    );
                }
                let mut cpu = vec![Mat4::ZERO; plan.num_joints()];
                plan.palette_of(&root, &yaw, &mut cpu);
                let mut gpu = vec![Mat4::ZERO; plan.num_slots()];
                run_program(&programs, &fish, &mut gpu);
                for (j, &slot) in plan.slot_of_joint().iter().enumerate() {
                    let g = &gpu[usize::from(slot)];
                    assert!(
                        within(g, &cpu[j], 5e-5),
                        "species {k} step {step} joint {j}: program {g:?} against the CPU stage {:?}",
                        cpu[j]
                    );
                }
                // The culling anchor is the CPU stage's slot 0 to rounding, and the program's.
                assert!(!plan.anchor_reads_yaw());
                let anchor = plan.anchor(&root, &[]);
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
            }
        }
        // The states compared include cross-fades and both kinds of turn wave.
        assert!(
            blended > 4 && stroke_turns > 4 && normal_turns > 4,
            "blended {blended}, stroke turns {stroke_turns}, normal turns {normal_turns}"
        );
    }

    #[test]
    fn a_skeleton_too_big_for_the_pass_is_refused_by_name() {
        let species = shipped();
        let tables = [WaveTable::new(
            &species[0].desc.motion,
            &species[0].rig.body,
        )];
        let mut plan = PosePlan::new(&species[0].rig, &species[0].model);
        let step = plan.schedule.models[0];
        plan.schedule.models = vec![step; GPU_POSE_MAX_MODELS + 1];
        let mut shape = shapes(&species[..1], &tables);
        shape[0].name = "big";
        let err = programs(&[plan], &shape).unwrap_err();
        assert_eq!(
            err,
            ProgramsError::Limit {
                species: "big".into(),
                limit: ProgramLimit::Models {
                    needed: GPU_POSE_MAX_MODELS + 1,
                    max: GPU_POSE_MAX_MODELS
                }
            }
        );
        let err = err.to_string();
        assert!(
            err.contains("species big") && err.contains("33 model matrices"),
            "{err}"
        );
    }

    #[test]
    fn a_body_with_a_stale_wave_table_is_refused_by_name() {
        let species = shipped();
        let tables = [WaveTable::new(
            &species[1].desc.motion,
            &species[1].rig.body,
        )];
        let plan = PosePlan::new(&species[0].rig, &species[0].model);
        // The eel's table beside the porgy's parameters and body.
        let shape = shapes(&species[..1], &tables);
        let err = programs(&[plan], &shape).unwrap_err();
        assert!(
            matches!(&err, ProgramsError::Limit { species, limit: ProgramLimit::StaleTable }
                if species == "black_porgy"),
            "{err:?}"
        );
        assert!(err.to_string().contains("species black_porgy"), "{err}");
    }

    #[test]
    fn non_finite_terms_pose_the_rest_shape() {
        let species = shipped();
        let tables = [WaveTable::new(
            &species[0].desc.motion,
            &species[0].rig.body,
        )];
        let plan = PosePlan::new(&species[0].rig, &species[0].model);
        let programs = programs(&[plan], &shapes(&species[..1], &tables)).unwrap();
        let terms = ShapeTerms {
            phase: f32::NAN,
            gain: 1.0,
            weight: 1.0,
            current: MotionTerms::PLAIN,
            previous: MotionTerms::PLAIN,
        };
        let f = fish_record(&RootState::default(), &terms, 0, 7);
        assert_eq!(f.palette_offset, 7);
        let yaws = shape_yaws(&programs.programs[0], &programs.samples, &f);
        assert!(yaws.iter().all(|&y| y == 0.0), "{yaws:?}");
        // A finite phase bends the body: the yaws come from the terms.
        let f = fish_record(
            &RootState::default(),
            &ShapeTerms {
                phase: 1.0,
                ..terms
            },
            0,
            7,
        );
        let yaws = shape_yaws(&programs.programs[0], &programs.samples, &f);
        assert!(yaws.iter().any(|&y| y.abs() > 1e-3), "{yaws:?}");
        assert_eq!(std::mem::size_of::<GpuFishPose>(), 112);
    }
}

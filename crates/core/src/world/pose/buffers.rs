//! [`PoseBuffers`]: what the pose stage writes — the skinning palettes on the CPU, or one record
//! per fish for the renderer's GPU pose pass — and where it poses.
//!
//! The world keeps them beside its [`WorldState`] and its spatial index (`index.rs`); the pose
//! stage ([`PoseBuffers::update`]) takes the state and the species' prepared data explicitly.

use std::sync::atomic::Ordering;
use std::time::Instant;

use glam::Mat4;

use super::super::registry::Catalog;
use super::super::shape::derive_shape;
use super::super::{PoseMode, StageCounters, WorldState};
use super::{LEAF_FISH, PoseInputs, PoseTiming, gpu, run};
use crate::skin::pose_program::{GpuFishPose, GpuPosePrograms};

/// The pose stage's output and settings (see the module docs).
pub(in crate::world) struct PoseBuffers {
    /// `palette_offsets[i]..palette_offsets[i + 1]` is dense fish i's palette range (its
    /// species' slots, see `pose.rs`).
    pub palette_offsets: Vec<u32>,
    /// Names the fish set, their species and `palette_offsets` as they are now: a new value
    /// ([`next_fish_revision`], unique across worlds) whenever any of them changes (see
    /// [`crate::world::World::fish_revision`]).
    pub fish_revision: u64,
    pub palettes: Vec<Mat4>,
    /// Where the pose stage poses (see [`PoseMode`]).
    pub pose_mode: PoseMode,
    /// The species' pose programs for the GPU pass, rebuilt with the pose plans; an error names
    /// a species whose skeleton is too big for it (the stage then poses on the CPU).
    pub gpu_programs: Result<GpuPosePrograms, gpu::ProgramsError>,
    /// After a GPU-mode pose stage, per dense fish: its record for the pose pass.
    pub gpu_fish: Vec<GpuFishPose>,
    /// After a GPU-mode pose stage, per dense fish: its palette's slot 0 (culling).
    pub pose_anchors: Vec<Mat4>,
    /// The fish's stored body shapes (`yaw`, `lateral`, the players' head recoil) are the
    /// players' current ones. False after a motion stage that left the shape to the GPU pass
    /// ([`PoseMode::Gpu`]) and after a restore: readers then derive it from the players, and
    /// the CPU pose stage refreshes it first.
    pub shapes_current: bool,
}

impl Default for PoseBuffers {
    fn default() -> Self {
        Self {
            palette_offsets: vec![0],
            fish_revision: next_fish_revision(),
            palettes: Vec::new(),
            pose_mode: PoseMode::Cpu,
            gpu_programs: Ok(GpuPosePrograms::default()),
            gpu_fish: Vec::new(),
            pose_anchors: Vec::new(),
            shapes_current: true,
        }
    }
}

/// A fish revision no world has had: one counter for the process, so that two worlds (a scene
/// restarted, the split tank's two) never share a value.
pub(in crate::world) fn next_fish_revision() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

impl PoseBuffers {
    /// Whether the pose stage writes GPU records: [`PoseMode::Gpu`] and every species fits the
    /// pass.
    pub fn on_gpu(&self) -> bool {
        self.pose_mode == PoseMode::Gpu && self.gpu_programs.is_ok()
    }

    /// The pose stage (see [`super::super::World::update_pose`]): palettes on the CPU, or the
    /// GPU pass's records; timed into `counters`.
    pub fn update(
        &mut self,
        state: &mut WorldState,
        catalog: &Catalog,
        counters: &mut StageCounters,
    ) {
        if self.on_gpu() {
            self.write_gpu_records(state, catalog, counters);
            return;
        }
        self.refresh_shapes(state, catalog);
        self.gpu_fish.clear();
        self.pose_anchors.clear();
        let start = Instant::now();
        let total = *self.palette_offsets.last().unwrap_or(&0) as usize;
        if self.palettes.len() != total {
            self.palettes.resize(total, Mat4::IDENTITY);
        }
        let inputs = PoseInputs {
            plans: &catalog.plans,
            fish_species: &state.fish.species,
            roots: &state.fish.roots,
            yaw: &state.fish.yaw,
            offsets: &self.palette_offsets,
        };
        let timing = PoseTiming::default();
        run(&inputs, 0, state.fish.len(), &mut self.palettes, &timing);
        let wall = start.elapsed().as_nanos() as u64;
        let skel = timing.skeleton_ns.load(Ordering::Relaxed);
        let pal = timing.palette_ns.load(Ordering::Relaxed);
        let share = if skel + pal > 0 {
            skel as f64 / (skel + pal) as f64
        } else {
            0.5
        };
        counters.skeleton_ns = (wall as f64 * share) as u64;
        counters.palette_ns = wall - counters.skeleton_ns;
    }

    /// Brings the stored body shapes (and the players' head recoil) up to date after motion
    /// stages that left them to the GPU pass: what whole motion steps would have stored, bit
    /// for bit.
    fn refresh_shapes(&mut self, state: &mut WorldState, catalog: &Catalog) {
        use rayon::prelude::*;
        if self.shapes_current {
            return;
        }
        let (species, wave_tables) = (&catalog.species, &catalog.wave_tables);
        let fish = &mut state.fish;
        fish.players
            .par_iter_mut()
            .zip(fish.roots.par_iter())
            .zip(fish.lateral.par_iter_mut())
            .zip(fish.yaw.par_iter_mut())
            .zip(fish.species.par_iter())
            .with_min_len(256)
            .for_each(|((((player, root), lateral), yaw), sid)| {
                let s = usize::from(sid.0);
                let (head, _) = derive_shape(
                    player,
                    root.speed,
                    &species[s],
                    &wave_tables[s],
                    lateral,
                    yaw,
                );
                player.set_head_shape(head);
            });
        self.shapes_current = true;
    }

    /// The record and anchor arrays sized for `n` fish, for a pass that writes every fish's
    /// record itself ([`gpu_record`]; the motion pass of `World::advance`), with the palette
    /// offsets it reads; the CPU palettes are emptied, as [`PoseBuffers::update`] leaves them in
    /// GPU mode.
    pub fn records_to_fill(&mut self, n: usize) -> RecordsOut<'_> {
        self.palettes.clear();
        self.gpu_fish.resize(n, bytemuck::Zeroable::zeroed());
        self.pose_anchors.resize(n, Mat4::IDENTITY);
        RecordsOut {
            records: &mut self.gpu_fish,
            anchors: &mut self.pose_anchors,
            offsets: &self.palette_offsets,
        }
    }

    /// The GPU pose stage: each fish's pass record and slot-0 entry, over both cores in
    /// chunks of [`LEAF_FISH`] fish.
    fn write_gpu_records(
        &mut self,
        state: &WorldState,
        catalog: &Catalog,
        counters: &mut StageCounters,
    ) {
        use rayon::prelude::*;
        let start = Instant::now();
        self.palettes.clear();
        let n = state.fish.len();
        self.gpu_fish.resize(n, bytemuck::Zeroable::zeroed());
        self.pose_anchors.resize(n, Mat4::IDENTITY);
        let shapes_current = self.shapes_current;
        let fish = &state.fish;
        let offsets = &self.palette_offsets;
        self.gpu_fish
            .par_chunks_mut(LEAF_FISH)
            .zip(self.pose_anchors.par_chunks_mut(LEAF_FISH))
            .enumerate()
            .for_each(|(chunk, (records, anchors))| {
                let first = chunk * LEAF_FISH;
                for (k, (record, anchor)) in records.iter_mut().zip(anchors).enumerate() {
                    let i = first + k;
                    (*record, *anchor) = gpu_record(
                        catalog,
                        &fish.players[i],
                        &fish.roots[i],
                        fish.species[i].0,
                        offsets[i],
                        fish.roots[i].heading.sin_cos(),
                        || shape_of(state, catalog, shapes_current, i).1,
                    );
                }
            });
        counters.skeleton_ns = 0;
        counters.palette_ns = start.elapsed().as_nanos() as u64;
    }
}

/// What [`PoseBuffers::records_to_fill`] hands a pass that writes the GPU records itself: one
/// entry per fish of each, in dense order.
pub(in crate::world) struct RecordsOut<'a> {
    pub records: &'a mut [GpuFishPose],
    pub anchors: &'a mut [Mat4],
    pub offsets: &'a [u32],
}

/// A fish's record for the GPU pose pass and its anchor (slot 0 of its palette, what the
/// renderer culls with), from its motion player and root as the motion stage left them:
/// `species` is its species' index, `offset` its first palette slot, `heading_sin_cos`
/// `root.heading.sin_cos()`, and `yaw()` its driven
/// joints' yaws now (asked only when the species' anchor reads one; see
/// [`super::PosePlan::anchor_reads_yaw`]). The pose stage's record pass and the motion pass that
/// writes the records itself (`World::advance`) both make them here.
pub(in crate::world) fn gpu_record(
    catalog: &Catalog,
    player: &crate::motion::MotionPlayer,
    root: &crate::motion::RootState,
    species: u16,
    offset: u32,
    heading_sin_cos: (f32, f32),
    yaw: impl FnOnce() -> [f32; super::super::MAX_DRIVEN_JOINTS],
) -> (GpuFishPose, Mat4) {
    let sp = &catalog.species[usize::from(species)];
    let terms = player.shape_terms(root.speed, &sp.desc.motion);
    let record = gpu::fish_record(root, &terms, u32::from(species), offset);
    let plan = &catalog.plans[usize::from(species)];
    let anchor = if plan.anchor_reads_yaw() {
        plan.anchor_with(root, heading_sin_cos, &yaw())
    } else {
        plan.anchor_with(root, heading_sin_cos, &[])
    };
    (record, anchor)
}

/// Dense fish `d`'s body shape now — its midline's lateral displacement at each `joints_x` entry
/// and its driven joints' yaws (unused entries 0) — as stored when `shapes_current`, else
/// derived from its motion player (the GPU pass's share of the last motion stage).
pub(in crate::world) fn shape_of(
    state: &WorldState,
    catalog: &Catalog,
    shapes_current: bool,
    d: usize,
) -> (
    [f32; super::super::MAX_DRIVEN_JOINTS + 1],
    [f32; super::super::MAX_DRIVEN_JOINTS],
) {
    let fish = &state.fish;
    let (mut lateral, mut yaw) = (fish.lateral[d], fish.yaw[d]);
    if !shapes_current {
        let sid = usize::from(fish.species[d].0);
        derive_shape(
            &fish.players[d],
            fish.roots[d].speed,
            &catalog.species[sid],
            &catalog.wave_tables[sid],
            &mut lateral,
            &mut yaw,
        );
    }
    (lateral, yaw)
}

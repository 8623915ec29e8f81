//! The Rust stages of a tick ([`super::tick::step`] runs them in order): motion, pose, grid.

use std::ops::Range;
use std::time::Instant;

use glam::{Mat4, Vec2};

use super::contact::{drift, resolve_contact};
use super::registry::Catalog;
use super::sense::wrap_angle;
use super::shape::derive_shape;
use super::{FishId, MAX_DRIVEN_JOINTS, PoseMode, StageCounters, World, WorldState, pose};
use crate::motion::RootState;
use std::sync::atomic::Ordering;

impl World {
    // ---- the Rust stages of a tick ----------------------------------------------------------

    /// Advances every fish by `dt` seconds (ignored unless finite and positive): motion players
    /// (locomotion and the body wave), drift in current zones, then hard contact — each fish's
    /// body (head, middle and tail along its heading) is pushed out of obstacles and back inside
    /// the tank, with `contact` set — so no script can take a fish out of the tank or through a
    /// rock. A motion step that yields a non-finite root is discarded (the fish keeps its last
    /// root and stops). Then the pellets sink, drift and dissolve (`World::step_food`). Timed
    /// into `motion_ns`.
    pub fn step_motion(&mut self, dt: f32) {
        self.step_motion_writing(dt, false, false);
    }

    /// Stages 3 to 5 of a tick ([`super::tick::step`]): [`World::step_motion`], then
    /// [`World::update_pose`], then [`World::rebuild_grid`], with the same results, in fewer
    /// passes over the fish: the motion pass, while it has each fish at hand, also writes what
    /// the two later stages would read of it again — in [`PoseMode::Gpu`] the fish's record for
    /// the GPU pose pass and its anchor (the pose stage then has nothing left to do), and, while
    /// crowd queries are being made, its heading's cosine and sine for the crowd columns. At
    /// 100,000 fish the separate passes read every fish's motion player, root and species twice
    /// more and took each heading's sine and cosine twice (docs/performance.md). In GPU mode the
    /// records' time is part of `motion_ns` (`palette_ns` is 0).
    pub fn advance(&mut self, dt: f32) {
        if !(dt.is_finite() && dt > 0.0) {
            self.step_motion(dt);
            self.update_pose();
            self.rebuild_grid();
            return;
        }
        let records = self.poses_on_gpu();
        let headings = self.index.crowd_wanted.load(Ordering::Relaxed);
        self.step_motion_writing(dt, records, headings);
        if records {
            self.counters.skeleton_ns = 0;
            self.counters.palette_ns = 0;
        } else {
            self.update_pose();
        }
        let start = Instant::now();
        self.index
            .rebuild(&self.state, &self.catalog.species, headings);
        self.state.crowd_columns = self.index.crowd_columns.len() > 0;
        self.counters.grid_ns = start.elapsed().as_nanos() as u64;
    }

    /// [`World::step_motion`], writing also the GPU pose records (`records`, GPU mode only) and
    /// the heading vectors of the crowd columns (`headings`) as [`World::advance`] says.
    fn step_motion_writing(&mut self, dt: f32, records: bool, headings: bool) {
        if !(dt.is_finite() && dt > 0.0) {
            return;
        }
        let start = Instant::now();
        // In GPU mode the pose pass samples the body's shape itself (`shaders/pose.wgsl`): the
        // players only move the roots, and the stored shapes go stale until someone asks.
        let shape_on_cpu = !self.poses_on_gpu();
        let n = self.state.fish.len();
        let out = PassOutputs {
            records: records.then(|| self.pose.records_to_fill(n)),
            headings: headings.then(|| self.index.crowd_columns.headings_to_fill(n)),
        };
        let rejected = move_fish(&mut self.state, &self.catalog, shape_on_cpu, dt, out);
        self.pose.shapes_current = shape_on_cpu;
        if rejected > 0 {
            if self.rejected_motion_steps == 0 {
                log::warn!("{rejected} motion steps produced non-finite values and were discarded");
            }
            self.rejected_motion_steps += rejected;
        }
        self.index.fish_moved();
        self.step_food(dt);
        self.state.time += f64::from(dt);
        self.state.tick += 1;
        self.counters.motion_ns = start.elapsed().as_nanos() as u64;
    }

    /// Fish `d`'s body shape now — its midline's lateral displacement at each `joints_x` entry
    /// and its driven joints' yaws (unused entries 0) — as stored, or derived from its motion
    /// player when the last motion stage left the shape to the GPU pass.
    pub(super) fn shape_of(
        &self,
        d: usize,
    ) -> ([f32; MAX_DRIVEN_JOINTS + 1], [f32; MAX_DRIVEN_JOINTS]) {
        pose::buffers::shape_of(&self.state, &self.catalog, self.pose.shapes_current, d)
    }

    /// Motion steps discarded because they produced NaN or infinity (a motion-layer bug).
    pub fn rejected_motion_steps(&self) -> u64 {
        self.rejected_motion_steps
    }

    /// The pose stage. Poses every fish: species rig → local transforms → forward kinematics
    /// from the fish's placement (head at its root position, facing its heading and pitch) →
    /// skinning palette (model × inverse bind pose), its distinct entries only, into
    /// [`World::palettes`]. Runs over both cores with rayon; the result does not depend on the
    /// thread count. Timed into `skeleton_ns` and `palette_ns` (the stage's wall time split in
    /// proportion to the threads' time in each half).
    ///
    /// In [`PoseMode::Gpu`] it writes instead what the renderer's pose pass needs
    /// ([`World::gpu_pose_records`], [`World::pose_anchors`]), timed into `palette_ns`
    /// (`skeleton_ns` 0), and [`World::palettes`] is left empty.
    pub fn update_pose(&mut self) {
        self.pose
            .update(&mut self.state, &self.catalog, &mut self.counters);
    }

    /// The grid stage: rebuilds the spatial index ([`SpatialIndex::rebuild`]: the fish and
    /// food grids, with cells of 0.3 of the longest view range, and what the crowding and
    /// predator scans read) from the state as it is now. Timed into `grid_ns`.
    ///
    /// [`SpatialIndex::rebuild`]: super::index::SpatialIndex::rebuild
    pub fn rebuild_grid(&mut self) {
        let start = Instant::now();
        self.index
            .rebuild(&self.state, &self.catalog.species, false);
        self.state.crowd_columns = self.index.crowd_columns.len() > 0;
        self.counters.grid_ns = start.elapsed().as_nanos() as u64;
    }

    /// Where the pose stage poses (set with [`World::set_pose_mode`]).
    pub fn pose_mode(&self) -> PoseMode {
        self.pose.pose_mode
    }

    /// Chooses where the pose stage poses; takes effect at the next [`World::update_pose`].
    pub fn set_pose_mode(&mut self, mode: PoseMode) {
        self.pose.pose_mode = mode;
    }

    /// Whether the pose stage writes GPU records: [`PoseMode::Gpu`] and every species fits the
    /// pass.
    pub fn poses_on_gpu(&self) -> bool {
        self.pose.on_gpu()
    }

    /// The species' programs for the GPU pose pass (species order), or why a species cannot
    /// be posed there.
    pub fn gpu_pose_programs(
        &self,
    ) -> Result<&crate::skin::pose_program::GpuPosePrograms, &pose::gpu::ProgramsError> {
        self.pose.gpu_programs.as_ref()
    }

    /// Per fish (dense order), its record for the GPU pose pass, after a GPU-mode
    /// [`World::update_pose`] (empty otherwise).
    pub fn gpu_pose_records(&self) -> &[crate::skin::pose_program::GpuFishPose] {
        &self.pose.gpu_fish
    }

    /// Per fish (dense order), slot 0 of its palette (joint 0's entry, what the renderer culls
    /// with), after a GPU-mode [`World::update_pose`] (empty otherwise): the matrix the CPU stage
    /// writes there, to f32 rounding (its placement made as the pose pass makes it).
    pub fn pose_anchors(&self) -> &[Mat4] {
        &self.pose.pose_anchors
    }

    /// World-space skinning palettes of every fish, fish after fish (dense order), each fish's
    /// distinct entries only: its species' slots in slot order (joint j's entry is slot
    /// [`World::slot_of_joint`]`(species)[j]`; [`World::joint_palette`] expands them). Valid
    /// after [`World::update_pose`] in [`PoseMode::Cpu`]; empty in [`PoseMode::Gpu`].
    pub fn palettes(&self) -> &[Mat4] {
        &self.pose.palettes
    }

    /// The fish's slots in [`World::palettes`].
    pub fn palette_range(&self, id: FishId) -> Option<Range<usize>> {
        let d = self.state.fish.dense(id)?;
        let range =
            self.pose.palette_offsets[d] as usize..self.pose.palette_offsets[d + 1] as usize;
        (range.end <= self.pose.palettes.len()).then_some(range)
    }

    /// The fish's per-joint palette (one entry per skeleton joint, as `skin::palette` makes
    /// it), expanded from its slots into `out` — the same matrices bit for bit. False (and
    /// `out` empty) for a fish that is gone or not yet posed. When the pose stage runs on the
    /// GPU it is computed here, from the fish's current root and body shape, as the CPU stage
    /// would.
    pub fn joint_palette(&self, id: FishId, out: &mut Vec<Mat4>) -> bool {
        out.clear();
        if self.poses_on_gpu() {
            let (Some(d), Some(species)) = (self.state.fish.dense(id), self.species_of(id)) else {
                return false;
            };
            let plan = &self.catalog.plans[usize::from(species.0)];
            out.resize(plan.num_joints(), Mat4::IDENTITY);
            plan.palette_of(&self.state.fish.roots[d], &self.shape_of(d).1, out);
            return true;
        }
        let (Some(range), Some(species)) = (self.palette_range(id), self.species_of(id)) else {
            return false;
        };
        pose::expand_palette(&self.pose.palettes[range], self.slot_of_joint(species), out);
        true
    }

    /// Palette start (first slot) of each fish (dense order) plus the total at the end.
    pub fn palette_offsets(&self) -> &[u32] {
        &self.pose.palette_offsets
    }

    /// A value that changes whenever the live fish, their dense order, their species or their
    /// [`World::palette_offsets`] change (a spawn, a despawn, a restore, a species reloaded with
    /// other palette slots), and only then; unique across worlds. A renderer's caller keeps its
    /// per-fish draw list while this stays the same (the fish move without changing it).
    pub fn fish_revision(&self) -> u64 {
        self.pose.fish_revision
    }

    /// Timings of the last tick's stages.
    pub fn counters(&self) -> &StageCounters {
        &self.counters
    }

    /// Timings, for the stages timed outside the world (perception, Lua).
    pub fn counters_mut(&mut self) -> &mut StageCounters {
        &mut self.counters
    }
}

/// What the motion pass also writes per fish, in dense order, while it has the fish at hand
/// (see [`World::advance`]); each slice is one entry per fish.
struct PassOutputs<'a> {
    /// GPU pose records, anchors, and each fish's first palette slot (read).
    records: Option<pose::buffers::RecordsOut<'a>>,
    /// `crowd::heading_vector` of each fish's heading after the step.
    headings: Option<&'a mut [Vec2]>,
}

/// Fish per task of the motion pass.
const MOTION_CHUNK: usize = 256;

/// `slice` in chunks of [`MOTION_CHUNK`] entries, or `chunks` empty places without one.
fn chunked<T>(slice: Option<&mut [T]>, chunks: usize) -> Vec<Option<&mut [T]>> {
    match slice {
        Some(s) => s.chunks_mut(MOTION_CHUNK).map(Some).collect(),
        None => std::iter::repeat_with(|| None).take(chunks).collect(),
    }
}

/// The fish's part of the motion stage ([`World::step_motion`]): every fish's motion player,
/// body shape (when `shape_on_cpu`), drift and contact, over both cores, and what `out` asks
/// for. Returns how many steps were discarded for non-finite values.
fn move_fish(
    state: &mut WorldState,
    catalog: &Catalog,
    shape_on_cpu: bool,
    dt: f32,
    out: PassOutputs<'_>,
) -> u64 {
    let (species, wave_tables) = (&catalog.species, &catalog.wave_tables);
    let tank = state.tank;
    let obstacles = &state.obstacles;
    let currents = &state.currents;
    let fish = &mut state.fish;
    let chunks = fish.len().div_ceil(MOTION_CHUNK);
    let (records, anchors, offsets) = match out.records {
        Some(r) => (Some(r.records), Some(r.anchors), r.offsets),
        None => (None, None, &[][..]),
    };
    let mut records = chunked(records, chunks);
    let mut anchors = chunked(anchors, chunks);
    let mut headings = chunked(out.headings, chunks);
    use rayon::prelude::*;
    fish.players
        .par_chunks_mut(MOTION_CHUNK)
        .zip(fish.roots.par_chunks_mut(MOTION_CHUNK))
        .zip(fish.lateral.par_chunks_mut(MOTION_CHUNK))
        .zip(fish.yaw.par_chunks_mut(MOTION_CHUNK))
        .zip(fish.contact.par_chunks_mut(MOTION_CHUNK))
        .zip(fish.species.par_chunks(MOTION_CHUNK))
        .zip(records.par_iter_mut())
        .zip(anchors.par_iter_mut())
        .zip(headings.par_iter_mut())
        .enumerate()
        .map(
            |(
                c,
                ((((((((players, roots), lateral), yaw), contact), sids), recs), anchs), heads),
            )| {
                let mut rejected = 0;
                for k in 0..players.len() {
                    let (player, root, sid) = (&mut players[k], &mut roots[k], sids[k]);
                    let sp = &species[usize::from(sid.0)];
                    let before = *root;
                    // The table was built from this species' params and body when it was added or
                    // replaced (species change no other way), so it matches without a check.
                    let table = &wave_tables[usize::from(sid.0)];
                    debug_assert!(table.matches(&sp.desc.motion, &sp.rig.body));
                    // The whole step (`MotionPlayer::step_tabled`) is these halves, bit for bit.
                    player.advance_tabled(dt, &sp.desc.motion, root);
                    if shape_on_cpu {
                        let (head, finite) = derive_shape(
                            player,
                            root.speed,
                            sp,
                            table,
                            &mut lateral[k],
                            &mut yaw[k],
                        );
                        player.set_head_shape(head);
                        rejected += u64::from(!finite);
                    }
                    if !(root.pos.is_finite()
                        && root.heading.is_finite()
                        && root.pitch.is_finite()
                        && root.speed.is_finite())
                    {
                        *root = RootState {
                            speed: 0.0,
                            ..before
                        };
                        rejected += 1;
                    }
                    root.heading = wrap_angle(root.heading);
                    root.pos += drift(currents, root.pos) * dt;
                    contact[k] = resolve_contact(root, sp.desc.motion.l, &tank, obstacles);
                    if recs.is_none() && heads.is_none() {
                        continue;
                    }
                    // One sine and cosine of the heading for both outputs (`heading_vector` is
                    // (cos, sin), bitwise `sin_cos`'s; the test of `advance` compares them).
                    let heading_sin_cos = root.heading.sin_cos();
                    if let (Some(recs), Some(anchs)) = (recs.as_deref_mut(), anchs.as_deref_mut()) {
                        let i = c * MOTION_CHUNK + k;
                        // As `shape_of` gives it: the stored shape, re-derived from the player
                        // when the GPU samples the shapes.
                        let shape_yaw = || {
                            let (mut l, mut y) = (lateral[k], yaw[k]);
                            if !shape_on_cpu {
                                derive_shape(player, root.speed, sp, table, &mut l, &mut y);
                            }
                            y
                        };
                        (recs[k], anchs[k]) = pose::buffers::gpu_record(
                            catalog,
                            player,
                            root,
                            sid.0,
                            offsets[i],
                            heading_sin_cos,
                            shape_yaw,
                        );
                    }
                    if let Some(heads) = heads.as_deref_mut() {
                        let (sin, cos) = heading_sin_cos;
                        heads[k] = Vec2::new(cos, sin);
                    }
                }
                rejected
            },
        )
        .sum()
}

//! The Rust stages of a tick ([`super::tick::step`] runs them in order): motion, pose, grid.

use std::ops::Range;
use std::sync::atomic::Ordering;
use std::time::Instant;

use glam::Mat4;

use super::contact::{drift, resolve_contact};
use super::sense::wrap_angle;
use super::{FishId, MAX_DRIVEN_JOINTS, PoseMode, StageCounters, World, pose};
use crate::motion::RootState;

/// The grid's cell size as a share of the longest view range (see [`World::rebuild_grid`]).
pub(super) const GRID_CELL_OF_VIEW: f32 = 0.3;

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
        if !(dt.is_finite() && dt > 0.0) {
            return;
        }
        let start = Instant::now();
        let species = &self.species;
        let wave_tables = &self.wave_tables;
        let tank = self.state.tank;
        let obstacles = &self.state.obstacles;
        let currents = &self.state.currents;
        // In GPU mode the pose pass samples the body's shape itself (`shaders/pose.wgsl`): the
        // players only move the roots, and the stored shapes go stale until someone asks.
        let shape_on_cpu = !self.poses_on_gpu();
        let fish = &mut self.state.fish;
        use rayon::prelude::*;
        let rejected: u64 = fish
            .players
            .par_iter_mut()
            .zip(fish.roots.par_iter_mut())
            .zip(fish.lateral.par_iter_mut())
            .zip(fish.yaw.par_iter_mut())
            .zip(fish.contact.par_iter_mut())
            .zip(fish.species.par_iter())
            .with_min_len(256)
            .map(|(((((player, root), lateral), yaw), contact), sid)| {
                let sp = &species[usize::from(sid.0)];
                let before = *root;
                // The table was built from this species' params and body when it was added or
                // replaced (species change no other way), so it matches without a check.
                let table = &wave_tables[usize::from(sid.0)];
                debug_assert!(table.matches(&sp.desc.motion, &sp.rig.body));
                let mut rejected = 0;
                // The whole step (`MotionPlayer::step_tabled`) is these halves, bit for bit.
                player.advance_tabled(dt, &sp.desc.motion, root);
                if shape_on_cpu {
                    let (head, finite) = derive_shape(player, root.speed, sp, table, lateral, yaw);
                    player.set_head_shape(head);
                    rejected = u64::from(!finite);
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
                    rejected = 1;
                }
                root.heading = wrap_angle(root.heading);
                root.pos += drift(currents, root.pos) * dt;
                *contact = resolve_contact(root, sp.desc.motion.l, &tank, obstacles);
                rejected
            })
            .sum();
        self.shapes_current = shape_on_cpu;
        if rejected > 0 {
            if self.rejected_motion_steps == 0 {
                log::warn!("{rejected} motion steps produced non-finite values and were discarded");
            }
            self.rejected_motion_steps += rejected;
        }
        self.grid_positions_current = false;
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
        let fish = &self.state.fish;
        let (mut lateral, mut yaw) = (fish.lateral[d], fish.yaw[d]);
        if !self.shapes_current {
            let sid = usize::from(fish.species[d].0);
            derive_shape(
                &fish.players[d],
                fish.roots[d].speed,
                &self.species[sid],
                &self.wave_tables[sid],
                &mut lateral,
                &mut yaw,
            );
        }
        (lateral, yaw)
    }

    /// Brings the stored body shapes (and the players' head recoil) up to date after motion
    /// stages that left them to the GPU pass: what whole motion steps would have stored, bit
    /// for bit.
    fn refresh_shapes(&mut self) {
        use rayon::prelude::*;
        if self.shapes_current {
            return;
        }
        let (species, wave_tables) = (&self.species, &self.wave_tables);
        let fish = &mut self.state.fish;
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

    /// Motion steps discarded because they produced NaN or infinity (a motion-layer bug).
    pub fn rejected_motion_steps(&self) -> u64 {
        self.rejected_motion_steps
    }

    /// Poses every fish: species rig → local transforms → forward kinematics from the fish's
    /// placement (head at its root position, facing its heading and pitch) → skinning palette
    /// (model × inverse bind pose), its distinct entries only, into [`World::palettes`]. Runs over both cores with rayon;
    /// the result does not depend on the thread count. Timed into `skeleton_ns` and `palette_ns`
    /// (the stage's wall time split in proportion to the threads' time in each half).
    ///
    /// In [`PoseMode::Gpu`] it writes instead what the renderer's pose pass needs
    /// ([`World::gpu_pose_records`], [`World::pose_anchors`]), timed into `palette_ns`
    /// (`skeleton_ns` 0), and [`World::palettes`] is left empty.
    pub fn update_pose(&mut self) {
        if self.poses_on_gpu() {
            self.write_gpu_pose_records();
            return;
        }
        self.refresh_shapes();
        self.gpu_fish.clear();
        self.pose_anchors.clear();
        let start = Instant::now();
        let total = *self.palette_offsets.last().unwrap_or(&0) as usize;
        if self.palettes.len() != total {
            self.palettes.resize(total, Mat4::IDENTITY);
        }
        let inputs = pose::PoseInputs {
            plans: &self.pose_plans,
            fish_species: &self.state.fish.species,
            roots: &self.state.fish.roots,
            yaw: &self.state.fish.yaw,
            offsets: &self.palette_offsets,
        };
        let timing = pose::PoseTiming::default();
        pose::run(
            &inputs,
            0,
            self.state.fish.len(),
            &mut self.palettes,
            &timing,
        );
        let wall = start.elapsed().as_nanos() as u64;
        let skel = timing.skeleton_ns.load(Ordering::Relaxed);
        let pal = timing.palette_ns.load(Ordering::Relaxed);
        let share = if skel + pal > 0 {
            skel as f64 / (skel + pal) as f64
        } else {
            0.5
        };
        self.counters.skeleton_ns = (wall as f64 * share) as u64;
        self.counters.palette_ns = wall - self.counters.skeleton_ns;
    }

    /// Rebuilds the spatial grid from the fish's current positions (and the food grid), with
    /// cells of 0.3 of the longest view range. Timed into `grid_ns`.
    pub fn rebuild_grid(&mut self) {
        let start = Instant::now();
        let extent = self.state.tank.extent().max_element();
        let view = self
            .species
            .iter()
            .map(|s| s.desc.view_range)
            .filter(|r| r.is_finite() && *r > 0.0)
            .fold(0.0f32, f32::max);
        // Cells of 0.3 of the longest view: queries cull the cells they visit row by row to
        // their sphere, and smaller cells fit it closer. The shipped crowd query (300 units,
        // under a predator's 500-unit view) scanned 23 % fewer instructions with 150-unit cells
        // than with 250 (half-range) ones, the whole bench 2.7 % fewer (callgrind, 2,000 fish);
        // full-range cells visit ~5x the sphere's volume. No smaller than 1/64 of the tank, so a
        // tiny view range cannot explode the count.
        let cell = if view > 0.0 {
            (GRID_CELL_OF_VIEW * view).max(extent / 64.0)
        } else {
            extent / 16.0
        };
        if (cell - self.grid.cell_size()).abs() > 1e-6 * cell {
            self.grid
                .configure(self.state.tank.min, self.state.tank.max, cell);
            self.food_grid
                .configure(self.state.tank.min, self.state.tank.max, cell);
            self.food_in_grid = 0;
        }
        use rayon::prelude::*;
        let (roots, species) = (&self.state.fish.roots, &self.state.fish.species);
        // Over both cores: at 100,000 fish the serial rebuild took ~9 ms a tick, ~6 ms now.
        self.grid.rebuild_indexed(roots.len(), |i| roots[i].pos);
        self.grid_ids.clone_from(&self.state.fish.ids);
        // What the crowding rules read per neighbour, copied into the grid's cell order so
        // their scans read contiguous memory (see `crowd.rs`); the headings' cosines and sines
        // (over both cores) only if crowd queries were made since the last rebuild.
        let keys = self.grid.keys();
        self.grid_species.clear();
        self.grid_species.par_extend(
            keys.par_iter()
                .with_min_len(4096)
                .map(|&k| species[k as usize]),
        );
        let wanted = self.crowd_wanted.swap(false, Ordering::Relaxed);
        if wanted {
            self.crowd_columns.fill(
                keys,
                self.grid.positions(),
                &self.grid_species,
                roots.len(),
                |k| roots[k].heading,
            );
        } else {
            self.crowd_columns.clear();
        }
        self.refresh_predator_spots();
        self.grid_exact = true;
        self.grid_positions_current = true;
        self.spawned_since_grid.clear();
        if self.food_in_grid != self.state.foods.len() {
            self.food_grid.rebuild(
                self.state
                    .foods
                    .iter()
                    .enumerate()
                    .map(|(i, (_, f))| (i as u32, f.pos)),
            );
            self.food_in_grid = self.state.foods.len();
        }
        self.counters.grid_ns = start.elapsed().as_nanos() as u64;
    }

    /// The GPU pose stage: each fish's pass record and slot-0 entry, over both cores in
    /// chunks of [`pose::LEAF_FISH`] fish.
    fn write_gpu_pose_records(&mut self) {
        use rayon::prelude::*;
        let start = Instant::now();
        self.palettes.clear();
        let n = self.state.fish.len();
        self.gpu_fish.resize(n, bytemuck::Zeroable::zeroed());
        self.pose_anchors.resize(n, Mat4::IDENTITY);
        let mut records = std::mem::take(&mut self.gpu_fish);
        let mut anchors = std::mem::take(&mut self.pose_anchors);
        let world = &*self;
        let fish = &world.state.fish;
        let (plans, offsets) = (&world.pose_plans, &world.palette_offsets);
        records
            .par_chunks_mut(pose::LEAF_FISH)
            .zip(anchors.par_chunks_mut(pose::LEAF_FISH))
            .enumerate()
            .for_each(|(chunk, (records, anchors))| {
                let first = chunk * pose::LEAF_FISH;
                for (k, (record, anchor)) in records.iter_mut().zip(anchors).enumerate() {
                    let i = first + k;
                    let species = fish.species[i].0;
                    let sp = &world.species[usize::from(species)];
                    let root = &fish.roots[i];
                    let terms = fish.players[i].shape_terms(root.speed, &sp.desc.motion);
                    *record = pose::gpu::fish_record(root, &terms, u32::from(species), offsets[i]);
                    let plan = &plans[usize::from(species)];
                    *anchor = if plan.anchor_reads_yaw() {
                        plan.anchor(root, &world.shape_of(i).1)
                    } else {
                        plan.anchor(root, &[])
                    };
                }
            });
        self.gpu_fish = records;
        self.pose_anchors = anchors;
        self.counters.skeleton_ns = 0;
        self.counters.palette_ns = start.elapsed().as_nanos() as u64;
    }

    /// Where the pose stage poses (set with [`World::set_pose_mode`]).
    pub fn pose_mode(&self) -> PoseMode {
        self.pose_mode
    }

    /// Chooses where the pose stage poses; takes effect at the next [`World::update_pose`].
    pub fn set_pose_mode(&mut self, mode: PoseMode) {
        self.pose_mode = mode;
    }

    /// Whether the pose stage writes GPU records: [`PoseMode::Gpu`] and every species fits the
    /// pass.
    pub fn poses_on_gpu(&self) -> bool {
        self.pose_mode == PoseMode::Gpu && self.gpu_programs.is_ok()
    }

    /// The species' programs for the GPU pose pass (species order), or why a species cannot
    /// be posed there.
    pub fn gpu_pose_programs(&self) -> Result<&crate::skin::pose_program::GpuPosePrograms, &str> {
        self.gpu_programs.as_ref().map_err(String::as_str)
    }

    /// Per fish (dense order), its record for the GPU pose pass, after a GPU-mode
    /// [`World::update_pose`] (empty otherwise).
    pub fn gpu_pose_records(&self) -> &[crate::skin::pose_program::GpuFishPose] {
        &self.gpu_fish
    }

    /// Per fish (dense order), slot 0 of its palette (joint 0's entry, what the renderer culls
    /// with), after a GPU-mode [`World::update_pose`] (empty otherwise): the matrix the CPU stage
    /// writes there, to f32 rounding (its placement made as the pose pass makes it).
    pub fn pose_anchors(&self) -> &[Mat4] {
        &self.pose_anchors
    }

    /// World-space skinning palettes of every fish, fish after fish (dense order), each fish's
    /// distinct entries only: its species' slots in slot order (joint j's entry is slot
    /// [`World::slot_of_joint`]`(species)[j]`; [`World::joint_palette`] expands them). Valid
    /// after [`World::update_pose`] in [`PoseMode::Cpu`]; empty in [`PoseMode::Gpu`].
    pub fn palettes(&self) -> &[Mat4] {
        &self.palettes
    }

    /// The fish's slots in [`World::palettes`].
    pub fn palette_range(&self, id: FishId) -> Option<Range<usize>> {
        let d = self.state.fish.dense(id)?;
        let range = self.palette_offsets[d] as usize..self.palette_offsets[d + 1] as usize;
        (range.end <= self.palettes.len()).then_some(range)
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
            let plan = &self.pose_plans[usize::from(species.0)];
            out.resize(plan.num_joints(), Mat4::IDENTITY);
            plan.palette_of(&self.state.fish.roots[d], &self.shape_of(d).1, out);
            return true;
        }
        let (Some(range), Some(species)) = (self.palette_range(id), self.species_of(id)) else {
            return false;
        };
        pose::expand_palette(&self.palettes[range], self.slot_of_joint(species), out);
        true
    }

    /// Palette start (first slot) of each fish (dense order) plus the total at the end.
    pub fn palette_offsets(&self) -> &[u32] {
        &self.palette_offsets
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

/// How many entries of a fish's stored `lateral` and `yaw` arrays `body` uses: its `joints_x`
/// samples and its driven joints.
pub(super) fn shape_lens(body: &crate::motion::Body) -> (usize, usize) {
    (
        body.joints_x.len().min(MAX_DRIVEN_JOINTS + 1),
        body.power.len().min(MAX_DRIVEN_JOINTS),
    )
}

/// `player`'s body shape for a root moving at `speed`, into `lateral` and `yaw` as the motion
/// stage stores them (all 0 if a value is not finite); returns the head's lateral offset and
/// yaw, for [`crate::motion::MotionPlayer::set_head_shape`], and whether the shape was finite.
fn derive_shape(
    player: &crate::motion::MotionPlayer,
    speed: f32,
    sp: &super::Species,
    table: &crate::motion::WaveTable,
    lateral: &mut [f32; MAX_DRIVEN_JOINTS + 1],
    yaw: &mut [f32; MAX_DRIVEN_JOINTS],
) -> ((f32, f32), bool) {
    let body = &sp.rig.body;
    let (samples, driven) = shape_lens(body);
    let head = player.shape_tabled(
        speed,
        &sp.desc.motion,
        body,
        table,
        &mut lateral[..samples],
        &mut yaw[..driven],
    );
    let finite = finite_shape(&lateral[..samples], &yaw[..driven]);
    if !finite {
        lateral.fill(0.0);
        yaw.fill(0.0);
    }
    (head, finite)
}

/// Whether a body shape's values are all finite.
fn finite_shape(lateral: &[f32], yaw: &[f32]) -> bool {
    lateral.iter().chain(yaw).all(|v| v.is_finite())
}

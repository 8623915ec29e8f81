//! [`WorldScene`]: the adapter from a simulation ([`Showable`]) to the renderer — fixed 60 Hz ticks,
//! the species' real meshes, the world's own palettes — and the questions the panel asks about
//! a fish (where it is, its body wave, its inspector lines), all by [`FishId`].
//!
//! The renderer reads the world's flat palette buffer as is: one instance per fish with
//! `palette_offset = world.palette_offsets()[i]` and `mesh = MeshId(species index)`; the rock and
//! food pellet props come after the species' meshes. The world's palettes hold each fish's
//! distinct entries only (its species' slots), so each species' mesh is uploaded with its joint
//! indices remapped to slots ([`shoal_core::world::pose::remap_joints`]); when a species' layout
//! changes (a hot-reloaded species file with other vertebral joints), the scene says its meshes
//! must be uploaded again ([`WorldScene::take_meshes_changed`]).

use std::f32::consts::TAU;
use std::sync::Arc;
use std::time::Instant;

use glam::{Mat4, Vec3};

use super::showable::{LogLine, Showable, SimError, SimState};
use shoal_core::motion::RootState;
use shoal_core::motion::{MotionParams, MotionRequest};
use shoal_core::world::pose::remap_joints;
use shoal_core::world::{FishId, FishModel, FoodId, PoseMode, Species, SpeciesId, TICK_HZ, World};
use shoal_render::props::PropMesh;
use shoal_render::{
    Camera, FishInstance, FrameInput, GpuPoseFrame, Look, MeshId, MeshUpload, OverlayLine, Prop,
    TankBounds,
};

/// The scene the window shows: any [`Showable`] behind the adapter.
pub type DynScene = WorldScene<Box<dyn Showable>>;
/// Where a fish is, for picking and the follow camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FishInfo {
    /// Centre of a sphere holding the fish, world space.
    pub center: Vec3,
    /// Its radius, length units.
    pub radius: f32,
}

/// Which debug overlays to draw.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct OverlayToggles {
    /// Skeleton bones and joints.
    pub skeleton: bool,
    /// The body midline.
    pub midline: bool,
    /// Velocity (green) and heading (white) arrows.
    pub velocity: bool,
    /// Sensor ranges of the behaviour layer.
    pub sensors: bool,
}

impl OverlayToggles {
    /// Every overlay on.
    pub const ALL: Self = Self {
        skeleton: true,
        midline: true,
        velocity: true,
        sensors: true,
    };

    /// True if any overlay is on.
    pub fn any(&self) -> bool {
        self.skeleton || self.midline || self.velocity || self.sensors
    }
}

/// Per species: what the overlays and the mesh upload need from its model and palette layout.
#[derive(Debug, Clone)]
struct SpeciesDraw {
    model: Arc<FishModel>,
    /// Each joint's bind-pose position in model space (inverse of its inverse bind matrix).
    bind_joint_pos: Vec<Vec3>,
    /// The world's joint → slot map of the species when these draws were made.
    slot_of_joint: Vec<u16>,
    /// The mesh's per-vertex joint indices remapped to slots through `slot_of_joint`.
    slot_joints: Vec<[u16; 4]>,
}

/// A [`Showable`] as the renderer and the panel see it: fixed 60 Hz ticks, real meshes, fish
/// posed by the renderer's GPU pose pass (or, [`WorldScene::set_gpu_pose`] off, real palettes
/// from the CPU), and the selected fish highlighted.
pub struct WorldScene<S: Showable> {
    sim: S,
    species: Vec<SpeciesDraw>,
    instances: Vec<FishInstance>,
    /// Names `instances` for the renderer ([`FrameInput::instances_revision`]): a new value
    /// whenever they are rebuilt or patched.
    instances_revision: u64,
    /// What `instances` were built from: the world's [`World::fish_revision`] and the mesh
    /// base. While both stay, a frame keeps the list (the fish move without changing it).
    instances_built_from: Option<(u64, u32)>,
    /// CPU time of the last [`WorldScene::rebuild_instances`] (instances and props),
    /// milliseconds.
    instances_ms: f32,
    rock: PropMesh,
    pellet: PropMesh,
    props: Vec<Prop>,
    selected: Option<FishId>,
    /// Mesh id of species 0 in the renderer (see [`WorldScene::set_mesh_base`]).
    mesh_base: u32,
    /// A species' palette layout changed since the meshes were made (see
    /// [`WorldScene::take_meshes_changed`]).
    meshes_changed: bool,
    accumulator_s: f64,
    step_ms: f32,
    hot_reload: bool,
    /// Hot reload applied edits since [`WorldScene::take_reloaded`].
    reloaded: bool,
    reload_log: Vec<LogLine>,
    /// The world's pose mode, kept across scene restarts.
    pose_mode: PoseMode,
}

impl<S: Showable> std::fmt::Debug for WorldScene<S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WorldScene")
            .field("fish", &self.sim.world().num_fish())
            .field("species", &self.species.len())
            .finish()
    }
}

/// Radius of a drawn food pellet, length units.
pub const FOOD_PELLET_RADIUS: f32 = 2.5;

impl<S: Showable> WorldScene<S> {
    /// Wraps a simulation whose species are all loaded (meshes are uploaded once at start).
    pub fn new(mut sim: S) -> Self {
        // The renderer poses the fish: the world's pose stage only writes the pass's records.
        sim.world_mut().set_pose_mode(PoseMode::Gpu);
        // Those exist only after a pose stage; a fresh world has not run one.
        sim.world_mut().update_pose();
        let species = Self::species_draws(sim.world());
        let mut scene = Self {
            sim,
            species,
            instances: Vec::new(),
            instances_revision: shoal_render::next_instances_revision(),
            instances_built_from: None,
            instances_ms: 0.0,
            rock: PropMesh::rock(),
            pellet: PropMesh::pellet(),
            props: Vec::new(),
            selected: None,
            mesh_base: 0,
            meshes_changed: false,
            accumulator_s: 0.0,
            step_ms: 0.0,
            hot_reload: false,
            reloaded: false,
            reload_log: Vec::new(),
            pose_mode: PoseMode::Gpu,
        };
        scene.rebuild_instances();
        scene
    }

    fn species_draws(w: &World) -> Vec<SpeciesDraw> {
        (0..w.num_species())
            .map(|i| {
                let id = SpeciesId(i as u16);
                let model = w.species(id).model.clone();
                let bind_joint_pos = model
                    .inverse_bind_poses
                    .iter()
                    .map(|ibm| ibm.inverse().w_axis.truncate())
                    .collect();
                let slot_of_joint = w.slot_of_joint(id).to_vec();
                let slot_joints =
                    remap_joints(&model.mesh.joints, &slot_of_joint, w.num_palette_slots(id));
                SpeciesDraw {
                    model,
                    bind_joint_pos,
                    slot_of_joint,
                    slot_joints,
                }
            })
            .collect()
    }

    /// Whether the world's palette layout of some species is no longer the one the draws (and
    /// so the uploaded meshes) were made with.
    fn layout_changed(&self) -> bool {
        let w = self.sim.world();
        w.num_species() != self.species.len()
            || self
                .species
                .iter()
                .enumerate()
                .any(|(i, d)| w.slot_of_joint(SpeciesId(i as u16)) != d.slot_of_joint.as_slice())
    }

    /// Each species' joint → slot map, as its meshes ([`WorldScene::meshes`]) are remapped: two
    /// scenes whose layouts are equal can be drawn with the same meshes.
    pub fn palette_layout(&self) -> Vec<&[u16]> {
        self.species
            .iter()
            .map(|d| d.slot_of_joint.as_slice())
            .collect()
    }

    /// True (once) when a species' palette layout changed (a species reloaded with other
    /// vertebral joints, say): [`WorldScene::meshes`] then differ and must be uploaded again,
    /// in place of the old ones.
    pub fn take_meshes_changed(&mut self) -> bool {
        std::mem::take(&mut self.meshes_changed)
    }

    /// Where this scene's meshes start among the renderer's: [`WorldScene::meshes`]' first one
    /// is `MeshId(base)` (0 unless another scene's meshes come first, as the split tank's B
    /// when its palette layout differs from A's).
    pub fn set_mesh_base(&mut self, base: u32) {
        self.mesh_base = base;
        self.rebuild_instances();
    }

    /// Poses the fish on the GPU (`on`: the renderer's pose pass writes their palettes from
    /// [`FrameInput::gpu_pose`]) or on the CPU (the world's palettes); the world's pose stage
    /// follows from the next tick, and is run once now. Returns whether the GPU poses them: not
    /// while a species is too big for the pass ([`World::gpu_pose_programs`] says why).
    pub fn set_gpu_pose(&mut self, on: bool) -> bool {
        let mode = if on { PoseMode::Gpu } else { PoseMode::Cpu };
        self.pose_mode = mode;
        let world = self.sim.world_mut();
        world.set_pose_mode(mode);
        world.update_pose();
        self.rebuild_instances();
        self.sim.world().poses_on_gpu()
    }

    /// The simulation.
    pub fn sim(&self) -> &S {
        &self.sim
    }

    /// The simulation, mutably.
    pub fn sim_mut(&mut self) -> &mut S {
        &mut self.sim
    }

    /// The world being shown.
    pub fn world(&self) -> &World {
        self.sim.world()
    }

    /// Brings the instances and props up to the world: the props every time (few: rocks and
    /// food), the instances only when the fish, their species or palette offsets changed
    /// ([`World::fish_revision`]) or the meshes moved, so that a frame of moving fish costs
    /// nothing per fish here.
    fn rebuild_instances(&mut self) {
        let start = Instant::now();
        let relayout = self.layout_changed();
        if relayout {
            self.species = Self::species_draws(self.sim.world());
            self.meshes_changed = true;
        }
        let w = self.sim.world();
        if relayout || (w.poses_on_gpu() && w.gpu_pose_records().len() != w.num_fish()) {
            // A reloaded species moved the palette ranges, or fish came or went, since the last
            // pose stage (a paused world runs none): pose again, so the frame's palettes or
            // records match the instances.
            self.sim.world_mut().update_pose();
        }
        let w = self.sim.world();
        // Props: rocks for the sphere obstacles, pellets for uneaten food (mesh ids after the
        // species' meshes, see `meshes`).
        let base = self.mesh_base;
        let rock = MeshId(base + self.species.len() as u32);
        let pellet = MeshId(base + self.species.len() as u32 + 1);
        self.props.clear();
        for o in w.obstacles() {
            self.props.push(Prop {
                mesh: rock,
                transform: Mat4::from_scale_rotation_translation(
                    Vec3::splat(o.radius),
                    glam::Quat::from_rotation_y(o.pos.x * 0.013 + o.pos.z * 0.007),
                    o.pos,
                ),
                tint: [1.0; 3],
            });
        }
        for (_, food) in w.foods() {
            if !food.eaten {
                // A pellet is a point to the world; one that has settled is drawn resting on
                // what it settled on rather than half sunk into it.
                let lift = if food.settled {
                    FOOD_PELLET_RADIUS
                } else {
                    0.0
                };
                self.props.push(Prop {
                    mesh: pellet,
                    transform: Mat4::from_scale_rotation_translation(
                        Vec3::splat(FOOD_PELLET_RADIUS),
                        glam::Quat::IDENTITY,
                        food.pos + Vec3::Y * lift,
                    ),
                    tint: [1.0; 3],
                });
            }
        }
        let built_from = Some((w.fish_revision(), base));
        if relayout || built_from != self.instances_built_from {
            self.instances.clear();
            let fish = w.palette_offsets().iter().zip(w.fish_species());
            for ((offset, species), id) in fish.zip(w.fish_id_slice()) {
                self.instances.push(FishInstance {
                    mesh: MeshId(base + u32::from(species.0)),
                    palette_offset: *offset,
                    tint: [1.0; 3],
                    selected: self.selected == Some(*id),
                });
            }
            self.instances_built_from = built_from;
            self.instances_revision = shoal_render::next_instances_revision();
        }
        self.instances_ms = start.elapsed().as_secs_f32() * 1e3;
    }

    /// CPU time the last frame spent bringing the instances and props up to the world,
    /// milliseconds (constant in the fish count while no fish comes, goes or changes species).
    pub fn instances_ms(&self) -> f32 {
        self.instances_ms
    }

    /// The fish to draw, one per live fish in dense order, as the renderer gets them.
    pub fn instances(&self) -> &[FishInstance] {
        &self.instances
    }

    /// Every mesh to upload once at start: each species' in species order (`MeshId(i)` for
    /// species i, after the base of [`WorldScene::set_mesh_base`]), its joint indices remapped
    /// to the world's palette slots, then the rock and the food pellet.
    pub fn meshes(&self) -> Vec<MeshUpload<'_>> {
        let w = self.sim.world();
        let mut meshes: Vec<MeshUpload<'_>> = self
            .species
            .iter()
            .enumerate()
            .map(|(i, s)| MeshUpload {
                joints: &s.slot_joints,
                ..MeshUpload::from_skinned_mesh(
                    &w.species(SpeciesId(i as u16)).desc.name,
                    &s.model.mesh,
                )
            })
            .collect();
        meshes.push(self.rock.upload());
        meshes.push(self.pellet.upload());
        meshes
    }

    /// Advances the simulation by `dt_s` seconds of simulated time: every whole tick it covers
    /// runs, the rest carries over to the next call. Applies edited scripts first when hot
    /// reload is on.
    pub fn step(&mut self, dt_s: f32) {
        self.step_observed(dt_s, |_| {});
    }

    /// [`WorldScene::step`], calling `after_tick` with the simulation after every tick (the
    /// window's history ring records each tick this way).
    pub fn step_observed(&mut self, dt_s: f32, mut after_tick: impl FnMut(&S)) {
        self.step_until(dt_s, |sim| {
            after_tick(sim);
            true
        });
    }

    /// Like [`WorldScene::step_observed`], but stops after a tick for which `after_tick` returns
    /// false (a "pause when" condition met): the rest of the frame's time is dropped.
    pub fn step_until(&mut self, dt_s: f32, mut after_tick: impl FnMut(&S) -> bool) {
        let start = Instant::now();
        self.poll_hot_reload();
        if dt_s.is_finite() && dt_s > 0.0 {
            self.accumulator_s += f64::from(dt_s);
        }
        // Every due tick runs: `shoal render --fps 4` simulates 15 ticks a frame. The window
        // bounds a frame's real time instead (see `app::aquarium`), so a slow frame cannot
        // spiral.
        let tick = 1.0 / TICK_HZ;
        while self.accumulator_s >= tick - 1e-9 {
            self.sim.tick();
            self.accumulator_s -= tick;
            if !after_tick(&self.sim) {
                self.accumulator_s = 0.0;
                break;
            }
        }
        self.rebuild_instances();
        self.step_ms = start.elapsed().as_secs_f32() * 1e3;
    }

    /// Runs exactly `ticks` ticks (applying edited scripts first when hot reload is on),
    /// calling `after_tick` after each: the split tank's second version follows the first's
    /// tick count this way.
    pub fn step_ticks(&mut self, ticks: u64, mut after_tick: impl FnMut(&S)) {
        let start = Instant::now();
        self.poll_hot_reload();
        for _ in 0..ticks {
            self.sim.tick();
            after_tick(&self.sim);
        }
        self.rebuild_instances();
        self.step_ms = start.elapsed().as_secs_f32() * 1e3;
    }

    /// Applies edited scripts when hot reload is on. Stepping does it first; a paused window
    /// calls it every frame too, so that a save shows at once (its console line, a syntax
    /// error, the scene-changed notice) rather than at the next play or step.
    pub fn poll_hot_reload(&mut self) {
        if self.hot_reload {
            let events = self.sim.poll_reload();
            self.reloaded |= !events.is_empty();
            self.reload_log
                .extend(events.into_iter().map(LogLine::note));
        }
    }

    /// True (once) when hot reload applied edited scripts since the last call.
    pub fn take_reloaded(&mut self) -> bool {
        std::mem::take(&mut self.reloaded)
    }

    /// This frame's palettes (or, when the GPU poses the fish, what its pose pass needs),
    /// instances, props, tank and time, seen from [`WorldScene::default_camera`] with no
    /// overlay (the caller sets `camera` and `overlay`).
    pub fn frame_input(&self) -> FrameInput<'_> {
        let w = self.sim.world();
        let t = w.tank();
        let gpu_pose = match w.gpu_pose_programs() {
            Ok(programs) if w.poses_on_gpu() => Some(GpuPoseFrame {
                programs,
                fish: w.gpu_pose_records(),
                anchors: w.pose_anchors(),
                palette_len: w.palette_offsets().last().copied().unwrap_or(0),
            }),
            _ => None,
        };
        FrameInput {
            gpu_pose,
            palettes: w.palettes(),
            instances: &self.instances,
            instances_revision: Some(self.instances_revision),
            camera: self.default_camera(),
            tank: TankBounds {
                min: t.min,
                max: t.max,
            },
            time_s: w.time() as f32,
            props: &self.props,
            overlay: &[],
            look: Look::default(),
        }
    }

    /// A camera that frames the tank (the window's start view).
    pub fn default_camera(&self) -> Camera {
        let t = self.sim.world().tank();
        let size = t.max - t.min;
        Camera {
            target: (t.min + t.max) * 0.5 - Vec3::Y * size.y * 0.1,
            yaw_rad: 0.35,
            pitch_rad: 0.2,
            distance: size.x.max(size.z) * 0.75,
            fov_y_rad: 50f32.to_radians(),
        }
    }

    /// Number of live fish.
    pub fn num_fish(&self) -> usize {
        self.sim.world().num_fish()
    }

    /// Simulated time, seconds.
    pub fn time_s(&self) -> f32 {
        self.sim.world().time() as f32
    }

    /// Bounding sphere of a fish; `None` once it is gone.
    pub fn fish_info(&self, id: FishId) -> Option<FishInfo> {
        let w = self.sim.world();
        let root = w.root(id)?;
        let l = w.species(w.species_of(id)?).body_length();
        Some(FishInfo {
            center: root.pos - root.forward() * l * 0.5,
            radius: l * 0.6,
        })
    }

    /// Highlights `fish` (or none) from now on.
    pub fn set_selected(&mut self, fish: Option<FishId>) {
        if fish == self.selected {
            return;
        }
        self.selected = fish;
        let ids = self.sim.world().fish_id_slice();
        for (inst, id) in self.instances.iter_mut().zip(ids) {
            inst.selected = fish == Some(*id);
        }
        self.instances_revision = shoal_render::next_instances_revision();
    }

    /// The highlighted fish.
    pub fn selected(&self) -> Option<FishId> {
        self.selected
    }

    /// Species names, in species order.
    pub fn species_names(&self) -> Vec<String> {
        let w = self.sim.world();
        (0..w.num_species())
            .map(|i| w.species(SpeciesId(i as u16)).desc.name.clone())
            .collect()
    }

    /// Species index of a fish.
    pub fn species_of(&self, id: FishId) -> Option<usize> {
        self.sim.world().species_of(id).map(|s| usize::from(s.0))
    }

    /// A species' motion parameters.
    pub fn motion_params(&self, species: usize) -> Option<MotionParams> {
        self.species_at(species).map(|s| s.desc.motion)
    }

    fn species_at(&self, species: usize) -> Option<&Species> {
        let id = SpeciesId(u16::try_from(species).ok()?);
        self.sim.world().try_species(id)
    }

    /// Replaces a species' motion parameters (validated first); its swimming fish use them at
    /// once.
    pub fn set_motion_params(
        &mut self,
        species: usize,
        params: MotionParams,
    ) -> Result<(), SimError> {
        params.validate()?;
        let mut s = self
            .species_at(species)
            .ok_or(SimError::NoSpecies(species))?
            .clone();
        s.desc.motion = params;
        let id = SpeciesId(species as u16); // in range: `species_at` found it
        self.sim.world_mut().replace_species(id, s)?;
        Ok(())
    }

    /// Starts `request` on fish `id` now, interrupting what it was doing.
    pub fn request_motion(&mut self, id: FishId, request: MotionRequest) -> Result<(), SimError> {
        let w = self.sim.world_mut();
        if !w.is_alive(id) {
            return Err(SimError::NoFish(id));
        }
        Ok(w.request(id, request, true)?)
    }

    /// Drops a food pellet at `pos` (as a scene's drops do: it then sinks and dissolves as the
    /// scene says).
    pub fn drop_food(&mut self, pos: Vec3) -> FoodId {
        self.sim.world_mut().add_food(pos)
    }

    /// Writes the fish's body wave as `(position along body 0..1, lateral displacement in
    /// length units)` pairs, head first (nothing once the fish is gone).
    pub fn body_wave(&self, id: FishId, out: &mut Vec<[f64; 2]>) {
        out.clear();
        let w = self.sim.world();
        let (Some(lateral), Some(species)) = (w.lateral(id), w.species_of(id)) else {
            return;
        };
        let body = &w.species(species).rig.body;
        for (x, l) in body.joints_x.iter().zip(lateral) {
            out.push([f64::from(*x), f64::from(l)]);
        }
    }

    /// Key/value lines about a fish: species, motion, behaviour, intention, percepts (empty
    /// once the fish is gone).
    pub fn inspect(&self, id: FishId) -> Vec<(String, String)> {
        if self.sim.world().is_alive(id) {
            self.sim.inspect(id)
        } else {
            Vec::new()
        }
    }

    /// Appends the overlay segments asked for, for every fish.
    pub fn overlay_lines(&self, toggles: OverlayToggles, out: &mut Vec<OverlayLine>) {
        let w = self.sim.world();
        for &id in w.fish_id_slice() {
            let (Some(root), Some(sid)) = (w.root(id), w.species_of(id)) else {
                continue;
            };
            let fish = FishOverlay {
                world: w,
                id,
                root,
                species: w.species(sid),
                draw: &self.species[usize::from(sid.0)],
            };
            if toggles.skeleton {
                fish.skeleton(out);
            }
            if toggles.midline {
                fish.midline(out);
            }
            if toggles.velocity {
                fish.velocity(out);
            }
            if toggles.sensors {
                fish.sensors(out);
            }
        }
    }

    /// Starts watching the scene's scripts for edits (the window calls this; headless renders
    /// do not, so they stay deterministic).
    pub fn enable_hot_reload(&mut self) -> Result<(), SimError> {
        self.hot_reload = true;
        self.sim.watch()
    }

    /// Puts the simulation back to `state`, then runs `ticks` more ticks (a scrub lands between
    /// two kept states this way). Log lines of those ticks are dropped: they were shown when
    /// the moment was first run. Nothing else carries over (a part-tick of time is dropped).
    pub fn rewind_to(&mut self, state: &SimState, ticks: u64) -> Result<(), SimError> {
        self.sim.restore(state)?;
        for _ in 0..ticks {
            self.sim.tick();
        }
        drop(self.sim.drain_log());
        self.accumulator_s = 0.0;
        self.rebuild_instances();
        Ok(())
    }

    /// Moves log lines (script errors, warnings, reloads) into `out`.
    pub fn drain_log(&mut self, out: &mut Vec<LogLine>) {
        out.append(&mut self.reload_log);
        out.extend(self.sim.drain_log());
    }

    /// True when the scene's own file was edited since it was loaded (the panel offers a
    /// restart).
    pub fn scene_changed(&self) -> bool {
        self.sim.scene_changed()
    }

    /// Reloads the scene file and starts it again, with nothing selected. `Ok(true)` means the
    /// species (and so the meshes of [`WorldScene::meshes`]) may have changed and must be
    /// uploaded again.
    pub fn restart_scene(&mut self) -> Result<bool, SimError> {
        self.sim.restart_scene()?;
        self.sim.world_mut().set_pose_mode(self.pose_mode);
        self.sim.world_mut().update_pose();
        self.species = Self::species_draws(self.sim.world());
        self.selected = None;
        self.accumulator_s = 0.0;
        self.rebuild_instances();
        Ok(true)
    }

    /// Named simulation stage timings of the last step, milliseconds.
    pub fn stage_timings_ms(&self) -> Vec<(&'static str, f32)> {
        let c = self.sim.world().counters();
        let ms = |ns: u64| ns as f32 * 1e-6;
        vec![
            ("frame's ticks (all stages)", self.step_ms),
            ("schedule (who decides)", ms(c.schedule_ns)),
            ("perception (last tick)", ms(c.perception_ns)),
            ("behaviour / Lua", ms(c.lua_ns)),
            ("motion", ms(c.motion_ns)),
            ("skeleton", ms(c.skeleton_ns)),
            (
                if self.sim.world().poses_on_gpu() {
                    "pose records (the GPU poses)"
                } else {
                    "palettes"
                },
                ms(c.palette_ns),
            ),
            ("grid", ms(c.grid_ns)),
        ]
    }
}

/// One fish's overlays (see [`OverlayToggles`]).
struct FishOverlay<'a> {
    world: &'a World,
    id: FishId,
    root: &'a RootState,
    species: &'a Species,
    draw: &'a SpeciesDraw,
}

impl FishOverlay<'_> {
    /// Bones and joint crosses, from the fish's per-joint palette (made here when the GPU
    /// poses the fish).
    fn skeleton(&self, out: &mut Vec<OverlayLine>) {
        let mut palette = Vec::new();
        if !self.world.joint_palette(self.id, &mut palette) {
            return;
        }
        let joint = |j: usize| {
            palette.get(j).map_or(Vec3::ZERO, |m: &Mat4| {
                m.transform_point3(self.draw.bind_joint_pos[j])
            })
        };
        OverlayLine::push_skeleton(out, self.draw.model.skeleton.parents(), joint, 0.6);
    }

    /// The motion layer's midline: lateral offsets from the travel line.
    fn midline(&self, out: &mut Vec<OverlayLine>) {
        let Some(lateral) = self.world.lateral(self.id) else {
            return;
        };
        let (root, l) = (self.root, self.species.body_length());
        let point = |x: f32, lat: f32| {
            root.pos - root.forward() * x * l + root.left() * lat + Vec3::Y * 0.3
        };
        let mut prev = root.pos;
        for (x, lat) in self.species.rig.body.joints_x.iter().zip(lateral) {
            let next = point(*x, lat);
            out.push(OverlayLine {
                a: prev,
                b: next,
                color: [0.2, 1.0, 1.0, 1.0],
            });
            prev = next;
        }
    }

    /// Velocity (green, one second of travel) and heading (white) arrows.
    fn velocity(&self, out: &mut Vec<OverlayLine>) {
        let root = self.root;
        out.push(OverlayLine {
            a: root.pos,
            b: root.pos + root.forward() * root.speed,
            color: [0.3, 1.0, 0.3, 1.0],
        });
        let h = Vec3::new(root.heading.cos(), 0.0, -root.heading.sin());
        out.push(OverlayLine {
            a: root.pos,
            b: root.pos + h * self.species.body_length() * 0.4,
            color: [1.0, 1.0, 1.0, 1.0],
        });
    }

    /// The species' view range as a horizontal circle.
    fn sensors(&self, out: &mut Vec<OverlayLine>) {
        let (pos, r) = (self.root.pos, self.species.desc.view_range);
        let n = 32;
        for k in 0..n {
            let a0 = TAU * k as f32 / n as f32;
            let a1 = TAU * (k + 1) as f32 / n as f32;
            out.push(OverlayLine {
                a: pos + Vec3::new(a0.cos(), 0.0, a0.sin()) * r,
                b: pos + Vec3::new(a1.cos(), 0.0, a1.sin()) * r,
                color: [1.0, 0.4, 1.0, 0.6],
            });
        }
    }
}

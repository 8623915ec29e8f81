//! [`WorldScene`]: the [`SceneDriver`] for the real simulation — the world (motion, skeleton,
//! palettes) driven either by the Lua behaviour host ([`crate::script::Simulation`]) or by the
//! built-in Rust wander driver ([`crate::world::bench::RustSim`]).
//!
//! The renderer reads the world's flat palette buffer as is: one instance per fish with
//! `palette_offset = world.palette_offsets()[i]` and `mesh = MeshId(species index)`.

use std::f32::consts::TAU;
use std::sync::Arc;
use std::time::Instant;

use glam::{Mat4, Vec3};

use super::props::PropMesh;
use super::{
    Camera, FishInfo, FishInstance, FrameInput, Look, MeshId, MeshUpload, OverlayLine,
    OverlayToggles, Prop, SceneDriver, TankBounds,
};
use crate::motion::{MotionParams, MotionRequest};
use crate::script::Simulation;
use crate::world::bench::RustSim;
use crate::world::{FishId, FishModel, SpeciesId, TICK_HZ, World};

/// A simulation the window and `shoal render` can drive: one fixed tick at a time.
pub trait WorldSim {
    /// Runs one tick (1 / [`TICK_HZ`] s): behaviour, motion, pose, grid.
    fn tick(&mut self);
    /// The world.
    fn world(&self) -> &World;
    /// The world, mutably (motion requests, species edits).
    fn world_mut(&mut self) -> &mut World;
    /// Inspector lines for a fish (species, behaviour, intention, percepts …).
    fn inspect(&self, id: FishId) -> Vec<(String, String)> {
        let w = self.world();
        let mut out = Vec::new();
        if let Some(s) = w.species_of(id) {
            out.push(("species".into(), w.species(s).desc.name.clone()));
        }
        out.push((
            "motion".into(),
            w.current_motion(id).unwrap_or("idle").to_owned(),
        ));
        out
    }
    /// Log lines (script errors, prints) since the last call.
    fn drain_log(&mut self) -> Vec<String> {
        Vec::new()
    }
    /// Starts watching script files for edits (see [`WorldSim::poll_reload`]).
    fn watch(&mut self) -> Result<(), String> {
        Ok(())
    }
    /// Applies edited scripts; one console line per reload event.
    fn poll_reload(&mut self) -> Vec<String> {
        Vec::new()
    }
    /// True when the scene file was edited since it was loaded.
    fn scene_changed(&self) -> bool {
        false
    }
    /// Reloads the scene file and starts it again.
    fn restart_scene(&mut self) -> Result<(), String> {
        Err("this simulation has no scene file".into())
    }
}

impl WorldSim for Simulation {
    fn tick(&mut self) {
        self.step();
    }
    fn world(&self) -> &World {
        Simulation::world(self)
    }
    fn world_mut(&mut self) -> &mut World {
        Simulation::world_mut(self)
    }
    fn inspect(&self, id: FishId) -> Vec<(String, String)> {
        Simulation::inspect(self, id)
    }
    fn drain_log(&mut self) -> Vec<String> {
        Simulation::drain_log(self)
            .into_iter()
            .map(|e| e.to_string())
            .collect()
    }
    fn watch(&mut self) -> Result<(), String> {
        Simulation::watch(self).map_err(|e| e.to_string())
    }
    fn poll_reload(&mut self) -> Vec<String> {
        Simulation::poll_reload(self)
            .into_iter()
            .map(|e| e.to_string())
            .collect()
    }
    fn scene_changed(&self) -> bool {
        Simulation::scene_changed(self)
    }
    fn restart_scene(&mut self) -> Result<(), String> {
        Simulation::restart_scene(self).map_err(|e| e.to_string())
    }
}

impl WorldSim for RustSim {
    fn tick(&mut self) {
        RustSim::tick(self);
    }
    fn world(&self) -> &World {
        RustSim::world(self)
    }
    fn world_mut(&mut self) -> &mut World {
        RustSim::world_mut(self)
    }
}

/// Per species: what the overlays need from its model.
#[derive(Debug, Clone)]
struct SpeciesDraw {
    model: Arc<FishModel>,
    /// Each joint's bind-pose position in model space (inverse of its inverse bind matrix).
    bind_joint_pos: Vec<Vec3>,
}

/// A [`SceneDriver`] over a [`WorldSim`]: fixed 60 Hz ticks, real meshes, real palettes.
pub struct WorldScene<S: WorldSim> {
    sim: S,
    species: Vec<SpeciesDraw>,
    instances: Vec<FishInstance>,
    rock: PropMesh,
    pellet: PropMesh,
    props: Vec<Prop>,
    selected: Option<usize>,
    accumulator_s: f64,
    step_ms: f32,
    look: Look,
    hot_reload: bool,
    reload_log: Vec<String>,
}

impl<S: WorldSim> std::fmt::Debug for WorldScene<S> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("WorldScene")
            .field("fish", &self.sim.world().num_fish())
            .field("species", &self.species.len())
            .finish()
    }
}

/// Radius of a drawn food pellet, length units.
pub const FOOD_PELLET_RADIUS: f32 = 2.5;

impl<S: WorldSim> WorldScene<S> {
    /// Wraps a simulation whose species are all loaded (meshes are uploaded once at start).
    pub fn new(mut sim: S) -> Self {
        // Palettes exist only after a pose pass; a fresh world has not run one.
        sim.world_mut().update_pose();
        let species = Self::species_draws(sim.world());
        let mut scene = Self {
            sim,
            species,
            instances: Vec::new(),
            rock: PropMesh::rock(),
            pellet: PropMesh::pellet(),
            props: Vec::new(),
            selected: None,
            accumulator_s: 0.0,
            step_ms: 0.0,
            look: Look::default(),
            hot_reload: false,
            reload_log: Vec::new(),
        };
        scene.rebuild_instances();
        scene
    }

    fn species_draws(w: &World) -> Vec<SpeciesDraw> {
        (0..w.num_species())
            .map(|i| {
                let model = w.species(SpeciesId(i as u16)).model.clone();
                let bind_joint_pos = model
                    .inverse_bind_poses
                    .iter()
                    .map(|ibm| ibm.inverse().w_axis.truncate())
                    .collect();
                SpeciesDraw {
                    model,
                    bind_joint_pos,
                }
            })
            .collect()
    }

    /// The simulation.
    pub fn sim(&self) -> &S {
        &self.sim
    }

    /// The simulation, mutably.
    pub fn sim_mut(&mut self) -> &mut S {
        &mut self.sim
    }

    /// Water and light settings used by [`SceneDriver::frame_input`].
    pub fn set_look(&mut self, look: Look) {
        self.look = look;
    }

    fn id(&self, fish: usize) -> Option<FishId> {
        self.sim.world().fish_id_slice().get(fish).copied()
    }

    fn rebuild_instances(&mut self) {
        let w = self.sim.world();
        // Props: rocks for the sphere obstacles, pellets for uneaten food (mesh ids after the
        // species' meshes, see `meshes`).
        let rock = MeshId(self.species.len() as u32);
        let pellet = MeshId(self.species.len() as u32 + 1);
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
                self.props.push(Prop {
                    mesh: pellet,
                    transform: Mat4::from_scale_rotation_translation(
                        Vec3::splat(FOOD_PELLET_RADIUS),
                        glam::Quat::IDENTITY,
                        food.pos,
                    ),
                    tint: [1.0; 3],
                });
            }
        }
        self.instances.clear();
        for (i, (offset, species)) in w.palette_offsets().iter().zip(w.fish_species()).enumerate() {
            self.instances.push(FishInstance {
                mesh: MeshId(u32::from(species.0)),
                palette_offset: *offset,
                tint: [1.0; 3],
                selected: self.selected == Some(i),
            });
        }
    }
}

impl<S: WorldSim> SceneDriver for WorldScene<S> {
    fn meshes(&self) -> Vec<MeshUpload<'_>> {
        let w = self.sim.world();
        let mut meshes: Vec<MeshUpload<'_>> = self
            .species
            .iter()
            .enumerate()
            .map(|(i, s)| {
                MeshUpload::from_skinned_mesh(
                    &w.species(SpeciesId(i as u16)).desc.name,
                    &s.model.mesh,
                )
            })
            .collect();
        meshes.push(self.rock.upload());
        meshes.push(self.pellet.upload());
        meshes
    }

    fn step(&mut self, dt_s: f32) {
        let start = Instant::now();
        if self.hot_reload {
            let events = self.sim.poll_reload();
            self.reload_log.extend(events);
        }
        if dt_s.is_finite() && dt_s > 0.0 {
            self.accumulator_s += f64::from(dt_s);
        }
        // Every due tick runs: `shoal render --fps 4` simulates 15 ticks a frame. The window
        // bounds a frame's real time instead (see `render::app`), so a slow frame cannot spiral.
        let tick = 1.0 / TICK_HZ;
        while self.accumulator_s >= tick - 1e-9 {
            self.sim.tick();
            self.accumulator_s -= tick;
        }
        self.rebuild_instances();
        self.step_ms = start.elapsed().as_secs_f32() * 1e3;
    }

    fn frame_input(&self) -> FrameInput<'_> {
        let w = self.sim.world();
        let t = w.tank();
        FrameInput {
            palettes: w.palettes(),
            instances: &self.instances,
            camera: self.default_camera(),
            tank: TankBounds {
                min: t.min,
                max: t.max,
            },
            time_s: w.time() as f32,
            props: &self.props,
            overlay: &[],
            look: self.look,
        }
    }

    fn default_camera(&self) -> Camera {
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

    fn num_fish(&self) -> usize {
        self.sim.world().num_fish()
    }

    fn time_s(&self) -> f32 {
        self.sim.world().time() as f32
    }

    fn fish_info(&self, fish: usize) -> Option<FishInfo> {
        let w = self.sim.world();
        let id = self.id(fish)?;
        let root = w.root(id)?;
        let l = w.species(w.species_of(id)?).body_length();
        Some(FishInfo {
            center: root.pos - root.forward() * l * 0.5,
            radius: l * 0.6,
        })
    }

    fn set_selected(&mut self, fish: Option<usize>) {
        self.selected = fish;
        for (i, inst) in self.instances.iter_mut().enumerate() {
            inst.selected = fish == Some(i);
        }
    }

    fn species_names(&self) -> Vec<String> {
        let w = self.sim.world();
        (0..w.num_species())
            .map(|i| w.species(SpeciesId(i as u16)).desc.name.clone())
            .collect()
    }

    fn species_of(&self, fish: usize) -> Option<usize> {
        let id = self.id(fish)?;
        self.sim.world().species_of(id).map(|s| usize::from(s.0))
    }

    fn motion_params(&self, species: usize) -> Option<MotionParams> {
        let w = self.sim.world();
        w.try_species(SpeciesId(u16::try_from(species).ok()?))
            .map(|s| s.desc.motion)
    }

    fn set_motion_params(&mut self, species: usize, params: MotionParams) -> Result<(), String> {
        params.validate().map_err(|e| e.to_string())?;
        let id = SpeciesId(u16::try_from(species).map_err(|_| format!("no species {species}"))?);
        let w = self.sim.world_mut();
        let mut s = w
            .try_species(id)
            .ok_or_else(|| format!("no species {species}"))?
            .clone();
        s.desc.motion = params;
        w.replace_species(id, s).map_err(|e| e.to_string())
    }

    fn request_motion(&mut self, fish: usize, request: MotionRequest) -> Result<(), String> {
        let id = self.id(fish).ok_or_else(|| format!("no fish {fish}"))?;
        self.sim
            .world_mut()
            .request(id, request, true)
            .map_err(|e| e.to_string())
    }

    fn body_wave(&self, fish: usize, out: &mut Vec<[f64; 2]>) {
        out.clear();
        let w = self.sim.world();
        let Some(id) = self.id(fish) else { return };
        let (Some(lateral), Some(species)) = (w.lateral(id), w.species_of(id)) else {
            return;
        };
        let body = &w.species(species).rig.body;
        for (x, l) in body.joints_x.iter().zip(lateral) {
            out.push([f64::from(*x), f64::from(*l)]);
        }
    }

    fn inspect(&self, fish: usize, out: &mut Vec<(String, String)>) {
        out.clear();
        if let Some(id) = self.id(fish) {
            *out = self.sim.inspect(id);
        }
    }

    fn overlay_lines(&self, toggles: OverlayToggles, out: &mut Vec<OverlayLine>) {
        let w = self.sim.world();
        let palettes = w.palettes();
        for (i, &id) in w.fish_id_slice().iter().enumerate() {
            let (Some(root), Some(sid)) = (w.root(id), w.species_of(id)) else {
                continue;
            };
            let species = w.species(sid);
            let draw = &self.species[usize::from(sid.0)];
            let base = w.palette_offsets()[i] as usize;
            let joint = |j: usize| {
                palettes.get(base + j).map_or(Vec3::ZERO, |m: &Mat4| {
                    m.transform_point3(draw.bind_joint_pos[j])
                })
            };
            if toggles.skeleton {
                OverlayLine::push_skeleton(out, draw.model.skeleton.parents(), joint, 0.6);
            }
            let l = species.body_length();
            if toggles.midline
                && let Some(lateral) = w.lateral(id)
            {
                let point = |x: f32, lat: f32| {
                    root.pos - root.forward() * x * l + root.left() * lat + Vec3::Y * 0.3
                };
                let mut prev = root.pos;
                for (x, lat) in species.rig.body.joints_x.iter().zip(lateral) {
                    let next = point(*x, *lat);
                    out.push(OverlayLine {
                        a: prev,
                        b: next,
                        color: [0.2, 1.0, 1.0, 1.0],
                    });
                    prev = next;
                }
            }
            if toggles.velocity {
                out.push(OverlayLine {
                    a: root.pos,
                    b: root.pos + root.forward() * root.speed,
                    color: [0.3, 1.0, 0.3, 1.0],
                });
                let h = Vec3::new(root.heading.cos(), 0.0, -root.heading.sin());
                out.push(OverlayLine {
                    a: root.pos,
                    b: root.pos + h * l * 0.4,
                    color: [1.0, 1.0, 1.0, 1.0],
                });
            }
            if toggles.sensors {
                let r = species.desc.view_range;
                let n = 32;
                for k in 0..n {
                    let a0 = TAU * k as f32 / n as f32;
                    let a1 = TAU * (k + 1) as f32 / n as f32;
                    out.push(OverlayLine {
                        a: root.pos + Vec3::new(a0.cos(), 0.0, a0.sin()) * r,
                        b: root.pos + Vec3::new(a1.cos(), 0.0, a1.sin()) * r,
                        color: [1.0, 0.4, 1.0, 0.6],
                    });
                }
            }
        }
    }

    fn drain_log(&mut self, out: &mut Vec<String>) {
        out.append(&mut self.reload_log);
        out.extend(self.sim.drain_log());
    }

    fn enable_hot_reload(&mut self) -> Result<(), String> {
        self.hot_reload = true;
        self.sim.watch()
    }

    fn scene_changed(&self) -> bool {
        self.sim.scene_changed()
    }

    fn restart_scene(&mut self) -> Result<bool, String> {
        self.sim.restart_scene()?;
        self.sim.world_mut().update_pose();
        self.species = Self::species_draws(self.sim.world());
        self.selected = None;
        self.accumulator_s = 0.0;
        self.rebuild_instances();
        Ok(true)
    }

    fn stage_timings_ms(&self) -> Vec<(&'static str, f32)> {
        let c = self.sim.world().counters();
        let ms = |ns: u64| ns as f32 * 1e-6;
        vec![
            ("frame's ticks (all stages)", self.step_ms),
            ("perception (last tick)", ms(c.perception_ns)),
            ("behaviour / Lua", ms(c.lua_ns)),
            ("motion", ms(c.motion_ns)),
            ("skeleton", ms(c.skeleton_ns)),
            ("palettes", ms(c.palette_ns)),
            ("grid", ms(c.grid_ns)),
        ]
    }
}

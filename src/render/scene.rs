//! The seam between the simulation and the renderer/window: [`SceneDriver`], and [`DemoScene`],
//! a self-contained scene (procedural fish on the real motion layer) used until the world layer
//! plugs in.
//!
//! Plugging in the world (a sketch for the integrator): wrap the simulation in a struct that
//! owns the `FishModel` of every species and a `Vec<FishInstance>` rebuilt after each tick, and
//! implement [`SceneDriver`]:
//! - `meshes()` → `MeshUpload::from_skinned_mesh(name, &model.mesh)` per species, in
//!   `SpeciesId` order (so `MeshId(species.0 as u32)`);
//! - `step(dt)` → the fixed-tick simulation (accumulate `dt`, run `TICK_HZ` ticks), then rebuild
//!   the instances: one per `fish_ids()` entry, `palette_offset = palette_range(id).start`;
//! - `frame_input()` → `palettes: world.palettes()`, the instances, the tank and `world.time()`;
//! - `fish_info(i)` → root position and the species' body length for picking;
//! - `motion_params` / `set_motion_params` → the species' `SpeciesDesc.motion` (validated);
//! - `request_motion` → `world.request(id, request, true)`;
//! - `body_wave` → `world.lateral(id)` against the rig's `body.joints_x`;
//! - `inspect` → species, `current_motion`, `behavior_of`, intention and percepts from the host;
//! - `drain_log` → script errors; `stage_timings_ms` → `world.counters()`.

use std::f32::consts::{PI, TAU};
use std::time::Instant;

use glam::{Mat4, Quat, Vec3};
use rand::{Rng, SeedableRng};

use super::demo_rig::{DemoRig, PoseScratch};
use super::{Camera, FishInstance, FrameInput, Look, MeshId, MeshUpload, OverlayLine, TankBounds};
use crate::motion::{Body, MotionParams, MotionPlayer, MotionRequest, RootState, Side, TurnKind};
use crate::species::SpeciesDesc;

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
    /// True if any overlay is on.
    pub fn any(&self) -> bool {
        self.skeleton || self.midline || self.velocity || self.sensors
    }
}

/// What the renderer and the window need from a simulation. The world layer implements this;
/// [`DemoScene`] is the stand-in. Optional capabilities have do-nothing defaults.
pub trait SceneDriver {
    /// Every species' mesh, uploaded once at start; entry `i` becomes `MeshId(i)`.
    fn meshes(&self) -> Vec<MeshUpload<'_>>;
    /// Advances the simulation by `dt_s` seconds.
    fn step(&mut self, dt_s: f32);
    /// This frame's palettes, instances, tank and time. The caller sets `camera` and `overlay`.
    fn frame_input(&self) -> FrameInput<'_>;
    /// A camera that frames the scene.
    fn default_camera(&self) -> Camera {
        Camera::default()
    }
    /// Number of fish.
    fn num_fish(&self) -> usize;
    /// Simulated time, seconds.
    fn time_s(&self) -> f32 {
        self.frame_input().time_s
    }
    /// Bounding sphere of fish `fish`.
    fn fish_info(&self, fish: usize) -> Option<FishInfo>;
    /// Highlights `fish` (or none) in the instances it returns.
    fn set_selected(&mut self, _fish: Option<usize>) {}
    /// Species names, in species order.
    fn species_names(&self) -> Vec<String> {
        Vec::new()
    }
    /// Species index of a fish.
    fn species_of(&self, _fish: usize) -> Option<usize> {
        None
    }
    /// A species' motion parameters.
    fn motion_params(&self, _species: usize) -> Option<MotionParams> {
        None
    }
    /// Replaces a species' motion parameters; applies to its swimming fish at once.
    fn set_motion_params(&mut self, _species: usize, _params: MotionParams) -> Result<(), String> {
        Err("this scene has no tunable motion".into())
    }
    /// Starts `request` on `fish` now (interrupting what it was doing).
    fn request_motion(&mut self, _fish: usize, _request: MotionRequest) -> Result<(), String> {
        Err("this scene does not take motion requests".into())
    }
    /// Writes the fish's body wave as `(position along body 0..1, lateral displacement in
    /// length units)` pairs, head first.
    fn body_wave(&self, _fish: usize, out: &mut Vec<[f64; 2]>) {
        out.clear();
    }
    /// Key/value lines about a fish: species, motion, behaviour, intention, percepts.
    fn inspect(&self, _fish: usize, out: &mut Vec<(String, String)>) {
        out.clear();
    }
    /// Appends the overlay segments asked for.
    fn overlay_lines(&self, _toggles: OverlayToggles, _out: &mut Vec<OverlayLine>) {}
    /// Starts watching the scene's scripts for edits (the window calls this; headless renders
    /// do not, so they stay deterministic).
    fn enable_hot_reload(&mut self) -> Result<(), String> {
        Ok(())
    }
    /// Moves log lines (script errors, warnings) into `out`.
    fn drain_log(&mut self, _out: &mut Vec<String>) {}
    /// True when the scene's own file was edited since it was loaded (the panel offers a
    /// restart).
    fn scene_changed(&self) -> bool {
        false
    }
    /// Reloads the scene file and starts it again. `Ok(true)` means the species (and so the
    /// meshes of [`SceneDriver::meshes`]) may have changed and must be uploaded again.
    fn restart_scene(&mut self) -> Result<bool, String> {
        Err("this scene has no scene file to restart from".into())
    }
    /// Named simulation stage timings of the last step, milliseconds.
    fn stage_timings_ms(&self) -> Vec<(&'static str, f32)> {
        Vec::new()
    }
}

/// Settings of the demo scene (a `--scene` JSON file holds these; every field optional).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct DemoSceneConfig {
    /// Number of fish.
    pub fish: usize,
    /// Random seed (positions, headings, phases, wander).
    pub seed: u64,
    /// The tank.
    pub tank: TankBounds,
    /// The camera (defaults to a view of the whole tank).
    pub camera: Option<Camera>,
    /// Caustic strength (0 turns them off).
    pub caustics: f32,
    /// Which fish: `"porgy"` (the generated `assets/black_porgy.glb`, falling back to the
    /// procedural fish with a log line when it cannot load) or `"procedural"`.
    pub mesh: DemoMesh,
}

/// The fish model of a [`DemoScene`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DemoMesh {
    /// The generated black porgy asset.
    Porgy,
    /// The built-in procedural fish (no files needed).
    Procedural,
}

impl Default for DemoSceneConfig {
    fn default() -> Self {
        Self {
            fish: 24,
            seed: 1,
            tank: TankBounds::default(),
            camera: None,
            caustics: 1.0,
            mesh: DemoMesh::Porgy,
        }
    }
}

impl DemoSceneConfig {
    /// Reads a JSON scene file.
    pub fn load(path: &std::path::Path) -> Result<Self, String> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| format!("cannot read scene `{}`: {e}", path.display()))?;
        let cfg: Self =
            serde_json::from_str(&text).map_err(|e| format!("scene `{}`: {e}", path.display()))?;
        cfg.validate()
            .map_err(|e| format!("scene `{}`: {e}", path.display()))?;
        Ok(cfg)
    }

    /// Checks the tank is a proper box and numbers are finite.
    pub fn validate(&self) -> Result<(), String> {
        let s = self.tank.size();
        if !(s.x > 0.0 && s.y > 0.0 && s.z > 0.0 && s.is_finite()) {
            return Err(format!(
                "tank min {} must be below max {}",
                self.tank.min, self.tank.max
            ));
        }
        if !(self.caustics.is_finite() && self.caustics >= 0.0) {
            return Err(format!("caustics = {} must be ≥ 0", self.caustics));
        }
        if self.fish > 100_000 {
            return Err(format!("fish = {} is more than 100000", self.fish));
        }
        Ok(())
    }
}

#[derive(Debug, Clone)]
struct DemoFish {
    player: MotionPlayer,
    root: RootState,
    lateral: Vec<f32>,
    yaw: Vec<f32>,
    wander_s: f32,
    tint: f32,
}

/// A self-contained aquarium on the real motion layer: procedural porgy-like fish, each with a
/// [`MotionPlayer`] (eq. 2–7) fed by a tiny built-in behaviour (wander with normal turns, serial
/// turns away from walls, ascend/descend back to mid-water). Deterministic for a given config.
/// Stands in for the world and Lua layers until they plug into [`SceneDriver`].
#[derive(Debug)]
pub struct DemoScene {
    config: DemoSceneConfig,
    rig: DemoRig,
    body: Body,
    bind_joints: (Vec<Vec3>, Vec<u16>),
    scratch: PoseScratch,
    params: MotionParams,
    fish: Vec<DemoFish>,
    palettes: Vec<Mat4>,
    instances: Vec<FishInstance>,
    rng: rand_pcg::Pcg32,
    time_s: f32,
    selected: Option<usize>,
    log: Vec<String>,
    step_ms: f32,
}

/// Where the generated black porgy lives: `assets/black_porgy.glb` under the working directory
/// when it is there, else under the source tree.
pub fn porgy_asset_path() -> std::path::PathBuf {
    let local = std::path::PathBuf::from("assets/black_porgy.glb");
    if local.is_file() {
        local
    } else {
        std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets/black_porgy.glb")
    }
}

/// The demo's motion parameters: the black porgy preset at the procedural fish's length.
pub fn demo_params() -> MotionParams {
    MotionParams::BLACK_PORGY
}

impl DemoScene {
    /// Builds the scene.
    pub fn new(config: DemoSceneConfig) -> Self {
        let mut log = Vec::new();
        let rig = match config.mesh {
            DemoMesh::Procedural => DemoRig::procedural(),
            DemoMesh::Porgy => {
                let path = porgy_asset_path();
                match DemoRig::asset(&SpeciesDesc::black_porgy(), &path) {
                    Ok(rig) => rig,
                    Err(e) => {
                        log.push(format!("{e}; using the procedural fish"));
                        DemoRig::procedural()
                    }
                }
            }
        };
        Self::with_rig(config, rig, log)
    }

    /// Builds the scene with a given fish (e.g. [`DemoRig::asset`] of any rigged model;
    /// `config.mesh` is then ignored). `log` starts the scene's log.
    pub fn with_rig(config: DemoSceneConfig, rig: DemoRig, log: Vec<String>) -> Self {
        let nj = rig.num_joints();
        let body = rig.body().clone();
        let mut rng = rand_pcg::Pcg32::seed_from_u64(config.seed);
        let params = demo_params().with_length(rig.length());
        let t = config.tank;
        let margin = Vec3::new(90.0, 40.0, 90.0).min(t.size() * 0.3);
        let fish = (0..config.fish)
            .map(|_| {
                let pos = Vec3::new(
                    rng.random_range(t.min.x + margin.x..t.max.x - margin.x),
                    rng.random_range(t.min.y + margin.y..t.max.y - margin.y),
                    rng.random_range(t.min.z + margin.z..t.max.z - margin.z),
                );
                let speed = params.s * rng.random_range(0.6..1.1);
                let mut player = MotionPlayer::with_phase(rng.random_range(0.0..TAU));
                // In range by construction; a rejected request would only leave the fish idle.
                let _ = player.push(MotionRequest::Swim { speed });
                DemoFish {
                    player,
                    root: RootState {
                        pos,
                        heading: rng.random_range(0.0..TAU),
                        pitch: 0.0,
                        speed,
                    },
                    lateral: vec![0.0; body.joints_x.len()],
                    yaw: vec![0.0; body.num_joints()],
                    wander_s: rng.random_range(1.0..5.0),
                    tint: rng.random_range(0.85..1.15),
                }
            })
            .collect();
        let mut scene = Self {
            palettes: vec![Mat4::IDENTITY; config.fish * nj],
            instances: Vec::with_capacity(config.fish),
            config,
            bind_joints: rig.bind_joints(),
            scratch: rig.scratch(),
            rig,
            body,
            params,
            fish,
            rng,
            time_s: 0.0,
            selected: None,
            log,
            step_ms: 0.0,
        };
        // Settle every body into its wave before the first frame.
        for f in &mut scene.fish {
            let mut root = f.root;
            f.player.step(
                0.0,
                &scene.params,
                &scene.body,
                &mut root,
                &mut f.lateral,
                &mut f.yaw,
            );
        }
        scene.update_pose();
        scene
    }

    /// The fish model the demo draws.
    pub fn rig(&self) -> &DemoRig {
        &self.rig
    }

    /// Root transform of a fish including the head's recoil (see `MotionPlayer::head_yaw`).
    fn root_matrix(f: &DemoFish) -> Mat4 {
        let r = &f.root;
        Mat4::from_rotation_translation(
            Quat::from_rotation_y(r.heading + f.player.head_yaw()) * Quat::from_rotation_z(r.pitch),
            r.pos + r.left() * f.player.head_lateral(),
        )
    }

    fn update_pose(&mut self) {
        let nj = self.rig.num_joints();
        self.instances.clear();
        for (i, f) in self.fish.iter().enumerate() {
            self.rig.write_palette(
                Self::root_matrix(f),
                &f.yaw,
                &mut self.scratch,
                &mut self.palettes[i * nj..(i + 1) * nj],
            );
            let t = f.tint;
            self.instances.push(FishInstance {
                mesh: MeshId(0),
                palette_offset: (i * nj) as u32,
                tint: [t, t, t * 1.02],
                selected: self.selected == Some(i),
            });
        }
    }

    /// The built-in behaviour: keep off the walls, floor and surface; wander otherwise.
    fn behave(&mut self, dt: f32) {
        let tank = self.config.tank;
        let p = self.params;
        let len = self.rig.length();
        for f in &mut self.fish {
            f.wander_s -= dt;
            let name = f.player.current_name();
            let r = &f.root;
            let ahead = r.pos + r.forward() * (len * 2.5);
            let inset = len * 0.8;
            let outside = ahead.x < tank.min.x + inset
                || ahead.x > tank.max.x - inset
                || ahead.z < tank.min.z + inset
                || ahead.z > tank.max.z - inset;
            let turning = name.ends_with("turn");
            let busy = f.player.queue_len() > 0 || !matches!(name, "swim" | "idle");
            // A wall ahead cuts short a climb; anything else waits for the current motion.
            let wall_cut = outside && !turning;
            if (busy && !wall_cut) || (r.speed <= 0.0 && name == "idle") {
                continue;
            }
            let request = if outside {
                let to_center = tank.center() - r.pos;
                let desired = (-to_center.z).atan2(to_center.x);
                let delta = (desired - r.heading + PI).rem_euclid(TAU) - PI;
                let side = if delta >= 0.0 {
                    Side::Left
                } else {
                    Side::Right
                };
                // Close to the wall: a quick (halting, small-radius) turn; else a serial one.
                let near = len * 1.5;
                let close = r.pos.x < tank.min.x + near
                    || r.pos.x > tank.max.x - near
                    || r.pos.z < tank.min.z + near
                    || r.pos.z > tank.max.z - near;
                Some(MotionRequest::Turn {
                    kind: if close {
                        TurnKind::Quick
                    } else {
                        TurnKind::Serial
                    },
                    angle: delta.abs().clamp(0.5, PI),
                    side,
                })
            } else if r.pos.y < tank.min.y + len * 0.8 {
                Some(MotionRequest::Ascend { height: len })
            } else if r.pos.y > tank.max.y - len * 0.8 {
                Some(MotionRequest::Descend { depth: len })
            } else if f.wander_s <= 0.0 {
                f.wander_s = self.rng.random_range(3.0..8.0);
                let side = if self.rng.random_bool(0.5) {
                    Side::Left
                } else {
                    Side::Right
                };
                Some(MotionRequest::Turn {
                    kind: TurnKind::Normal,
                    angle: self.rng.random_range(0.3..1.0) * p.turn_angle,
                    side,
                })
            } else {
                None
            };
            let result = match request {
                Some(request) if busy => f.player.interrupt(request),
                Some(request) => f.player.push(request),
                None => Ok(()),
            };
            if let Err(e) = result {
                self.log.push(format!("demo behaviour: {e}"));
            }
        }
    }
}

impl SceneDriver for DemoScene {
    fn meshes(&self) -> Vec<MeshUpload<'_>> {
        vec![self.rig.upload()]
    }

    fn step(&mut self, dt_s: f32) {
        let start = Instant::now();
        let dt = if dt_s.is_finite() {
            dt_s.clamp(0.0, 0.25)
        } else {
            0.0
        };
        self.time_s += dt;
        self.behave(dt);
        let tank = self.config.tank;
        for f in &mut self.fish {
            f.player.step(
                dt,
                &self.params,
                &self.body,
                &mut f.root,
                &mut f.lateral,
                &mut f.yaw,
            );
            // The demo has no collision: keep roots inside the tank.
            f.root.pos = f.root.pos.clamp(tank.min, tank.max);
        }
        self.update_pose();
        self.step_ms = start.elapsed().as_secs_f32() * 1e3;
    }

    fn frame_input(&self) -> FrameInput<'_> {
        FrameInput {
            palettes: &self.palettes,
            instances: &self.instances,
            camera: self.default_camera(),
            tank: self.config.tank,
            time_s: self.time_s,
            props: &[],
            overlay: &[],
            look: Look {
                caustic_strength: self.config.caustics,
                ..Look::default()
            },
        }
    }

    fn default_camera(&self) -> Camera {
        if let Some(c) = self.config.camera {
            return c;
        }
        let t = self.config.tank;
        let size = t.size();
        Camera {
            target: t.center() - Vec3::Y * size.y * 0.1,
            yaw_rad: 0.35,
            pitch_rad: 0.2,
            distance: size.x.max(size.z) * 0.9,
            fov_y_rad: 50f32.to_radians(),
        }
    }

    fn num_fish(&self) -> usize {
        self.fish.len()
    }

    fn fish_info(&self, fish: usize) -> Option<FishInfo> {
        let f = self.fish.get(fish)?;
        Some(FishInfo {
            center: f.root.pos - f.root.forward() * self.rig.length() * 0.5,
            radius: self.rig.length() * 0.55,
        })
    }

    fn set_selected(&mut self, fish: Option<usize>) {
        self.selected = fish;
        for (i, inst) in self.instances.iter_mut().enumerate() {
            inst.selected = fish == Some(i);
        }
    }

    fn species_names(&self) -> Vec<String> {
        vec![self.rig.upload().label.to_owned()]
    }

    fn species_of(&self, fish: usize) -> Option<usize> {
        (fish < self.fish.len()).then_some(0)
    }

    fn motion_params(&self, species: usize) -> Option<MotionParams> {
        (species == 0).then_some(self.params)
    }

    fn set_motion_params(&mut self, species: usize, params: MotionParams) -> Result<(), String> {
        if species != 0 {
            return Err(format!("no species {species}"));
        }
        params.validate().map_err(|e| e.to_string())?;
        self.params = params;
        Ok(())
    }

    fn request_motion(&mut self, fish: usize, request: MotionRequest) -> Result<(), String> {
        let f = self
            .fish
            .get_mut(fish)
            .ok_or_else(|| format!("no fish {fish}"))?;
        f.player.interrupt(request).map_err(|e| e.to_string())
    }

    fn body_wave(&self, fish: usize, out: &mut Vec<[f64; 2]>) {
        out.clear();
        let Some(f) = self.fish.get(fish) else { return };
        out.push([0.0, f64::from(f.player.head_lateral())]);
        for (x, l) in self.body.joints_x.iter().zip(&f.lateral) {
            out.push([f64::from(*x), f64::from(*l)]);
        }
    }

    fn inspect(&self, fish: usize, out: &mut Vec<(String, String)>) {
        out.clear();
        let Some(f) = self.fish.get(fish) else { return };
        let r = &f.root;
        out.push(("species".into(), self.rig.upload().label.to_owned()));
        out.push(("motion".into(), f.player.current_name().into()));
        out.push(("queued".into(), f.player.queue_len().to_string()));
        out.push(("speed".into(), format!("{:.1} units/s", r.speed)));
        out.push((
            "heading".into(),
            format!("{:.0}°", r.heading.to_degrees().rem_euclid(360.0)),
        ));
        out.push(("pitch".into(), format!("{:.0}°", r.pitch.to_degrees())));
        out.push((
            "position".into(),
            format!("{:.0}, {:.0}, {:.0}", r.pos.x, r.pos.y, r.pos.z),
        ));
        out.push(("behaviour".into(), "built-in demo wander".into()));
    }

    fn overlay_lines(&self, toggles: OverlayToggles, out: &mut Vec<OverlayLine>) {
        let nj = self.rig.num_joints();
        let (bind_pos, parents) = &self.bind_joints;
        for (i, f) in self.fish.iter().enumerate() {
            let pal = &self.palettes[i * nj..(i + 1) * nj];
            let joint = |j: usize| pal[j].transform_point3(bind_pos[j]);
            if toggles.skeleton {
                OverlayLine::push_skeleton(out, &parents[..nj.min(parents.len())], joint, 0.8);
            }
            if toggles.midline {
                // The motion layer's midline: lateral offsets from the travel line.
                let r = &f.root;
                let point = |x: f32, lat: f32| {
                    r.pos - r.forward() * x * self.rig.length() + r.left() * lat + Vec3::Y * 0.5
                };
                let mut prev = point(0.0, f.player.head_lateral());
                for (x, lat) in self.body.joints_x.iter().zip(&f.lateral) {
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
                let r = &f.root;
                out.push(OverlayLine {
                    a: r.pos,
                    b: r.pos + r.forward() * r.speed,
                    color: [0.3, 1.0, 0.3, 1.0],
                });
                let h = Vec3::new(r.heading.cos(), 0.0, -r.heading.sin());
                out.push(OverlayLine {
                    a: r.pos,
                    b: r.pos + h * 20.0,
                    color: [1.0, 1.0, 1.0, 1.0],
                });
            }
            if toggles.sensors {
                let r = self.rig.length() * 3.0;
                let n = 32;
                for k in 0..n {
                    let a0 = TAU * k as f32 / n as f32;
                    let a1 = TAU * (k + 1) as f32 / n as f32;
                    out.push(OverlayLine {
                        a: f.root.pos + Vec3::new(a0.cos(), 0.0, a0.sin()) * r,
                        b: f.root.pos + Vec3::new(a1.cos(), 0.0, a1.sin()) * r,
                        color: [1.0, 0.4, 1.0, 0.6],
                    });
                }
            }
        }
    }

    fn drain_log(&mut self, out: &mut Vec<String>) {
        out.append(&mut self.log);
    }

    fn stage_timings_ms(&self) -> Vec<(&'static str, f32)> {
        vec![("simulation", self.step_ms)]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fish heading straight at a wall turns back into the tank instead of pressing on it.
    #[test]
    fn demo_fish_turns_away_from_the_wall() {
        let mut scene = DemoScene::new(DemoSceneConfig {
            fish: 1,
            ..DemoSceneConfig::default()
        });
        let tank = scene.config.tank;
        scene.fish[0].root.pos = Vec3::new(tank.max.x - 150.0, 120.0, 0.0);
        scene.fish[0].root.heading = 0.0;
        let mut max_x = f32::MIN;
        let mut trace = Vec::new();
        for i in 0..600 {
            scene.step(1.0 / 60.0);
            let r = scene.fish[0].root;
            max_x = max_x.max(r.pos.x);
            if i % 30 == 0 {
                trace.push((
                    scene.fish[0].player.current_name(),
                    r.pos.x,
                    r.heading,
                    r.speed,
                ));
            }
        }
        let r = scene.fish[0].root;
        assert!(
            max_x < tank.max.x - 5.0,
            "pressed on the wall: max x {max_x}\n{trace:?}"
        );
        assert!(
            r.pos.x < tank.max.x - 100.0,
            "did not come back: {r:?}\n{trace:?}"
        );
    }
}

//! The seam between the simulation and the renderer/window: [`SceneDriver`], and [`DemoScene`],
//! a self-contained scene (procedural fish, travelling-sine swimming) used until the world
//! layer plugs in.

use std::f32::consts::{PI, TAU};
use std::time::Instant;

use glam::{Mat4, Quat, Vec3};
use rand::{Rng, SeedableRng};

use super::testmesh::TestFish;
use super::{Camera, FishInstance, FrameInput, Look, MeshId, MeshUpload, OverlayLine, TankBounds};
use crate::motion::{MotionParams, MotionRequest, Side, TurnKind};

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
    /// Moves log lines (script errors, warnings) into `out`.
    fn drain_log(&mut self, _out: &mut Vec<String>) {}
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
}

impl Default for DemoSceneConfig {
    fn default() -> Self {
        Self {
            fish: 24,
            seed: 1,
            tank: TankBounds::default(),
            camera: None,
            caustics: 1.0,
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

#[derive(Debug, Clone, Copy)]
struct DemoFish {
    pos: Vec3,
    heading: f32,
    pitch: f32,
    speed: f32,
    target_speed: f32,
    accel_per_s: f32,
    phase: f32,
    turn_left_rad: f32,
    turn_rate: f32,
    turn_kind: Option<TurnKind>,
    target_y: Option<f32>,
    wander_s: f32,
    tint: f32,
    motion: &'static str,
}

/// A self-contained aquarium: procedural porgy-like fish swimming with a travelling sine wave
/// (amplitude, wavelength and frequency from [`MotionParams`]), wandering and turning away from
/// the walls. Deterministic for a given config.
#[derive(Debug)]
pub struct DemoScene {
    config: DemoSceneConfig,
    mesh: TestFish,
    params: MotionParams,
    fish: Vec<DemoFish>,
    palettes: Vec<Mat4>,
    instances: Vec<FishInstance>,
    yaws: Vec<f32>,
    rng: rand_pcg::Pcg32,
    time_s: f32,
    selected: Option<usize>,
    log: Vec<String>,
    step_ms: f32,
}

/// The demo's motion parameters (Table 1-like values for a 50-unit porgy).
pub fn demo_params() -> MotionParams {
    MotionParams {
        p: 0.2,
        s: 40.0,
        l: 50.0,
        max_amp: 7.0,
        lambda: 55.0,
        omega: TAU * 1.6,
        tt: 0.8,
        f: 1.5,
        turn_angle: PI / 2.0,
    }
}

impl DemoScene {
    /// Builds the scene.
    pub fn new(config: DemoSceneConfig) -> Self {
        let mesh = TestFish::demo();
        let mut rng = rand_pcg::Pcg32::seed_from_u64(config.seed);
        let params = demo_params();
        let t = config.tank;
        let margin = Vec3::new(40.0, 25.0, 40.0).min(t.size() * 0.25);
        let fish = (0..config.fish)
            .map(|_| {
                let pos = Vec3::new(
                    rng.random_range(t.min.x + margin.x..t.max.x - margin.x),
                    rng.random_range(t.min.y + margin.y..t.max.y - margin.y),
                    rng.random_range(t.min.z + margin.z..t.max.z - margin.z),
                );
                let speed = params.s * rng.random_range(0.7..1.2);
                DemoFish {
                    pos,
                    heading: rng.random_range(0.0..TAU),
                    pitch: 0.0,
                    speed,
                    target_speed: speed,
                    accel_per_s: params.s,
                    phase: rng.random_range(0.0..TAU),
                    turn_left_rad: 0.0,
                    turn_rate: 0.0,
                    turn_kind: None,
                    target_y: None,
                    wander_s: rng.random_range(1.0..4.0),
                    tint: rng.random_range(0.85..1.15),
                    motion: "swim",
                }
            })
            .collect();
        let nj = mesh.num_joints();
        let mut scene = Self {
            palettes: vec![Mat4::IDENTITY; config.fish * nj],
            instances: Vec::with_capacity(config.fish),
            yaws: vec![0.0; nj],
            config,
            mesh,
            params,
            fish,
            rng,
            time_s: 0.0,
            selected: None,
            log: Vec::new(),
            step_ms: 0.0,
        };
        scene.update_pose();
        scene
    }

    /// The procedural mesh the demo uses.
    pub fn mesh(&self) -> &TestFish {
        &self.mesh
    }

    fn forward(f: &DemoFish) -> Vec3 {
        Vec3::new(
            f.heading.cos() * f.pitch.cos(),
            f.pitch.sin(),
            -f.heading.sin() * f.pitch.cos(),
        )
    }

    fn root(f: &DemoFish) -> Mat4 {
        Mat4::from_rotation_translation(
            Quat::from_rotation_y(f.heading) * Quat::from_rotation_z(f.pitch),
            f.pos,
        )
    }

    /// Local joint yaws of a travelling wave y(x, t) = A(x)·sin(2πx/λ − φ), A(x) growing from
    /// the pivot p·l to maxAmp at the tail.
    fn wave_yaws(params: &MotionParams, length: f32, phase: f32, amp_scale: f32, yaws: &mut [f32]) {
        let n = yaws.len();
        let seg = length / n as f32;
        let mut prev = 0.0;
        for (j, yaw) in yaws.iter_mut().enumerate() {
            // Slope of the midline over bone j (from joint j to j+1).
            let lateral = |x: f32| {
                let a = ((x - params.p * length) / length).max(0.0) * params.max_amp * amp_scale;
                a * (TAU * x / params.lambda.max(1.0) - phase).sin()
            };
            let x0 = j as f32 * seg;
            let slope = (lateral(x0 + seg) - lateral(x0)) / seg;
            let angle = slope.atan();
            *yaw = angle - prev;
            prev = angle;
        }
    }

    fn update_pose(&mut self) {
        let nj = self.mesh.num_joints();
        self.instances.clear();
        for (i, f) in self.fish.iter().enumerate() {
            let amp = (f.speed / self.params.s.max(1e-3)).clamp(0.25, 1.6);
            Self::wave_yaws(&self.params, self.mesh.length, f.phase, amp, &mut self.yaws);
            if let Some(kind) = f.turn_kind {
                // Bend the whole body into the turn (F_nt/F_st stand-in).
                let bend = f.turn_rate.signum()
                    * if kind == TurnKind::Normal { 0.1 } else { 0.18 }
                    * self.params.f;
                for y in self.yaws.iter_mut().skip(1) {
                    *y += bend;
                }
            }
            self.mesh.palette(
                Self::root(f),
                &self.yaws,
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
}

impl SceneDriver for DemoScene {
    fn meshes(&self) -> Vec<MeshUpload<'_>> {
        vec![self.mesh.upload()]
    }

    fn step(&mut self, dt_s: f32) {
        let start = Instant::now();
        let dt = dt_s.clamp(0.0, 0.25);
        self.time_s += dt;
        let tank = self.config.tank;
        let p = self.params;
        let len = self.mesh.length;
        for f in &mut self.fish {
            // Speed towards target.
            let dv = (f.target_speed - f.speed).clamp(-f.accel_per_s * dt, f.accel_per_s * dt);
            f.speed += dv;
            if (f.target_speed - f.speed).abs() < 1e-3 {
                f.motion = if f.target_speed == 0.0 {
                    "idle"
                } else if f.turn_kind.is_none() && f.target_y.is_none() {
                    "swim"
                } else {
                    f.motion
                };
            }
            // Tail beat: frequency follows speed; a quick turn beats hard.
            let beat = (f.speed / p.s.max(1e-3)).clamp(0.2, 2.0)
                + if f.turn_kind == Some(TurnKind::Quick) {
                    1.0
                } else {
                    0.0
                };
            f.phase = (f.phase + p.omega * beat * dt).rem_euclid(TAU * 64.0);
            // Turning.
            if f.turn_kind.is_some() {
                let step = f.turn_rate * dt;
                if step.abs() >= f.turn_left_rad.abs() {
                    f.heading += f.turn_left_rad;
                    f.turn_left_rad = 0.0;
                    f.turn_kind = None;
                    if f.target_speed > 0.0 {
                        f.motion = "swim";
                    }
                } else {
                    f.heading += step;
                    f.turn_left_rad -= step;
                }
            }
            // Ascend/descend.
            if let Some(y) = f.target_y {
                let dy = y - f.pos.y;
                f.pitch = (dy * 0.02).clamp(-0.5, 0.5);
                if dy.abs() < 1.0 {
                    f.target_y = None;
                }
            } else {
                f.pitch *= (1.0 - 2.0 * dt).max(0.0);
            }
            // Stay in the tank: turn away from walls ahead, wander otherwise.
            let fwd = Self::forward(f);
            let ahead = f.pos + fwd * (len * 2.0 + f.speed);
            let inset = len * 0.6;
            let outside = ahead.x < tank.min.x + inset
                || ahead.x > tank.max.x - inset
                || ahead.z < tank.min.z + inset
                || ahead.z > tank.max.z - inset;
            f.wander_s -= dt;
            if f.turn_kind.is_none() && f.speed > 0.0 && (outside || f.wander_s <= 0.0) {
                let to_center = tank.center() - f.pos;
                let desired = (-to_center.z).atan2(to_center.x);
                let mut delta = (desired - f.heading + PI).rem_euclid(TAU) - PI;
                if !outside {
                    delta = self.rng.random_range(-1.0..1.0);
                }
                f.turn_kind = Some(if outside {
                    TurnKind::Serial
                } else {
                    TurnKind::Normal
                });
                f.turn_left_rad = delta;
                f.turn_rate = delta.signum() * p.turn_angle / p.tt.max(0.05) * 0.7;
                f.motion = if outside {
                    "serial_turn"
                } else {
                    "normal_turn"
                };
                f.wander_s = self.rng.random_range(2.0..6.0);
            }
            if f.target_y.is_none()
                && (f.pos.y < tank.min.y + len * 0.5 || f.pos.y > tank.max.y - len * 0.5)
            {
                f.target_y = Some(tank.center().y);
            }
            let fwd = Self::forward(f);
            f.pos += fwd * f.speed * dt;
            f.pos = f.pos.clamp(tank.min, tank.max);
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
            center: f.pos - Self::forward(f) * self.mesh.length * 0.5,
            radius: self.mesh.bounding_radius(),
        })
    }

    fn set_selected(&mut self, fish: Option<usize>) {
        self.selected = fish;
        for (i, inst) in self.instances.iter_mut().enumerate() {
            inst.selected = fish == Some(i);
        }
    }

    fn species_names(&self) -> Vec<String> {
        vec!["procedural porgy".into()]
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
        let fields = [
            ("p", params.p),
            ("s", params.s),
            ("l", params.l),
            ("maxAmp", params.max_amp),
            ("lambda", params.lambda),
            ("omega", params.omega),
            ("Tt", params.tt),
            ("f", params.f),
            ("turn angle", params.turn_angle),
        ];
        if let Some((name, v)) = fields.iter().find(|(_, v)| !v.is_finite() || *v < 0.0) {
            return Err(format!("{name} = {v} must be a finite number ≥ 0"));
        }
        let old_s = self.params.s;
        self.params = params;
        for f in &mut self.fish {
            if f.target_speed > 0.0 && old_s > 0.0 {
                f.target_speed *= params.s / old_s;
            }
        }
        Ok(())
    }

    fn request_motion(&mut self, fish: usize, request: MotionRequest) -> Result<(), String> {
        let p = self.params;
        let f = self
            .fish
            .get_mut(fish)
            .ok_or_else(|| format!("no fish {fish}"))?;
        match request {
            MotionRequest::Swim { speed } => {
                f.target_speed = speed.max(0.0);
                f.accel_per_s = p.s;
                f.motion = "swim";
            }
            MotionRequest::Accelerate { speed, duration } => {
                f.accel_per_s = (speed - f.speed).abs() / duration.max(0.05);
                f.target_speed = speed.max(0.0);
                f.motion = "accelerate";
            }
            MotionRequest::Stop { duration } => {
                f.accel_per_s = f.speed / duration.max(0.05);
                f.target_speed = 0.0;
                f.motion = "stop";
            }
            MotionRequest::Turn { kind, angle, side } => {
                let sign = -side.d();
                f.turn_kind = Some(kind);
                f.turn_left_rad = sign * angle;
                f.turn_rate = sign * angle / p.tt.max(0.05);
                f.motion = match kind {
                    TurnKind::Normal => "normal_turn",
                    TurnKind::Quick => "quick_turn",
                    TurnKind::Serial => "serial_turn",
                };
                if kind == TurnKind::Quick {
                    f.target_speed = f.target_speed.min(p.s * 0.3);
                }
            }
            MotionRequest::Ascend { height } => {
                f.target_y = Some((f.pos.y + height).min(self.config.tank.max.y - 20.0));
                f.motion = "ascend";
            }
            MotionRequest::Descend { depth } => {
                f.target_y = Some((f.pos.y - depth).max(self.config.tank.min.y + 20.0));
                f.motion = "descend";
            }
        }
        let _ = Side::Left;
        Ok(())
    }

    fn body_wave(&self, fish: usize, out: &mut Vec<[f64; 2]>) {
        out.clear();
        let Some(f) = self.fish.get(fish) else { return };
        let n = 40;
        let len = self.mesh.length;
        let amp = (f.speed / self.params.s.max(1e-3)).clamp(0.25, 1.6);
        for i in 0..=n {
            let x = len * i as f32 / n as f32;
            let a = ((x - self.params.p * len) / len).max(0.0) * self.params.max_amp * amp;
            let y = a * (TAU * x / self.params.lambda.max(1.0) - f.phase).sin();
            out.push([f64::from(x / len), f64::from(y)]);
        }
    }

    fn inspect(&self, fish: usize, out: &mut Vec<(String, String)>) {
        out.clear();
        let Some(f) = self.fish.get(fish) else { return };
        out.push(("species".into(), "procedural porgy".into()));
        out.push(("motion".into(), f.motion.into()));
        out.push(("speed".into(), format!("{:.1} units/s", f.speed)));
        out.push((
            "heading".into(),
            format!("{:.0}°", f.heading.to_degrees().rem_euclid(360.0)),
        ));
        out.push((
            "position".into(),
            format!("{:.0}, {:.0}, {:.0}", f.pos.x, f.pos.y, f.pos.z),
        ));
        out.push(("behaviour".into(), "(demo scene: none)".into()));
    }

    fn overlay_lines(&self, toggles: OverlayToggles, out: &mut Vec<OverlayLine>) {
        let nj = self.mesh.num_joints();
        let seg = self.mesh.length / nj as f32;
        for (i, f) in self.fish.iter().enumerate() {
            let pal = &self.palettes[i * nj..(i + 1) * nj];
            let joint = |j: usize| pal[j].transform_point3(Vec3::new(-(j as f32) * seg, 0.0, 0.0));
            let tail = pal[nj - 1].transform_point3(Vec3::new(-self.mesh.length, 0.0, 0.0));
            if toggles.skeleton {
                for j in 0..nj {
                    let a = joint(j);
                    let b = if j + 1 < nj { joint(j + 1) } else { tail };
                    out.push(OverlayLine {
                        a,
                        b,
                        color: [1.0, 0.85, 0.2, 1.0],
                    });
                    for d in [Vec3::X, Vec3::Y, Vec3::Z] {
                        out.push(OverlayLine {
                            a: a - d * 1.5,
                            b: a + d * 1.5,
                            color: [1.0, 0.3, 0.2, 1.0],
                        });
                    }
                }
            }
            if toggles.midline {
                let up = Vec3::Y * 0.5;
                for j in 0..nj {
                    let a = joint(j) + up;
                    let b = if j + 1 < nj { joint(j + 1) } else { tail } + up;
                    out.push(OverlayLine {
                        a,
                        b,
                        color: [0.2, 1.0, 1.0, 1.0],
                    });
                }
            }
            if toggles.velocity {
                let fwd = Self::forward(f);
                out.push(OverlayLine {
                    a: f.pos,
                    b: f.pos + fwd * f.speed,
                    color: [0.3, 1.0, 0.3, 1.0],
                });
                out.push(OverlayLine {
                    a: f.pos,
                    b: f.pos + fwd * 20.0 + Vec3::Y * 0.01,
                    color: [1.0, 1.0, 1.0, 1.0],
                });
            }
            if toggles.sensors {
                let r = self.mesh.length * 3.0;
                let n = 32;
                for k in 0..n {
                    let a0 = TAU * k as f32 / n as f32;
                    let a1 = TAU * (k + 1) as f32 / n as f32;
                    out.push(OverlayLine {
                        a: f.pos + Vec3::new(a0.cos(), 0.0, a0.sin()) * r,
                        b: f.pos + Vec3::new(a1.cos(), 0.0, a1.sin()) * r,
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

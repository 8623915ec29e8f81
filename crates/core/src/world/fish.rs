//! One fish as the behaviour layer sees it ([`FishRef`], resolved once), what its behaviour may
//! change while it decides ([`FishControls`]), and motion requests.

use glam::Vec3;
use rand::SeedableRng;
use rand_pcg::Pcg32;

use super::sense::wrap_angle;
use super::steer::{self, Agent, Steer, SteerMemo, SteerParams};
use super::types::finite;
use super::{CONTACT_MARGIN_LENGTHS, FishId, Species, SpeciesId, World, WorldError};
use crate::motion::{MotionPlayer, MotionRequest, RootState};

/// What a fish's behaviour may change while it decides, checked out of the world by
/// [`World::check_out`]: its motion player, its steering memo and its random generator.
pub struct FishControls {
    player: Box<MotionPlayer>,
    steer: SteerMemo,
    rng: Pcg32,
}

impl Default for FishControls {
    fn default() -> Self {
        Self {
            player: Box::new(MotionPlayer::new()),
            steer: SteerMemo::default(),
            rng: Pcg32::seed_from_u64(0),
        }
    }
}

impl FishControls {
    /// The fish's motion player (current motion, queue).
    pub fn player(&self) -> &MotionPlayer {
        &self.player
    }

    /// The fish's own random generator.
    pub fn rng(&mut self) -> &mut Pcg32 {
        &mut self.rng
    }
}

/// Rejects a request carrying NaN or infinity, naming the field.
fn validate_request(r: &MotionRequest) -> Result<(), WorldError> {
    match *r {
        MotionRequest::Swim { speed } => finite("swim speed", speed),
        MotionRequest::Accelerate { speed, duration } => {
            finite("accelerate speed", speed)?;
            finite("accelerate duration", duration)
        }
        MotionRequest::Stop { duration } => finite("stop duration", duration),
        MotionRequest::Turn { angle, .. } => finite("turn angle", angle),
        MotionRequest::Ascend { height } => finite("ascend height", height),
        MotionRequest::Descend { depth } => finite("descend depth", depth),
    }
}

/// One live fish, its handle resolved once: its state and species, and the steering helpers of
/// [`steer`] applied to it. Get one with [`World::fish`]; it borrows the world read-only, so
/// decisions of many fish can hold one each in parallel.
#[derive(Clone, Copy)]
pub struct FishRef<'w> {
    world: &'w World,
    id: FishId,
    /// Dense position in the fish arrays.
    d: usize,
}

impl World {
    /// The fish `id`, or `None` if it was despawned (or never spawned).
    pub fn fish(&self, id: FishId) -> Option<FishRef<'_>> {
        let d = self.state.fish.dense(id)?;
        Some(FishRef { world: self, id, d })
    }

    /// Moves what a fish's behaviour may change while it decides — its motion player, steering
    /// memo and random generator — out of the world into `controls` (swapping, so `controls`'
    /// previous contents wait in the world). With every deciding fish's controls checked out,
    /// decisions of different fish can run in parallel against a shared `&World` (script lanes);
    /// [`World::check_in`] puts them back. Until then the world's own copy of the fish's motion
    /// state is a stand-in: read it from `controls`. False if `id` is stale.
    pub fn check_out(&mut self, id: FishId, controls: &mut FishControls) -> bool {
        let Some(d) = self.state.fish.dense(id) else {
            return false;
        };
        let fish = &mut self.state.fish;
        std::mem::swap(&mut fish.players[d], &mut controls.player);
        std::mem::swap(&mut fish.steer[d], &mut controls.steer);
        std::mem::swap(&mut fish.rngs[d], &mut controls.rng);
        true
    }

    /// Puts back what [`World::check_out`] took (the same swap). False if `id` is stale.
    pub fn check_in(&mut self, id: FishId, controls: &mut FishControls) -> bool {
        self.check_out(id, controls)
    }

    /// Name of the motion a fish is playing (see `MotionPlayer::current_name`).
    pub fn current_motion(&self, id: FishId) -> Option<&'static str> {
        self.state
            .fish
            .dense(id)
            .map(|d| self.state.fish.players[d].current_name())
    }

    /// Number of motion requests queued behind the current one.
    pub fn queue_len(&self, id: FishId) -> Option<usize> {
        self.state
            .fish
            .dense(id)
            .map(|d| self.state.fish.players[d].queue_len())
    }

    /// The midline's lateral displacement at each of the species' `body.joints_x`, world units
    /// (derived from the fish's motion player when the GPU samples the shapes; see
    /// [`FishRef::lateral`]).
    pub fn lateral(&self, id: FishId) -> Option<Vec<f32>> {
        self.fish(id).map(|f| f.lateral())
    }

    /// Each driven joint's local yaw, radians (see [`FishRef::yaw`]).
    pub fn yaw(&self, id: FishId) -> Option<Vec<f32>> {
        self.fish(id).map(|f| f.yaw())
    }

    /// Gives a fish a motion request: queued behind what plays, or (with `interrupt`) now.
    /// NaN or infinite values are refused naming the field; the motion layer refuses the rest.
    pub fn request(
        &mut self,
        id: FishId,
        r: MotionRequest,
        interrupt: bool,
    ) -> Result<(), WorldError> {
        self.with_controls(id, |f, c| f.request(c, r, interrupt))
    }

    /// [`FishRef::steer_to`] for a fish whose controls are in the world.
    pub fn steer_to(
        &mut self,
        id: FishId,
        heading: f32,
        depth: f32,
        speed: f32,
    ) -> Result<(), WorldError> {
        self.with_controls(id, |f, c| f.steer_to(c, heading, depth, speed))
    }

    /// Runs `f` with the fish's controls checked out (for the `&mut self` conveniences).
    fn with_controls<R>(
        &mut self,
        id: FishId,
        f: impl FnOnce(FishRef<'_>, &mut FishControls) -> Result<R, WorldError>,
    ) -> Result<R, WorldError> {
        let mut c = FishControls::default();
        if !self.check_out(id, &mut c) {
            return Err(WorldError::StaleFish(id));
        }
        let fish = self.fish(id).ok_or(WorldError::StaleFish(id));
        let r = fish.and_then(|fish| f(fish, &mut c));
        self.check_in(id, &mut c);
        r
    }
}

impl<'w> FishRef<'w> {
    /// Its handle.
    pub fn id(&self) -> FishId {
        self.id
    }

    /// Its root state.
    pub fn root(&self) -> &'w RootState {
        &self.world.state.fish.roots[self.d]
    }

    /// Its species' id.
    pub fn species_id(&self) -> SpeciesId {
        self.world.state.fish.species[self.d]
    }

    /// Its species.
    pub fn species(&self) -> &'w Species {
        &self.world.catalog.species[usize::from(self.species_id().0)]
    }

    /// The behaviour script it runs.
    pub fn behavior(&self) -> Option<&'w str> {
        self.world.state.fish.behaviors[self.d].as_deref()
    }

    /// Whether it touched a wall, floor, surface or obstacle in the last motion step.
    pub fn contact(&self) -> bool {
        self.world.state.fish.contact[self.d]
    }

    /// The midline's lateral displacement at each of the species' `body.joints_x`, world units.
    /// As the last motion stage stored it, or, when that stage left the body's shape to the GPU
    /// pose pass, derived from the fish's motion player now (the same values).
    pub fn lateral(&self) -> Vec<f32> {
        let (n, _) = super::shape::shape_lens(&self.species().rig.body);
        self.world.shape_of(self.d).0[..n].to_vec()
    }

    /// Each driven joint's local yaw, radians (stored or derived, as [`FishRef::lateral`]).
    pub fn yaw(&self) -> Vec<f32> {
        let (_, n) = super::shape::shape_lens(&self.species().rig.body);
        self.world.shape_of(self.d).1[..n].to_vec()
    }

    /// The steering helpers' view of it (look-ahead one body length).
    pub fn agent(&self) -> Agent {
        let r = self.root();
        Agent {
            pos: r.pos,
            heading: r.heading,
            pitch: r.pitch,
            speed: r.speed,
            surface_y: self.world.state.tank.max.y,
            lookahead: self.species().body_length(),
        }
    }

    /// [`steer::seek`]: towards `target`.
    pub fn seek(&self, target: Vec3, speed: f32) -> Steer {
        steer::seek(&self.agent(), target, speed)
    }

    /// [`steer::flee`]: away from `threat`.
    pub fn flee(&self, threat: Vec3, speed: f32) -> Steer {
        steer::flee(&self.agent(), threat, speed)
    }

    /// [`steer::arrive`]: towards `target`, slowing inside `slow_radius`.
    pub fn arrive(&self, target: Vec3, slow_radius: f32, speed: f32) -> Steer {
        steer::arrive(&self.agent(), target, slow_radius, speed)
    }

    /// [`steer::wander`], drawing from the fish's own generator (in its checked-out controls).
    pub fn wander(
        &self,
        controls: &mut FishControls,
        max_turn: f32,
        max_depth_change: f32,
        speed: f32,
    ) -> Steer {
        steer::wander(
            &mut controls.rng,
            &self.agent(),
            max_turn,
            max_depth_change,
            speed,
        )
    }

    /// [`steer::avoid_obstacles`] against the world's rocks.
    pub fn avoid_obstacles(&self, lookahead: f32, clearance: f32, speed: f32) -> Option<Steer> {
        steer::avoid_obstacles(
            &self.agent(),
            &self.world.state.obstacles,
            lookahead,
            clearance,
            speed,
        )
    }

    /// [`steer::avoid_walls`] against the tank.
    pub fn avoid_walls(&self, margin: f32, speed: f32) -> Option<Steer> {
        steer::avoid_walls(&self.agent(), &self.world.state.tank, margin, speed)
    }

    /// Gives it a motion request through its checked-out `controls`: queued behind what plays,
    /// or (with `interrupt`) now. NaN or infinite values are refused naming the field; the
    /// motion layer refuses the rest.
    pub fn request(
        &self,
        controls: &mut FishControls,
        r: MotionRequest,
        interrupt: bool,
    ) -> Result<(), WorldError> {
        validate_request(&r)?;
        let player = &mut controls.player;
        if interrupt {
            player.interrupt(r)?;
        } else {
            player.push(r)?;
        }
        Ok(())
    }

    /// Steers towards a heading (radians), a depth below the surface (world units) and a speed
    /// (world units per second; clamped to the species' `max_speed`), through its checked-out
    /// `controls`, choosing the motion: small heading error → normal turn; large → quick turn
    /// when slow, serial turn when fast; then ascend/descend; then accelerate/stop. A wish
    /// already being carried out requests nothing, so calling this every behaviour tick does not
    /// make the fish jitter (see [`steer::plan_steer`]).
    pub fn steer_to(
        &self,
        controls: &mut FishControls,
        heading: f32,
        depth: f32,
        speed: f32,
    ) -> Result<(), WorldError> {
        finite("steer heading", heading)?;
        finite("steer depth", depth)?;
        finite("steer speed", speed)?;
        let species = self.species();
        let params = SteerParams::new(species.desc.motion.s, species.desc.motion.l);
        let margin = CONTACT_MARGIN_LENGTHS * species.desc.motion.l;
        let height = self.world.state.tank.extent().y;
        let want = Steer {
            heading: wrap_angle(heading),
            depth: depth.clamp(
                margin.min(height * 0.5),
                (height - margin).max(height * 0.5),
            ),
            speed: speed.clamp(0.0, species.desc.max_speed.max(0.0)),
        };
        let player = &mut controls.player;
        let plan = steer::plan_steer(
            self.root(),
            self.world.state.tank.max.y,
            player.current_kind(),
            &mut controls.steer,
            want,
            &params,
        );
        if let Some(plan) = plan {
            if plan.interrupt {
                player.interrupt(plan.request)?;
            } else {
                player.push(plan.request)?;
            }
        }
        Ok(())
    }
}

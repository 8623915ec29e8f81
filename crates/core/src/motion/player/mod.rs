//! The motion player (paper Fig. 10): a per-fish queue of motion requests, each played to
//! completion in order, with the body wave's phase integrated over time and the root moved along.
//!
//! Files: this one holds [`MotionPlayer`] (the queue, and the step as a sequence of named
//! stages); `active` plans one motion when it starts (its speed, turn and climb over time);
//! `table` holds [`WaveTable`], the body wave's per-body constants; `shape` evaluates the
//! paper's F at a midline sample and poses the chain.

use std::collections::VecDeque;
use std::f32::consts::{FRAC_PI_4, PI, TAU};

use super::body::curve_to_yaw;
use super::wave::{self, smoothstep};
use super::{Body, MotionError, MotionKind, MotionParams, MotionRequest, RootState};
use crate::math::wrap_angle;

mod active;
mod shape;
mod table;
#[cfg(test)]
mod tests;

use active::{Active, Plan};
pub use shape::{MotionTerms, ShapeTerms};
use shape::{ShapeContext, TurnStep, posed_lateral, shape};
use table::WaveSample;
pub use table::WaveTable;

/// Seconds a `Swim` request takes to reach its speed (smoothstep ramp).
pub const SPEED_RAMP_S: f32 = 0.5;
/// Seconds over which a new motion's body shape cross-fades from the previous one's.
pub const SHAPE_BLEND_S: f32 = 0.3;
/// Speed, in body lengths per second, at which the swim wave reaches its full amplitude; below it
/// the amplitude fades (smoothstep) to a straight body at rest.
pub const FULL_AMPLITUDE_SPEED_BODY_LENGTHS_PER_S: f32 = 0.25;
/// Radius of a normal turn's path, body lengths: the turn lasts max(Tt, angle·radius/speed).
pub const NORMAL_TURN_RADIUS_BODY_LENGTHS: f32 = 1.0;
/// Largest heading change of one serial-turn stroke (radians): a serial turn of angle a makes
/// ⌈a / 45°⌉ strokes of Tt each.
pub const SERIAL_STROKE_MAX_RAD: f32 = FRAC_PI_4;
/// Speed of normal/serial turns, ascents and descents started from (almost) rest, as a fraction
/// of the cruising speed `s`: these motions keep the fish swimming.
pub const MIN_MOVING_SPEED_FRACTION: f32 = 0.5;
/// Steepest pitch of an ascent or descent, radians (30°).
pub const MAX_CLIMB_PITCH_RAD: f32 = PI / 6.0;
/// Shortest ascent or descent, seconds.
pub const MIN_CLIMB_S: f32 = 1.0;
/// Time constant, seconds, with which pitch relaxes to level outside ascents and descents.
pub const PITCH_RELAX_S: f32 = 0.3;
/// Extra bend of the quick turn's wave F_st over the swim amplitude (a C-shaped bend).
pub const QUICK_TURN_BEND_GAIN: f32 = 2.0;
/// Extra bend of the serial turn's wave F_st over the swim amplitude.
pub const SERIAL_TURN_BEND_GAIN: f32 = 1.5;
/// Shortest wavelength of the quick/serial turn wave along the body, body lengths.
pub const TURN_WAVELENGTH_BODY_LENGTHS: f32 = 8.0;
/// Most motion transitions a single `step` performs (zero-length motions finish at once).
const MAX_TRANSITIONS_PER_STEP: usize = 8;

thread_local! {
    /// [`MotionPlayer::step`]'s table, for the body it saw last on this thread.
    static STEP_TABLE: std::cell::RefCell<WaveTable> = std::cell::RefCell::new(WaveTable::default());
}

/// Plays a queue of [`MotionRequest`]s for one fish, integrating the wave phase over time.
///
/// Allocation happens only when the queue grows; `step` never allocates.
///
/// Each request plays to completion before the next (Fig. 10); `Swim` plays until something else
/// is queued. When a motion completes with nothing queued, the fish keeps swimming at the speed
/// the motion ended with (after `Stop`, it rests). Every change of motion cross-fades the body
/// shape over [`SHAPE_BLEND_S`] and ramps the speed smoothly; the wave's phase only ever advances.
#[derive(Debug, Clone, PartialEq)]
pub struct MotionPlayer {
    queue: VecDeque<MotionRequest>,
    current: Active,
    previous: Option<Active>,
    blend_elapsed_s: f32,
    /// An interrupt is waiting at the front of the queue.
    cut: bool,
    /// Swim wave phase φ, radians in [0, 2π).
    phase: f32,
    head_lateral: f32,
    head_yaw: f32,
}

impl MotionPlayer {
    /// A player at rest with an empty queue.
    pub fn new() -> Self {
        Self {
            queue: VecDeque::new(),
            current: Active::IDLE,
            previous: None,
            blend_elapsed_s: 0.0,
            cut: false,
            phase: 0.0,
            head_lateral: 0.0,
            head_yaw: 0.0,
        }
    }

    /// A player at rest whose wave starts at `phase` radians (to de-synchronise a shoal).
    pub fn with_phase(phase: f32) -> Self {
        let mut player = Self::new();
        if phase.is_finite() {
            player.phase = phase.rem_euclid(TAU);
        }
        player
    }

    /// Queues `request` after the ones already queued. Rejects NaN / out-of-range values.
    pub fn push(&mut self, request: MotionRequest) -> Result<(), MotionError> {
        request.validate()?;
        self.queue.push_back(request);
        Ok(())
    }

    /// Drops the queue and starts `request` now, blending from the current body shape.
    ///
    /// "Now" is the next [`MotionPlayer::step`]; until then `request` waits at the head of the
    /// queue.
    pub fn interrupt(&mut self, request: MotionRequest) -> Result<(), MotionError> {
        request.validate()?;
        self.queue.clear();
        self.queue.push_back(request);
        self.cut = true;
        Ok(())
    }

    /// Number of requests waiting behind the current one.
    pub fn queue_len(&self) -> usize {
        self.queue.len()
    }

    /// The motion now playing ([`MotionKind::Idle`] when at rest with nothing queued).
    pub fn current_kind(&self) -> MotionKind {
        self.current.kind()
    }

    /// Name of the motion now playing (`"swim"`, `"accelerate"`, `"stop"`, `"normal_turn"`,
    /// `"quick_turn"`, `"serial_turn"`, `"ascend"`, `"descend"`, `"idle"`): the
    /// [`MotionKind::name`] of [`MotionPlayer::current_kind`].
    pub fn current_name(&self) -> &'static str {
        self.current_kind().name()
    }

    /// The request now playing (`None` when idle). After a motion completes with nothing
    /// queued, this is the implicit `Swim` at the speed it ended with.
    pub fn current(&self) -> Option<MotionRequest> {
        self.current.request
    }

    /// Seconds the current motion has played.
    pub fn elapsed_s(&self) -> f32 {
        self.current.elapsed_s
    }

    /// Planned length of the current motion, seconds (infinite for swim and idle).
    pub fn duration_s(&self) -> f32 {
        self.current.duration_s
    }

    /// The swim wave's phase φ, radians in [0, 2π).
    pub fn phase(&self) -> f32 {
        self.phase
    }

    /// Sideways offset of the head from the root's travel line after the last step, length
    /// units, positive to the fish's left (the head's recoil in front of the pivot).
    pub fn head_lateral(&self) -> f32 {
        self.head_lateral
    }

    /// Yaw of the head segment relative to `root.heading` after the last step, radians,
    /// counter-clockwise seen from above. A renderer that wants the head's recoil rotates the root
    /// joint by `heading + head_yaw` and offsets it by `head_lateral`; ignoring both keeps the
    /// head on the heading and moves the recoil into the rest of the body.
    pub fn head_yaw(&self) -> f32 {
        self.head_yaw
    }

    fn begin(&mut self, request: Option<MotionRequest>, params: &MotionParams, speed: f32) {
        self.previous = Some(self.current);
        self.blend_elapsed_s = 0.0;
        self.current = Active::start(request, speed, params);
    }

    /// Advances by `dt` seconds: updates `root` (locomotion) and writes the midline's lateral
    /// displacement at each entry of `body.joints_x` into `lateral` and each driven joint's local
    /// yaw (radians) into `yaw`. Panics only on mismatched slice lengths (a programming error).
    ///
    /// The wave (equations (3)–(7)) is sampled at the head and at `body.joints_x`; the bends
    /// between segments, weighted by `body.power`, become `yaw`; `lateral` is the posed chain's
    /// sideways displacement (so `lateral`, `yaw`, [`MotionPlayer::head_lateral`] and
    /// [`MotionPlayer::head_yaw`] always describe the same body).
    ///
    /// `dt` = 0 (or a NaN / negative `dt`, treated as 0) only recomputes the outputs. `params`
    /// should have passed [`MotionParams::validate`]. Never allocates once the thread's
    /// [`WaveTable`] has grown to the body; a caller stepping many fish of a few species keeps a
    /// table per species and calls [`MotionPlayer::step_with`] (the same results).
    pub fn step(
        &mut self,
        dt: f32,
        params: &MotionParams,
        body: &Body,
        root: &mut RootState,
        lateral: &mut [f32],
        yaw: &mut [f32],
    ) {
        STEP_TABLE.with_borrow_mut(|table| {
            if !table.matches(params, body) {
                table.rebuild(params, body);
            }
            self.step_tabled(dt, params, body, table, root, lateral, yaw);
        });
    }

    /// [`MotionPlayer::step`] with the body's [`WaveTable`] built by the caller (once per
    /// species) for these `params` and `body`; a table built for others is not used (the step
    /// goes through [`MotionPlayer::step`]'s own). Never allocates.
    #[allow(clippy::too_many_arguments)]
    pub fn step_with(
        &mut self,
        dt: f32,
        params: &MotionParams,
        body: &Body,
        table: &WaveTable,
        root: &mut RootState,
        lateral: &mut [f32],
        yaw: &mut [f32],
    ) {
        if table.matches(params, body) {
            self.step_tabled(dt, params, body, table, root, lateral, yaw);
        } else {
            self.step(dt, params, body, root, lateral, yaw);
        }
    }

    /// The step, `table` matching `params` and `body` (the world's tables are built with its
    /// species and replaced with them, so it steps through here without comparing them per
    /// fish). Its stages, in order: [`MotionPlayer::advance_queue`],
    /// [`MotionPlayer::move_root`], [`MotionPlayer::advance_phase`],
    /// [`MotionPlayer::advance_blend`] (together [`MotionPlayer::advance_tabled`]), then
    /// [`MotionPlayer::sample_shape`] and `pose_body` (together [`MotionPlayer::shape_tabled`]).
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn step_tabled(
        &mut self,
        dt: f32,
        params: &MotionParams,
        body: &Body,
        table: &WaveTable,
        root: &mut RootState,
        lateral: &mut [f32],
        yaw: &mut [f32],
    ) {
        self.advance_tabled(dt, params, root);
        let head = self.shape_tabled(root.speed, params, body, table, lateral, yaw);
        self.set_head_shape(head);
    }

    /// The step without the body's shape: queue, root locomotion, phase and blend, as
    /// [`MotionPlayer::step_tabled`] does them, but `lateral`, `yaw`,
    /// [`MotionPlayer::head_lateral`] and [`MotionPlayer::head_yaw`] are left as they were. For a
    /// caller that derives the shape elsewhere (the GPU pose pass, from
    /// [`MotionPlayer::shape_terms`]) or later ([`MotionPlayer::shape_tabled`], then
    /// [`MotionPlayer::set_head_shape`]).
    pub(crate) fn advance_tabled(&mut self, dt: f32, params: &MotionParams, root: &mut RootState) {
        let dt = if dt.is_finite() && dt > 0.0 { dt } else { 0.0 };
        if !root.speed.is_finite() || root.speed < 0.0 {
            root.speed = 0.0;
        }
        self.advance_queue(params, root.speed);
        let v = self.move_root(dt, params, root);
        self.advance_phase(v, dt, params);
        self.advance_blend(dt);
    }

    /// The body's shape now, for a root moving at `speed` (the step's `root.speed`): writes
    /// `lateral` and `yaw` as [`MotionPlayer::step_tabled`] does and returns what it stores as
    /// (`head_lateral`, `head_yaw`). A function of the player's state alone: after
    /// [`MotionPlayer::advance_tabled`] it gives, bit for bit, what the whole step would have.
    /// `table` must match `params` and `body`. Panics only on mismatched slice lengths.
    pub(crate) fn shape_tabled(
        &self,
        speed: f32,
        params: &MotionParams,
        body: &Body,
        table: &WaveTable,
        lateral: &mut [f32],
        yaw: &mut [f32],
    ) -> (f32, f32) {
        assert_eq!(
            lateral.len(),
            body.joints_x.len(),
            "lateral needs one entry per joints_x"
        );
        assert_eq!(
            yaw.len(),
            body.num_joints(),
            "yaw needs one entry per driven joint"
        );
        let head = self.sample_shape(self.blend_weight(), speed, params, table, lateral);
        pose_body(head, params, body, lateral, yaw)
    }

    /// Stores what [`MotionPlayer::shape_tabled`] returned as [`MotionPlayer::head_lateral`]
    /// and [`MotionPlayer::head_yaw`]: after steps taken with [`MotionPlayer::advance_tabled`],
    /// the player is then as whole steps would have left it.
    pub(crate) fn set_head_shape(&mut self, (head_lateral, head_yaw): (f32, f32)) {
        self.head_lateral = head_lateral;
        self.head_yaw = head_yaw;
    }

    /// What the GPU pose pass needs to evaluate the body's shape itself (`shaders/pose.wgsl`
    /// mirrors [`MotionPlayer::shape_tabled`]'s sampling from these): the phase, the speed
    /// gain at `speed`, the blend weight, and each motion's turn terms.
    pub(crate) fn shape_terms(&self, speed: f32, params: &MotionParams) -> ShapeTerms {
        let tt = params.tt;
        ShapeTerms {
            phase: self.phase,
            gain: speed_gain(speed, params),
            weight: self.blend_weight(),
            current: MotionTerms::of(&self.current, tt),
            previous: self
                .previous
                .as_ref()
                .map_or(MotionTerms::PLAIN, |prev| MotionTerms::of(prev, tt)),
        }
    }

    /// The current motion's weight in the shape's cross-fade: below 1 while the previous
    /// motion's shape fades out, 1 once it is gone.
    fn blend_weight(&self) -> f32 {
        match self.previous {
            Some(_) => smoothstep(self.blend_elapsed_s / SHAPE_BLEND_S),
            None => 1.0,
        }
    }

    /// Transitions (Fig. 10): the next request, an interrupt, or the implicit continuation,
    /// each starting at `speed`; at most [`MAX_TRANSITIONS_PER_STEP`] of them.
    fn advance_queue(&mut self, params: &MotionParams, speed: f32) {
        for _ in 0..MAX_TRANSITIONS_PER_STEP {
            let cut = std::mem::take(&mut self.cut);
            if cut || self.current.completed() || (self.current.yields() && !self.queue.is_empty())
            {
                let next = match self.queue.pop_front() {
                    Some(request) => Some(request),
                    None => self.current.continuation(),
                };
                if next.is_none() && self.current.request.is_none() {
                    break;
                }
                self.begin(next, params, speed);
            } else {
                break;
            }
        }
    }

    /// Locomotion of the root over `dt`: speed, heading (turns yaw about the turning axis), pitch and
    /// position. Returns the step's mean speed, which drives the wave's phase.
    fn move_root(&mut self, dt: f32, params: &MotionParams, root: &mut RootState) -> f32 {
        let a = &mut self.current;
        let t0 = a.elapsed_s;
        let t1 = t0 + dt;
        a.elapsed_s = t1;
        let v_start = root.speed;
        let v_end = a.speed_at(t1).max(0.0);
        let v = 0.5 * (v_start + v_end);
        // progress(t0) is the last step's progress(t1) unless the motion changed since.
        let progress_t0 = match a.last_progress {
            Some((t, p)) if t.to_bits() == t0.to_bits() => p,
            _ => a.progress(t0),
        };
        let progress_t1 = a.progress(t1);
        a.last_progress = Some((t1, progress_t1));
        let dprog = progress_t1 - progress_t0;
        let mut heading = root.heading;
        let mut dy = 0.0;
        match a.plan {
            Plan::Turn { d, angle, .. } => {
                // d = −1 (left) increases the heading.
                heading -= d * angle * dprog;
            }
            Plan::Climb { height, .. } => dy = height * dprog,
            _ => {}
        }
        let heading_mid = 0.5 * (root.heading + heading);
        let horizontal = if let Plan::Climb { .. } = a.plan {
            if dt > 0.0 && v > 0.0 {
                let vy = dy / dt;
                root.pitch = (vy / v).clamp(-1.0, 1.0).asin();
                (v * v - vy * vy).max(0.0).sqrt() * dt
            } else {
                0.0
            }
        } else if root.pitch != 0.0 {
            root.pitch *= (-dt / PITCH_RELAX_S).exp();
            v * root.pitch.cos() * dt
        } else {
            // Level (most fish): the relaxation keeps 0 and cos 0 = 1, without `expf`/`cosf`.
            v * dt
        };
        let (sh, ch) = heading_mid.sin_cos();
        root.pos.x += ch * horizontal;
        root.pos.z -= sh * horizontal;
        if heading != root.heading {
            // Turns yaw the body about its turning axis (the pivot unless the species sets one
            // apart), not about the head: the head, that far in front of it, swings round with
            // the heading. The head moves by arm·(cos h1 − cos h0, −(sin h1 − sin h0)); with
            // h_mid = (h0 + h1)/2 and Δ = h1 − h0 that is 2·arm·sin(Δ/2)·(−sin h_mid, −cos h_mid):
            // the mid-heading's sine and cosine are already taken, and the half-step's sine
            // replaces two sine-cosine pairs (and the difference of two nearly equal cosines).
            let arm = params.turn_axis_fraction() * params.l;
            let k = 2.0 * arm * (0.5 * (heading - root.heading)).sin();
            root.pos.x -= k * sh;
            root.pos.z -= k * ch;
        }
        root.pos.y += dy;
        root.heading = wrap_angle(heading);
        root.speed = v_end;
        if !root.pos.is_finite() {
            root.pos = glam::Vec3::ZERO;
        }
        v
    }

    /// The wave's phase: φ advances by 2π·ω'/λ·dt at mean speed `v` and never runs backwards.
    fn advance_phase(&mut self, v: f32, dt: f32, params: &MotionParams) {
        let omega_prime = wave::omega_prime(v, params.p, params.omega).max(0.0);
        let dphase = TAU * omega_prime / params.lambda * dt;
        if dphase.is_finite() {
            let phase = self.phase + dphase;
            // rem_euclid leaves [0, 2π) as it is (bit for bit); skip its `fmodf` there.
            self.phase = if (0.0..TAU).contains(&phase) {
                phase
            } else {
                phase.rem_euclid(TAU)
            };
        }
    }

    /// Advances the cross-fade from the previous motion's body shape by `dt`; the previous motion
    /// is dropped once the current one's weight ([`MotionPlayer::blend_weight`]) reaches 1.
    fn advance_blend(&mut self, dt: f32) {
        if let Some(prev) = self.previous.as_mut() {
            prev.elapsed_s += dt;
            self.blend_elapsed_s += dt;
        }
        if self.blend_weight() >= 1.0 {
            self.previous = None;
        }
    }

    /// Body shape: the current motion's, cross-faded from the previous one's with weight `w`,
    /// at `speed`, sampled from `table` at each `joints_x` entry into `lateral` (positive left).
    /// Returns the head sample's lateral displacement.
    fn sample_shape(
        &self,
        w: f32,
        speed: f32,
        params: &MotionParams,
        table: &WaveTable,
        lateral: &mut [f32],
    ) -> f32 {
        let context = ShapeContext {
            gain: speed_gain(speed, params),
            phase: self.phase.sin_cos(),
            tt: params.tt,
            f: params.f,
        };
        let current = &self.current;
        let current_turn = TurnStep::new(current, &context, table);
        let previous = self
            .previous
            .as_ref()
            .map(|prev| (prev, TurnStep::new(prev, &context, table)));
        let eval = |sample: &WaveSample| {
            let f_new = shape(current, &context, &current_turn, sample);
            let f = match &previous {
                Some((prev, turn)) => f_new * w + shape(prev, &context, turn, sample) * (1.0 - w),
                None => f_new,
            };
            // lateral is positive to the left; the paper's F to the right.
            let lat = -f;
            if lat.is_finite() { lat } else { 0.0 }
        };
        let (head_sample, samples) = table
            .samples
            .split_first()
            .expect("a wave table holds the head sample");
        let head = eval(head_sample);
        for (out, sample) in lateral.iter_mut().zip(samples) {
            *out = eval(sample);
        }
        head
    }
}

/// The swim wave's amplitude gain at `speed`: it fades (smoothstep) to a straight body at rest
/// below [`FULL_AMPLITUDE_SPEED_BODY_LENGTHS_PER_S`].
fn speed_gain(speed: f32, params: &MotionParams) -> f32 {
    smoothstep(speed / (FULL_AMPLITUDE_SPEED_BODY_LENGTHS_PER_S * params.l))
}

/// Turns the sampled midline (`head`, then `lateral`) into the joint yaws, weighted by
/// `body.power`, and the head's yaw; then rewrites `lateral` as the body so posed. Returns the
/// head's lateral displacement (after the recoil) and yaw.
fn pose_body(
    head: f32,
    params: &MotionParams,
    body: &Body,
    lateral: &mut [f32],
    yaw: &mut [f32],
) -> (f32, f32) {
    let mut head_lateral = head;
    let mut head_yaw = curve_to_yaw(params.l, &body.joints_x, &body.power, head, lateral, yaw);
    for y in yaw.iter_mut() {
        if !y.is_finite() {
            *y = 0.0;
        }
    }
    if !head_yaw.is_finite() {
        head_yaw = 0.0;
    }
    // Report the body as posed: the weighted yaws, chained from the head, give each
    // sample's sideways displacement (what a renderer driving the joints shows).
    posed_lateral(params.l, &body.joints_x, head, head_yaw, yaw, lateral);
    // The body recoils so that its centre of mass stays on the travel line (a body with a
    // mass model; the recoil is 0 without one).
    let recoil = body.recoil(head, lateral);
    if recoil != 0.0 && recoil.is_finite() {
        head_lateral -= recoil;
        lateral.iter_mut().for_each(|y| *y -= recoil);
    }
    (head_lateral, head_yaw)
}

impl Default for MotionPlayer {
    fn default() -> Self {
        Self::new()
    }
}

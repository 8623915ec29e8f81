//! The motion player (paper Fig. 10): a per-fish queue of motion requests, each played to
//! completion in order, with the body wave's phase integrated over time and the root moved along.

use std::collections::VecDeque;
use std::f32::consts::{FRAC_PI_4, PI, TAU};

use super::body::curve_to_yaw;
use super::wave::{self, smoothstep};
use super::{Body, MotionError, MotionKind, MotionParams, MotionRequest, RootState, TurnKind};
use crate::math::wrap_angle;

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

/// What an active motion does, planned when it starts (from the root's speed and the params).
#[derive(Debug, Clone, Copy, PartialEq)]
enum Plan {
    /// At rest, nothing queued.
    Idle,
    /// Swim, accelerate, stop: the speed ramps from v0 to v1 over `ramp_s`.
    Speed { ramp_s: f32 },
    /// A turn of `angle` radians to side `d` in `strokes` strokes of `stroke_s` seconds; the
    /// quick/serial wave F_st has wavelength `wavelength` along the body.
    Turn {
        kind: TurnKind,
        d: f32,
        angle: f32,
        strokes: u32,
        stroke_s: f32,
        wavelength: f32,
    },
    /// Rise (`height` > 0) or sink (< 0) by |height| length units, starting after `lead_s`
    /// seconds (the time the speed needs to reach the climbing speed).
    Climb { height: f32, lead_s: f32 },
}

/// One motion in progress.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Active {
    request: Option<MotionRequest>,
    plan: Plan,
    elapsed_s: f32,
    duration_s: f32,
    /// Speed when the motion started and the speed it settles at, length units per second.
    v0: f32,
    v1: f32,
    /// The last step's end time and [`Active::progress`] there, which the next step starts
    /// from.
    last_progress: Option<(f32, f32)>,
}

impl Active {
    const IDLE: Self = Self {
        request: None,
        plan: Plan::Idle,
        elapsed_s: 0.0,
        duration_s: f32::INFINITY,
        v0: 0.0,
        v1: 0.0,
        last_progress: None,
    };

    /// Plans `request` starting at speed `v0`.
    fn start(request: Option<MotionRequest>, v0: f32, params: &MotionParams) -> Self {
        let moving = |v0: f32| {
            v0.max(MIN_MOVING_SPEED_FRACTION * params.s)
                .max(FULL_AMPLITUDE_SPEED_BODY_LENGTHS_PER_S * params.l)
        };
        let mut a = Self {
            request,
            plan: Plan::Idle,
            elapsed_s: 0.0,
            duration_s: f32::INFINITY,
            v0,
            v1: 0.0,
            last_progress: None,
        };
        let Some(request) = request else {
            return a;
        };
        match request {
            MotionRequest::Swim { speed } => {
                a.v1 = speed;
                a.plan = Plan::Speed {
                    ramp_s: SPEED_RAMP_S,
                };
            }
            MotionRequest::Accelerate { speed, duration } => {
                a.v1 = speed;
                a.duration_s = duration;
                a.plan = Plan::Speed { ramp_s: duration };
            }
            MotionRequest::Stop { duration } => {
                a.v1 = 0.0;
                a.duration_s = duration;
                a.plan = Plan::Speed { ramp_s: duration };
            }
            MotionRequest::Turn { kind, angle, side } => {
                let tt = params.tt;
                let wavelength = turn_wavelength(params);
                let (v1, strokes, stroke_s, duration) = match kind {
                    TurnKind::Normal => {
                        let v1 = moving(v0);
                        let arc = angle * NORMAL_TURN_RADIUS_BODY_LENGTHS * params.l;
                        let duration = if v1 > 0.0 { (arc / v1).max(tt) } else { tt };
                        (v1, 1, duration, duration)
                    }
                    TurnKind::Quick => (v0, 1, tt, tt),
                    TurnKind::Serial => {
                        let strokes = ((angle / SERIAL_STROKE_MAX_RAD).ceil() as u32).max(1);
                        (moving(v0), strokes, tt, strokes as f32 * tt)
                    }
                };
                a.v1 = v1;
                a.duration_s = duration;
                a.plan = Plan::Turn {
                    kind,
                    d: side.d(),
                    angle,
                    strokes,
                    stroke_s,
                    wavelength,
                };
            }
            MotionRequest::Ascend { height } | MotionRequest::Descend { depth: height } => {
                let signed = if matches!(request, MotionRequest::Ascend { .. }) {
                    height
                } else {
                    -height
                };
                let v1 = moving(v0);
                // Vertical speed peaks at H·π/(2T) (cosine ease); keep it ≤ v1·sin(max pitch).
                // From a slower start, first reach v1, then climb.
                let climb_s =
                    (PI * height / (2.0 * v1 * MAX_CLIMB_PITCH_RAD.sin())).max(MIN_CLIMB_S);
                let lead_s = if v0 < v1 { SPEED_RAMP_S } else { 0.0 };
                a.v1 = v1;
                a.duration_s = lead_s + climb_s;
                a.plan = Plan::Climb {
                    height: signed,
                    lead_s,
                };
            }
        }
        a
    }

    fn kind(&self) -> MotionKind {
        self.request.map_or(MotionKind::Idle, |r| r.kind())
    }

    fn completed(&self) -> bool {
        self.elapsed_s >= self.duration_s
    }

    /// Swim and idle give way as soon as something is queued; every other motion plays out.
    fn yields(&self) -> bool {
        matches!(self.request, None | Some(MotionRequest::Swim { .. }))
    }

    /// What plays when this motion completes with nothing queued.
    fn continuation(&self) -> Option<MotionRequest> {
        match self.request {
            None => None,
            Some(MotionRequest::Stop { .. }) => None,
            Some(_) if self.v1 <= 0.0 => None,
            Some(_) => Some(MotionRequest::Swim { speed: self.v1 }),
        }
    }

    /// The turn interpolation I_p at `t` seconds into the motion (0 outside turns).
    fn ip(&self, t: f32) -> f32 {
        match self.plan {
            Plan::Turn { stroke_s, .. } if t < self.duration_s => wave::i_p(t, stroke_s),
            _ => 0.0,
        }
    }

    fn speed_at(&self, t: f32) -> f32 {
        match self.plan {
            Plan::Idle => self.v0 * (1.0 - smoothstep(t / SPEED_RAMP_S)),
            Plan::Turn {
                kind: TurnKind::Quick,
                ..
            } => self.v0 * (1.0 - self.ip(t)),
            Plan::Speed { ramp_s } if ramp_s <= 0.0 => self.v1,
            Plan::Speed { ramp_s } => self.v0 + (self.v1 - self.v0) * smoothstep(t / ramp_s),
            Plan::Turn { .. } | Plan::Climb { .. } => {
                self.v0 + (self.v1 - self.v0) * smoothstep(t / SPEED_RAMP_S)
            }
        }
    }

    /// Fraction in [0, 1] of the turn's heading change (or the climb's height) done at `t`.
    /// Its rate is proportional to I_p, so the heading turns fastest when the turn wave is
    /// strongest and not at all at the ends of a stroke.
    fn progress(&self, t: f32) -> f32 {
        if !self.duration_s.is_finite() || self.duration_s <= 0.0 {
            return 1.0;
        }
        let lead_s = match self.plan {
            Plan::Climb { lead_s, .. } => lead_s,
            _ => 0.0,
        };
        let u = ((t - lead_s) / (self.duration_s - lead_s)).clamp(0.0, 1.0);
        let strokes = match self.plan {
            Plan::Turn { strokes, .. } => strokes as f32,
            _ => 1.0,
        };
        let su = u * strokes;
        let whole = su.floor().min(strokes - 1.0);
        let frac = su - whole;
        (whole + 0.5 * (1.0 - (PI * frac).cos())) / strokes
    }
}

/// The body wave's per-body constants, computed once per species instead of every step: for the
/// head (x = 0) and each entry of `body.joints_x`, the sample's position terms of equations
/// (3)–(6) and the sine and cosine of the wave arguments that do not depend on time.
///
/// With them, each travelling wave sin(2π·x'/λ − φ) of a step is
/// sin(2π·x'/λ)·cos φ − cos(2π·x'/λ)·sin φ: one `sin_cos(φ)` per step (and one per quick or
/// serial turn wave) instead of one sine per sample and wave. The equations are the paper's; the
/// values differ from evaluating each sine directly only by rounding (a few 1e-7 of the
/// amplitude).
///
/// [`MotionPlayer::step_with`] takes a table built for its `params` and `body`;
/// [`MotionPlayer::step`] keeps one per thread, rebuilt when the body or parameters change.
#[derive(Debug, Clone, Default)]
pub struct WaveTable {
    /// The parameters and midline samples it was built for, bit for bit.
    params_bits: [u32; 9],
    joints_x_bits: Vec<u32>,
    /// Wavelength of the quick/serial turn wave along the body (as `Active::start` plans it).
    turn_wavelength: f32,
    /// Head first, then one per `joints_x` entry.
    samples: Vec<WaveSample>,
}

/// One midline sample's constants (see [`WaveTable`]).
#[derive(Debug, Clone, Copy, Default)]
struct WaveSample {
    /// x' = x·l − p·l, length units.
    xp: f32,
    /// A(x), length units (before the speed gain).
    amp: f32,
    /// sin and cos of the swim wave's spatial argument: 2π·x'/λ' in front of the pivot, 2π·x'/λ
    /// behind it (also F_nt's argument there).
    swim: (f32, f32),
    /// sin and cos of F_st's spatial argument 2π·x'/Λ''.
    turn: (f32, f32),
}

fn param_bits(p: &MotionParams) -> [u32; 9] {
    [
        p.p,
        p.s,
        p.l,
        p.max_amp,
        p.lambda,
        p.omega,
        p.tt,
        p.f,
        p.turn_angle,
    ]
    .map(f32::to_bits)
}

/// The quick/serial turn wave's wavelength along the body, length units: λ'' = 2·Tt is a period;
/// the swim wave's phase speed ω' at cruising speed turns it into a length along the body, at
/// least [`TURN_WAVELENGTH_BODY_LENGTHS`]·l so the bend stays one smooth C instead of folding.
fn turn_wavelength(params: &MotionParams) -> f32 {
    (wave::lambda_2(params.tt) * wave::omega_prime(params.s, params.p, params.omega))
        .max(TURN_WAVELENGTH_BODY_LENGTHS * params.l)
}

impl WaveTable {
    /// The table of `body` under `params`. Allocates; build it once per species.
    pub fn new(params: &MotionParams, body: &Body) -> Self {
        let mut table = Self::default();
        table.rebuild(params, body);
        table
    }

    /// Whether the table was built for exactly these parameters and midline samples.
    pub fn matches(&self, params: &MotionParams, body: &Body) -> bool {
        self.params_bits == param_bits(params)
            && self.joints_x_bits.len() == body.joints_x.len()
            && self
                .joints_x_bits
                .iter()
                .zip(&body.joints_x)
                .all(|(&b, x)| b == x.to_bits())
    }

    /// Rebuilds in place for `params` and `body` (allocates only to grow).
    fn rebuild(&mut self, params: &MotionParams, body: &Body) {
        self.params_bits = param_bits(params);
        self.joints_x_bits.clear();
        self.joints_x_bits
            .extend(body.joints_x.iter().map(|x| x.to_bits()));
        self.turn_wavelength = turn_wavelength(params);
        let (p, l) = (params.p, params.l);
        let lambda_prime = params.lambda_prime();
        let wavelength = self.turn_wavelength;
        self.samples.clear();
        self.samples.extend(
            std::iter::once(0.0)
                .chain(body.joints_x.iter().copied())
                .map(|x| {
                    // The same expressions as wave::swim_wave, f_front/f_back, f_nt and f_st.
                    let xl = x * l;
                    let xp = wave::x_prime(xl, p, l);
                    let swim = if xp < 0.0 {
                        TAU * xp / lambda_prime
                    } else {
                        TAU * xp / params.lambda
                    };
                    WaveSample {
                        xp,
                        amp: if xp < 0.0 {
                            wave::front_amplitude(xl, p, l)
                        } else {
                            wave::amplitude(xl, p, l, params.max_amp)
                        },
                        swim: swim.sin_cos(),
                        turn: (TAU * xp / wavelength).sin_cos(),
                    }
                }),
        );
    }
}

thread_local! {
    /// [`MotionPlayer::step`]'s table, for the body it saw last on this thread.
    static STEP_TABLE: std::cell::RefCell<WaveTable> = std::cell::RefCell::new(WaveTable::default());
}

/// Per-step values every shape evaluation shares.
struct ShapeContext {
    gain: f32,
    /// sin φ, cos φ of the swim wave's phase.
    phase: (f32, f32),
    tt: f32,
    f: f32,
}

/// A motion's turn terms for this step (the same at every sample).
struct TurnStep {
    /// I_p at the motion's time.
    ip: f32,
    /// 2π·ω''·t of F_st, and its sine and cosine.
    omega_t: f32,
    sin_cos: (f32, f32),
    /// The table's turn wavelength is the motion's (else F_st is evaluated directly).
    tabled: bool,
}

impl TurnStep {
    fn new(a: &Active, c: &ShapeContext, table: &WaveTable) -> Self {
        let ip = a.ip(a.elapsed_s);
        match a.plan {
            Plan::Turn {
                kind: TurnKind::Quick | TurnKind::Serial,
                wavelength,
                ..
            } if ip != 0.0 => {
                let omega_t = TAU * wave::omega_2(c.tt) * a.elapsed_s;
                TurnStep {
                    ip,
                    omega_t,
                    sin_cos: omega_t.sin_cos(),
                    tabled: wavelength.to_bits() == table.turn_wavelength.to_bits(),
                }
            }
            _ => TurnStep {
                ip,
                omega_t: 0.0,
                sin_cos: (0.0, 1.0),
                tabled: true,
            },
        }
    }
}

/// The paper's F (positive to the fish's right) of motion `a` at midline sample `s` (see
/// [`WaveTable`]); `turn` holds the motion's turn terms for this step.
fn shape(a: &Active, c: &ShapeContext, turn: &TurnStep, s: &WaveSample) -> f32 {
    // sin(2π·x'/λ − φ) (λ' in front of the pivot): eq. (3)/(4) without the amplitude.
    let (sin_phi, cos_phi) = c.phase;
    let travelling = s.swim.0 * cos_phi - s.swim.1 * sin_phi;
    let swim = s.amp * c.gain * travelling;
    let Plan::Turn {
        kind,
        d,
        wavelength,
        strokes,
        ..
    } = a.plan
    else {
        return swim;
    };
    let (ip, xp, amp) = (turn.ip, s.xp, s.amp);
    if ip == 0.0 || xp < 0.0 {
        // The turn functions only change the part behind the pivot (paper 3.5.2).
        return swim;
    }
    let t = match kind {
        // Eq. (5), F_nt = A(x)·(sin(2π·x'/λ − φ) + d)·f: behind the pivot its sine is the swim
        // wave's.
        TurnKind::Normal => amp * (travelling + d) * c.f,
        TurnKind::Quick | TurnKind::Serial => {
            // One |sin| lobe per stroke: the bend enters at the pivot when the stroke starts
            // and runs to the tail; before it arrives (and after the last stroke) a point is
            // not bent, so no lobe of a stroke that never happened shows.
            let theta = turn.omega_t - TAU * xp / wavelength;
            if theta < 0.0 || theta > strokes as f32 * PI {
                0.0
            } else {
                let gain = if kind == TurnKind::Quick {
                    QUICK_TURN_BEND_GAIN
                } else {
                    SERIAL_TURN_BEND_GAIN
                };
                let a_st = amp * gain * c.f;
                if turn.tabled {
                    // Eq. (6), F_st = A·d·|sin(2π·x'/Λ'' − 2π·ω''·t)|, by angle subtraction.
                    let (sin_t, cos_t) = turn.sin_cos;
                    a_st * d * (s.turn.0 * cos_t - s.turn.1 * sin_t).abs()
                } else {
                    wave::f_st(a_st, xp, wavelength, a.elapsed_s, c.tt, d)
                }
            }
        }
    };
    wave::t_locomotion(swim, t, ip)
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
    /// fish).
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
        let dt = if dt.is_finite() && dt > 0.0 { dt } else { 0.0 };
        if !root.speed.is_finite() || root.speed < 0.0 {
            root.speed = 0.0;
        }

        // Transitions (Fig. 10): next request, interrupt, or the implicit continuation.
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
                self.begin(next, params, root.speed);
            } else {
                break;
            }
        }

        // Locomotion of the root.
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
            // Turns yaw the body about the pivot (the paper's turning axis), not about the head:
            // the head, p·l in front of it, swings round with the heading.
            let arm = params.p * params.l;
            let (s0, c0) = root.heading.sin_cos();
            let (s1, c1) = heading.sin_cos();
            root.pos.x += arm * (c1 - c0);
            root.pos.z -= arm * (s1 - s0);
        }
        root.pos.y += dy;
        root.heading = wrap_angle(heading);
        root.speed = v_end;
        if !root.pos.is_finite() {
            root.pos = glam::Vec3::ZERO;
        }

        // The wave's phase: φ advances by 2π·ω'/λ·dt and never runs backwards.
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

        // Body shape: the current motion, cross-faded from the previous one.
        let w = match self.previous.as_mut() {
            Some(prev) => {
                prev.elapsed_s += dt;
                self.blend_elapsed_s += dt;
                smoothstep(self.blend_elapsed_s / SHAPE_BLEND_S)
            }
            None => 1.0,
        };
        if w >= 1.0 {
            self.previous = None;
        }
        let context = ShapeContext {
            gain: smoothstep(v_end / (FULL_AMPLITUDE_SPEED_BODY_LENGTHS_PER_S * params.l)),
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
        self.head_lateral = head;
        self.head_yaw = curve_to_yaw(params.l, &body.joints_x, &body.power, head, lateral, yaw);
        for y in yaw.iter_mut() {
            if !y.is_finite() {
                *y = 0.0;
            }
        }
        if !self.head_yaw.is_finite() {
            self.head_yaw = 0.0;
        }
        // Report the body as posed: the weighted yaws, chained from the head, give each
        // sample's sideways displacement (what a renderer driving the joints shows).
        posed_lateral(params.l, &body.joints_x, head, self.head_yaw, yaw, lateral);
    }
}

/// Sideways displacement (positive left) of each `joints_x` sample of the rigid chain that starts
/// `head_lateral` to the side, leaves the head at `head_yaw` and bends by `yaw` at each driven
/// joint. Segment lengths are Δx·l.
fn posed_lateral(
    l: f32,
    joints_x: &[f32],
    head_lateral: f32,
    head_yaw: f32,
    yaw: &[f32],
    lateral: &mut [f32],
) {
    let mut left = head_lateral;
    let mut alpha = -head_yaw;
    let mut x_prev = 0.0;
    for (k, (&x, out)) in joints_x.iter().zip(lateral.iter_mut()).enumerate() {
        if k > 0 {
            alpha += yaw[k - 1];
        }
        left += (x - x_prev) * l * alpha.sin();
        x_prev = x;
        *out = left;
    }
}

impl Default for MotionPlayer {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion::Side;

    fn run(
        player: &mut MotionPlayer,
        params: &MotionParams,
        root: &mut RootState,
        seconds: f32,
    ) -> (Vec<f32>, Vec<f32>) {
        let body = Body::black_porgy();
        let mut lateral = vec![0.0; 7];
        let mut yaw = vec![0.0; 6];
        let dt = 1.0 / 60.0;
        let steps = (seconds / dt).round() as usize;
        for _ in 0..steps {
            player.step(dt, params, &body, root, &mut lateral, &mut yaw);
        }
        (lateral, yaw)
    }

    #[test]
    fn test_progress_reaches_one_for_every_stroke_count() {
        let params = MotionParams::default();
        for angle in [0.3, 1.0, 1.6, 3.0] {
            let a = Active::start(
                Some(MotionRequest::Turn {
                    kind: TurnKind::Serial,
                    angle,
                    side: Side::Left,
                }),
                50.0,
                &params,
            );
            assert_eq!(a.progress(0.0), 0.0);
            assert!((a.progress(a.duration_s) - 1.0).abs() < 1e-6);
            // Monotone.
            let mut last = 0.0;
            for k in 0..=100 {
                let g = a.progress(a.duration_s * k as f32 / 100.0);
                assert!(g >= last - 1e-6);
                last = g;
            }
        }
    }

    #[test]
    fn test_steady_swim_advances_at_s() {
        let params = MotionParams::default();
        let mut player = MotionPlayer::new();
        let mut root = RootState {
            speed: 50.0,
            ..RootState::default()
        };
        player.push(MotionRequest::Swim { speed: 50.0 }).unwrap();
        run(&mut player, &params, &mut root, 1.0);
        let x0 = root.pos.x;
        run(&mut player, &params, &mut root, 2.0);
        assert!(
            ((root.pos.x - x0) - 100.0).abs() < 0.01,
            "{}",
            root.pos.x - x0
        );
        assert!(root.pos.z.abs() < 1e-4);
        assert_eq!(player.current_name(), "swim");
    }

    #[test]
    fn test_quick_turn_left_turns_ninety_degrees_in_tt() {
        let params = MotionParams::default();
        let mut player = MotionPlayer::new();
        let mut root = RootState {
            speed: 50.0,
            ..RootState::default()
        };
        player
            .push(MotionRequest::Turn {
                kind: TurnKind::Quick,
                angle: std::f32::consts::FRAC_PI_2,
                side: Side::Left,
            })
            .unwrap();
        run(&mut player, &params, &mut root, params.tt);
        assert!(
            (root.heading - std::f32::consts::FRAC_PI_2).abs() < 1e-3,
            "{}",
            root.heading
        );
    }

    /// Parameters that failed validation still never put NaN or infinity into the outputs.
    #[test]
    fn test_invalid_params_never_produce_nan() {
        let ok = MotionParams::default();
        let bad = [
            MotionParams { p: f32::NAN, ..ok },
            MotionParams { lambda: 0.0, ..ok },
            MotionParams { l: 0.0, ..ok },
            MotionParams { tt: 0.0, ..ok },
            MotionParams { p: 0.1, ..ok },
            MotionParams {
                omega: f32::INFINITY,
                ..ok
            },
            MotionParams {
                max_amp: f32::NAN,
                ..ok
            },
        ];
        let body = Body::black_porgy();
        for params in bad {
            for request in [
                MotionRequest::Swim { speed: 50.0 },
                MotionRequest::Turn {
                    kind: TurnKind::Quick,
                    angle: 1.0,
                    side: Side::Right,
                },
                MotionRequest::Turn {
                    kind: TurnKind::Normal,
                    angle: 1.0,
                    side: Side::Left,
                },
                MotionRequest::Ascend { height: 10.0 },
            ] {
                let mut player = MotionPlayer::new();
                let mut root = RootState {
                    speed: 50.0,
                    ..RootState::default()
                };
                player.push(request).unwrap();
                let mut lateral = [0.0; 7];
                let mut yaw = [0.0; 6];
                for _ in 0..200 {
                    player.step(
                        1.0 / 60.0,
                        &params,
                        &body,
                        &mut root,
                        &mut lateral,
                        &mut yaw,
                    );
                    assert!(
                        lateral.iter().chain(yaw.iter()).all(|v| v.is_finite())
                            && root.pos.is_finite()
                            && root.heading.is_finite()
                            && root.pitch.is_finite()
                            && root.speed.is_finite(),
                        "{params:?} {request:?}: {lateral:?} {yaw:?} {root:?}"
                    );
                }
            }
        }
    }

    /// The shape as it was evaluated before [`WaveTable`]: every sine directly, from the wave
    /// functions of `wave.rs`.
    fn shape_direct(a: &Active, params: &MotionParams, phase: f32, gain: f32, x: f32) -> f32 {
        let (p, l) = (params.p, params.l);
        let xl = x * l;
        let s = wave::swim_wave(
            xl,
            p,
            l,
            params.max_amp,
            params.lambda,
            params.lambda_prime(),
            phase,
            gain,
        );
        let Plan::Turn {
            kind,
            d,
            wavelength,
            strokes,
            ..
        } = a.plan
        else {
            return s;
        };
        let ip = a.ip(a.elapsed_s);
        let xp = wave::x_prime(xl, p, l);
        if ip == 0.0 || xp < 0.0 {
            return s;
        }
        let amp = wave::amplitude(xl, p, l, params.max_amp);
        let t = match kind {
            TurnKind::Normal => wave::f_nt(amp, xp, params.lambda, phase, d, params.f),
            TurnKind::Quick | TurnKind::Serial => {
                let theta = TAU * wave::omega_2(params.tt) * a.elapsed_s - TAU * xp / wavelength;
                if theta < 0.0 || theta > strokes as f32 * PI {
                    0.0
                } else {
                    let gain = if kind == TurnKind::Quick {
                        QUICK_TURN_BEND_GAIN
                    } else {
                        SERIAL_TURN_BEND_GAIN
                    };
                    wave::f_st(
                        amp * gain * params.f,
                        xp,
                        wavelength,
                        a.elapsed_s,
                        params.tt,
                        d,
                    )
                }
            }
        };
        wave::t_locomotion(s, t, ip)
    }

    /// The tabled shape is the paper's equations evaluated sine by sine, within 2e-7 body
    /// lengths, through every kind of motion and the cross-fades between them, for two species'
    /// parameters; and `step_with` (the world's path) gives bitwise what `step` gives.
    #[test]
    fn test_tabled_shape_matches_direct_evaluation() {
        let eel = MotionParams {
            p: 0.2,
            s: 30.0,
            l: 70.0,
            max_amp: 70.0 / 8.0,
            lambda: 42.0,
            omega: 3.0,
            tt: 2.5,
            f: 1.0,
            turn_angle: FRAC_PI_4,
        };
        let requests = [
            MotionRequest::Swim { speed: 50.0 },
            MotionRequest::Turn {
                kind: TurnKind::Normal,
                angle: 1.2,
                side: Side::Left,
            },
            MotionRequest::Turn {
                kind: TurnKind::Quick,
                angle: 1.6,
                side: Side::Right,
            },
            MotionRequest::Turn {
                kind: TurnKind::Serial,
                angle: 2.5,
                side: Side::Left,
            },
            MotionRequest::Ascend { height: 30.0 },
            MotionRequest::Accelerate {
                speed: 90.0,
                duration: 0.7,
            },
            MotionRequest::Stop { duration: 0.5 },
        ];
        for (params, body) in [
            (MotionParams::default(), Body::black_porgy()),
            (eel, Body::evenly_spaced(9)),
        ] {
            let table = WaveTable::new(&params, &body);
            let other = WaveTable::new(&MotionParams::default(), &Body::evenly_spaced(4));
            let n = body.joints_x.len();
            let mut player = MotionPlayer::with_phase(1.0);
            let mut twin = player.clone();
            let mut root = RootState {
                speed: 40.0,
                ..RootState::default()
            };
            let mut twin_root = root;
            let (mut lateral, mut yaw) = (vec![0.0; n], vec![0.0; n - 1]);
            let (mut twin_lateral, mut twin_yaw) = (lateral.clone(), yaw.clone());
            let (mut worst, mut turning) = (0.0f32, 0);
            for (k, request) in requests.iter().cycle().take(40).enumerate() {
                if k % 3 == 0 {
                    player.interrupt(*request).unwrap();
                    twin.interrupt(*request).unwrap();
                } else {
                    player.push(*request).unwrap();
                    twin.push(*request).unwrap();
                }
                for step in 0..50 {
                    player.step(
                        1.0 / 60.0,
                        &params,
                        &body,
                        &mut root,
                        &mut lateral,
                        &mut yaw,
                    );
                    // The world's path, every other step with a table for another body.
                    let t = if step % 2 == 0 { &table } else { &other };
                    twin.step_with(
                        1.0 / 60.0,
                        &params,
                        &body,
                        t,
                        &mut twin_root,
                        &mut twin_lateral,
                        &mut twin_yaw,
                    );
                    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    assert_eq!(bits(&lateral), bits(&twin_lateral));
                    assert_eq!(bits(&yaw), bits(&twin_yaw));
                    assert_eq!(root, twin_root);
                    // Each motion's shape at every sample, tabled and direct.
                    let context = ShapeContext {
                        gain: smoothstep(
                            root.speed / (FULL_AMPLITUDE_SPEED_BODY_LENGTHS_PER_S * params.l),
                        ),
                        phase: player.phase.sin_cos(),
                        tt: params.tt,
                        f: params.f,
                    };
                    for a in std::iter::once(&player.current).chain(player.previous.as_ref()) {
                        turning += usize::from(a.ip(a.elapsed_s) > 0.0);
                        let turn = TurnStep::new(a, &context, &table);
                        for (sample, x) in table
                            .samples
                            .iter()
                            .zip(std::iter::once(0.0).chain(body.joints_x.iter().copied()))
                        {
                            let tabled = shape(a, &context, &turn, sample);
                            let direct = shape_direct(a, &params, player.phase, context.gain, x);
                            worst = worst.max((tabled - direct).abs() / params.l);
                        }
                    }
                }
            }
            assert!(turning > 500, "turns were exercised: {turning}");
            assert!(
                worst <= 2e-6,
                "tabled shape differs by {worst} body lengths"
            );
        }
    }

    /// 10,000 fish each hold a player: keep it within a few cache lines.
    #[test]
    fn test_player_state_is_small() {
        let size = std::mem::size_of::<MotionPlayer>();
        assert!(size <= 192, "MotionPlayer is {size} bytes");
    }
}

//! One motion in progress: what it does, planned when it starts from the root's speed and the
//! parameters (its speed ramp, turn strokes or climb), and where it is at a time `t`.

use std::f32::consts::PI;

use super::table::turn_wavelength;
use super::{
    FULL_AMPLITUDE_SPEED_BODY_LENGTHS_PER_S, MAX_CLIMB_PITCH_RAD, MIN_CLIMB_S,
    MIN_MOVING_SPEED_FRACTION, NORMAL_TURN_RADIUS_BODY_LENGTHS, SERIAL_STROKE_MAX_RAD,
    SPEED_RAMP_S,
};
use crate::motion::wave::{self, smoothstep};
use crate::motion::{MotionKind, MotionParams, MotionRequest, TurnKind};

/// What an active motion does, planned when it starts (from the root's speed and the params).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) enum Plan {
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
pub(super) struct Active {
    pub(super) request: Option<MotionRequest>,
    pub(super) plan: Plan,
    pub(super) elapsed_s: f32,
    pub(super) duration_s: f32,
    /// Speed when the motion started and the speed it settles at, length units per second.
    pub(super) v0: f32,
    pub(super) v1: f32,
    /// The last step's end time and [`Active::progress`] there, which the next step starts
    /// from.
    pub(super) last_progress: Option<(f32, f32)>,
}

impl Active {
    pub(super) const IDLE: Self = Self {
        request: None,
        plan: Plan::Idle,
        elapsed_s: 0.0,
        duration_s: f32::INFINITY,
        v0: 0.0,
        v1: 0.0,
        last_progress: None,
    };

    /// Plans `request` starting at speed `v0`.
    pub(super) fn start(request: Option<MotionRequest>, v0: f32, params: &MotionParams) -> Self {
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

    pub(super) fn kind(&self) -> MotionKind {
        self.request.map_or(MotionKind::Idle, |r| r.kind())
    }

    pub(super) fn completed(&self) -> bool {
        self.elapsed_s >= self.duration_s
    }

    /// Swim and idle give way as soon as something is queued; every other motion plays out.
    pub(super) fn yields(&self) -> bool {
        matches!(self.request, None | Some(MotionRequest::Swim { .. }))
    }

    /// What plays when this motion completes with nothing queued.
    pub(super) fn continuation(&self) -> Option<MotionRequest> {
        match self.request {
            None => None,
            Some(MotionRequest::Stop { .. }) => None,
            Some(_) if self.v1 <= 0.0 => None,
            Some(_) => Some(MotionRequest::Swim { speed: self.v1 }),
        }
    }

    /// The turn interpolation I_p at `t` seconds into the motion (0 outside turns).
    pub(super) fn ip(&self, t: f32) -> f32 {
        match self.plan {
            Plan::Turn { stroke_s, .. } if t < self.duration_s => wave::i_p(t, stroke_s),
            _ => 0.0,
        }
    }

    pub(super) fn speed_at(&self, t: f32) -> f32 {
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
    pub(super) fn progress(&self, t: f32) -> f32 {
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

//! Motion layer (paper sections 3.4–3.5, equations (2)–(7), Table 1).
//!
//! The public types in this file (requests, parameters, the root's state, [`MotionKind`]) are what
//! the world, the Lua host and the renderer use of the motion layer.
//!
//! Conventions shared by every layer:
//! - Lengths are in the units of the species' body length `l` (Table 1 uses l = 50).
//! - World axes: +y is up. `heading` is radians counter-clockwise seen from above; heading 0
//!   faces +x, so forward = (cos h · cos pitch, sin pitch, −sin h · cos pitch). A left turn
//!   increases heading. `pitch` is radians, positive nose-up.
//! - `lateral` displacement of the midline is positive towards the fish's left; a joint's local
//!   `yaw` is positive when it bends the body towards the fish's left.
//! - `Side` follows the paper's `d`: −1 left, +1 right.
//!
//! Files: [`wave`] holds equations (2)–(7) as functions named after the paper's symbols;
//! [`body`] turns the body curve into joint yaws (power profile after Fig. 5); [`player`] holds
//! [`MotionPlayer`] (the motions, their queue, and the step as named stages: queue, root
//! locomotion, phase, blend, shape, pose); [`presets`] the four experiments of Table 1. The
//! smoothstep and angle wrap it uses are [`crate::math`]'s. `docs/motion.md` maps every equation to its function and records every
//! reading of the paper that had to be chosen.

use glam::Vec3;

pub mod body;
pub mod kinematics;
pub mod player;
pub mod presets;
pub mod record;
pub mod wave;

pub use body::{MidlinePoseJob, PowerProfile, power_after_fig5};
pub use kinematics::{Kinematics, KinematicsError, MidlineSeries, analyze, record_swim};
pub use player::{MotionPlayer, WaveTable};
pub use presets::Preset;
pub use record::{Recording, record_preset};
pub use wave::FrontWave;

/// Which way a turn goes: the paper's `d` (−1 left, 1 right; 0 "front" is not a turn).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Side {
    /// d = −1: heading increases (counter-clockwise seen from above).
    Left,
    /// d = +1: heading decreases.
    Right,
}

impl Side {
    /// The paper's `d` for this side.
    pub fn d(self) -> f32 {
        match self {
            Side::Left => -1.0,
            Side::Right => 1.0,
        }
    }
}

/// The three turn kinds of section 3.5.2.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum TurnKind {
    /// Tail to one side only, wave F_nt (5); the fish keeps swimming.
    Normal,
    /// Turn while halting, small radius, in about Tt; wave F_st (6).
    Quick,
    /// Turn while still swimming forward; wave F_st (6).
    Serial,
}

/// Per-species motion parameters (Table 1 plus what the paper leaves implicit).
///
/// `Copy`, validated by [`MotionParams::validate`]; every field documents its unit.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MotionParams {
    /// Pivot position `p` as a fraction of body length from the head; must give λ' > 0.
    pub p: f32,
    /// Cruising speed `s`, length units per second.
    pub s: f32,
    /// Body length `l`, length units.
    pub l: f32,
    /// `maxAmp` of A(x) = ((x − p·l)/l)·maxAmp, length units.
    pub max_amp: f32,
    /// Base wavelength λ of (2), length units.
    pub lambda: f32,
    /// Base frequency ω of (2)/(3)/(4) (see docs/motion.md for its unit).
    pub omega: f32,
    /// Turning time `Tt`, seconds.
    pub tt: f32,
    /// Turn amplitude weight `f` of (5), in [1, 2].
    pub f: f32,
    /// Default turn angle, radians (Table 1 experiments use 90°).
    pub turn_angle: f32,
    /// The turning axis: where the body yaws about during turns, as a fraction of the body length
    /// from the head; `None` turns about the pivot `p` (the paper's reading). A species sets it
    /// where its swim wave's node (`p`) is not where it turns (docs/motion.md, "Where the pivot
    /// sits").
    #[serde(default)]
    pub turn_axis: Option<f32>,
    /// Amplitude of the front wave F_f at the snout, a fraction of the body length (equation (3)
    /// prints none: one length unit, 1/50 of Table 1's fish, [`wave::FRONT_AMPLITUDE_BODY_LENGTHS`]).
    #[serde(default = "default_front_amp")]
    pub front_amp: f32,
    /// How F_f's amplitude runs from the snout to the pivot ([`wave::FrontWave`]).
    #[serde(default)]
    pub front_wave: wave::FrontWave,
}

fn default_front_amp() -> f32 {
    wave::FRONT_AMPLITUDE_BODY_LENGTHS
}

/// One motion request, as a behaviour script issues it (Fig. 10: played to completion in order).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum MotionRequest {
    /// Steady swim at `speed` (length units / s) until the next request.
    Swim {
        /// Length units per second, ≥ 0.
        speed: f32,
    },
    /// Change speed to `speed` over `duration` seconds, then keep swimming.
    Accelerate {
        /// Target speed, length units per second, ≥ 0.
        speed: f32,
        /// Seconds, ≥ 0.
        duration: f32,
    },
    /// Come to rest over `duration` seconds.
    Stop {
        /// Seconds, ≥ 0.
        duration: f32,
    },
    /// Turn by `angle` radians (> 0) to `side`.
    Turn {
        /// Normal, quick or serial (section 3.5.2).
        kind: TurnKind,
        /// Heading change, radians in (0, 2π].
        angle: f32,
        /// Which way (the paper's d).
        side: Side,
    },
    /// Rise by `height` length units (pitch up, then level out).
    Ascend {
        /// Length units, ≥ 0.
        height: f32,
    },
    /// Sink by `depth` length units (pitch down, then level out).
    Descend {
        /// Length units, ≥ 0.
        depth: f32,
    },
}

/// The root joint's state: position and orientation (paper 3.2: only the root carries position).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct RootState {
    /// World position of the root (head end of the vertebral column), length units.
    pub pos: Vec3,
    /// Radians counter-clockwise seen from above; 0 faces +x.
    pub heading: f32,
    /// Radians, positive nose-up.
    pub pitch: f32,
    /// Current forward speed, length units per second.
    pub speed: f32,
}

/// The vertebral body a motion drives: where its driven joints sit and how strongly each bends.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Body {
    /// Driven joints' positions as fractions of body length from head (0) to tail (1), increasing,
    /// followed by the tail tip (1.0). Length = number of driven joints + 1.
    pub joints_x: Vec<f32>,
    /// Per driven joint power weight after Fig. 5. Length = number of driven joints.
    pub power: Vec<f32>,
    /// The share of the body's mass in each rigid segment of the chain — head to the first
    /// driven joint, then joint to joint, the last one ending at the tail tip (so one entry per
    /// `joints_x` entry) — summing to 1. The posed body recoils sideways so that its centre of
    /// mass stays on the line the fish travels ([`Body::recoil`]). Empty: no recoil (the paper's
    /// Table 1 body, which has no mass model; a species bound to a model gets its mass from the
    /// model's cross-sections).
    #[serde(default)]
    pub mass: Vec<f32>,
}

/// Errors of the motion layer: each names the value and why it is rejected.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MotionError {
    /// A parameter is NaN, infinite or out of its range.
    #[error("invalid motion parameter {name} = {value}: {why}")]
    InvalidParam {
        /// The parameter's name (a `MotionParams` field, a request field, `d`, `seconds`, …).
        name: &'static str,
        /// The rejected value.
        value: f32,
        /// Why it was rejected and what range is accepted.
        why: String,
    },
    /// A [`Body`] is malformed (joint positions not increasing, lengths disagree, ...).
    #[error("invalid body: {why}")]
    InvalidBody {
        /// What is wrong, naming the entry.
        why: String,
    },
    /// No preset has this name.
    #[error("unknown motion preset {name:?}: expected one of ex1, ex2, ex3, ex4")]
    UnknownPreset {
        /// The name asked for.
        name: String,
    },
}

/// Fraction of `l` the tail tip sweeps peak to peak in a steady swim with the default
/// parameters (Bainbridge 1958: about 0.2 body lengths).
pub const DEFAULT_TAIL_EXCURSION_BODY_LENGTHS: f32 = 0.2;

fn check(name: &'static str, value: f32, ok: bool, why: &str) -> Result<(), MotionError> {
    if !value.is_finite() {
        return Err(MotionError::InvalidParam {
            name,
            value,
            why: "must be a finite number".to_owned(),
        });
    }
    if ok {
        Ok(())
    } else {
        Err(MotionError::InvalidParam {
            name,
            value,
            why: why.to_owned(),
        })
    }
}

impl MotionParams {
    /// The values the paper's Table 1 experiments start from (the presets `ex1` … `ex4` override
    /// p, s, l, Tt and f on top of these).
    ///
    /// p = 0.4, s = 50 (one body length per second), l = 50, λ = l, ω = 3.75 so the tail beats
    /// at s·p·ω/λ = 1.5 Hz per body length per second, maxAmp = l/5, Tt = 2 s, f = 1, turn
    /// angle 90°. Kept as they were when the presets were first matched to the paper's figures, so
    /// `shoal plot --preset exN` keeps its meaning whatever the species defaults become.
    pub const TABLE_1: Self = Self {
        p: 0.4,
        s: 50.0,
        l: 50.0,
        max_amp: 50.0 / 5.0,
        lambda: 50.0,
        omega: 3.75,
        tt: 2.0,
        f: 1.0,
        turn_angle: std::f32::consts::FRAC_PI_2,
        turn_axis: None,
        front_amp: wave::FRONT_AMPLITUDE_BODY_LENGTHS,
        front_wave: wave::FrontWave::Recoil,
    };

    /// The black porgy, swimming like a carangiform fish (docs/motion.md, "Defaults and biology").
    ///
    /// Table 1's s = 50 (one body length per second), l = 50 and Tt = 2 s, with the swim wave's
    /// pivot at p = 0.3, where carangiform fish are quietest (Jayne & Lauder 1995; Videler & Hess
    /// 1984), while the body still turns about Table 1's 0.4 (`turn_axis`, near the centre of
    /// mass; the school's alignment depends on it). λ = 1.2·l, which the posed body (rigid
    /// segments, Fig. 5 weights) shows as a body wave of about one body length (carangiform fish:
    /// 0.8 – 1.2 L); ω = 6 so the tail beats at s·p·ω/λ = 1.5 Hz per body length per second;
    /// maxAmp = 0.16·l so the posed tail tip sweeps about 0.2·l peak to peak (with the body's
    /// sideways recoil, [`Body::recoil`]) and the Strouhal number is about 0.3 at every speed. The
    /// snout swings about the paper's 0.02 L, recoiling against the tail. f = 1, turn angle 90°.
    pub const BLACK_PORGY: Self = Self {
        p: 0.3,
        s: 50.0,
        l: 50.0,
        max_amp: 50.0 * 0.16,
        lambda: 50.0 * 1.2,
        omega: 6.0,
        tt: 2.0,
        f: 1.0,
        turn_angle: std::f32::consts::FRAC_PI_2,
        turn_axis: Some(0.4),
        front_amp: wave::FRONT_AMPLITUDE_BODY_LENGTHS,
        front_wave: wave::FrontWave::Recoil,
    };

    /// Checks every field: finite, and p ∈ (18.8/132, 1) so λ' > 0, s ≥ 0, l > 0, maxAmp ≥ 0,
    /// λ > 0, ω ≥ 0, Tt > 0, f ∈ [1, 2], turn angle ∈ (0, 2π], turn axis (if set) ∈ [0, 1],
    /// front amplitude ∈ [0, 0.5]. The error names the field, its
    /// value and why.
    pub fn validate(&self) -> Result<(), MotionError> {
        check(
            "p",
            self.p,
            self.p > wave::P_MIN && self.p < 1.0,
            "the pivot must lie in (18.8/132, 1) = (0.1424, 1): below it λ' = (132·p − 18.8)·λ \
             is not positive, at 1 there is no body behind the pivot",
        )?;
        check("s", self.s, self.s >= 0.0, "speed must not be negative")?;
        check("l", self.l, self.l > 0.0, "body length must be positive")?;
        check(
            "max_amp",
            self.max_amp,
            self.max_amp >= 0.0,
            "maximum amplitude must not be negative",
        )?;
        check(
            "lambda",
            self.lambda,
            self.lambda > 0.0,
            "wavelength must be positive",
        )?;
        check(
            "omega",
            self.omega,
            self.omega >= 0.0,
            "the wave-speed factor must not be negative (the wave would run tail to head)",
        )?;
        check(
            "tt",
            self.tt,
            self.tt > 0.0,
            "turning time must be positive",
        )?;
        check(
            "f",
            self.f,
            (1.0..=2.0).contains(&self.f),
            "the turn amplitude weight f must lie in [1, 2]",
        )?;
        check(
            "turn_angle",
            self.turn_angle,
            self.turn_angle > 0.0 && self.turn_angle <= std::f32::consts::TAU,
            "turn angle must lie in (0, 2π] radians",
        )?;
        if let Some(axis) = self.turn_axis {
            check(
                "turn_axis",
                axis,
                (0.0..=1.0).contains(&axis),
                "the turning axis must lie on the body: a fraction of its length in [0, 1]",
            )?;
        }
        check(
            "front_amp",
            self.front_amp,
            (0.0..=0.5).contains(&self.front_amp),
            "the front wave's snout amplitude must be a fraction of the body length in [0, 0.5]",
        )?;
        Ok(())
    }

    /// The same fish at body length `l`: maxAmp and λ scale with the body, the rest is kept.
    pub fn with_length(mut self, l: f32) -> Self {
        let k = l / self.l;
        self.max_amp *= k;
        self.lambda *= k;
        self.l = l;
        self
    }

    /// λ' = (132·p − 18.8)·λ for these parameters, length units.
    pub fn lambda_prime(&self) -> f32 {
        wave::lambda_prime(self.p, self.lambda)
    }

    /// The turning axis as a fraction of the body length: `turn_axis`, or the pivot `p`.
    pub fn turn_axis_fraction(&self) -> f32 {
        self.turn_axis.unwrap_or(self.p)
    }

    /// Tail-beat frequency at `speed` (length units per second), hertz.
    pub fn tail_beat_hz(&self, speed: f32) -> f32 {
        wave::tail_beat_hz(speed, self.p, self.omega, self.lambda)
    }
}

impl Default for MotionParams {
    /// [`MotionParams::BLACK_PORGY`].
    fn default() -> Self {
        Self::BLACK_PORGY
    }
}

impl Side {
    /// The side for the paper's `d`: −1 left, 1 right, 0 (straight ahead) none.
    pub fn from_d(d: i32) -> Result<Option<Self>, MotionError> {
        match d {
            -1 => Ok(Some(Side::Left)),
            0 => Ok(None),
            1 => Ok(Some(Side::Right)),
            _ => Err(MotionError::InvalidParam {
                name: "d",
                value: d as f32,
                why: "the turn direction d must be -1 (left), 0 (straight) or 1 (right)".to_owned(),
            }),
        }
    }
}

impl TurnKind {
    /// The motion name the player reports for this turn (`"normal_turn"`, …).
    pub fn name(self) -> &'static str {
        self.motion().name()
    }

    /// The motion this turn plays as.
    pub fn motion(self) -> MotionKind {
        match self {
            TurnKind::Normal => MotionKind::NormalTurn,
            TurnKind::Quick => MotionKind::QuickTurn,
            TurnKind::Serial => MotionKind::SerialTurn,
        }
    }
}

/// A word that names none of a motion type's values: what [`Side`]'s and [`TurnKind`]'s
/// `FromStr` return, for the script and test APIs to show. Its message lists the accepted names.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{what} must be {accepted}, got \"{got}\"")]
pub struct UnknownName {
    /// What was being parsed: `"side"` or `"kind"`.
    pub what: &'static str,
    /// The accepted names, quoted, as a phrase: `"left" or "right"`.
    pub accepted: &'static str,
    /// The word given.
    pub got: String,
}

impl std::str::FromStr for Side {
    type Err = UnknownName;

    /// `"left"` or `"right"` (lower case, as scripts write them).
    fn from_str(s: &str) -> Result<Self, UnknownName> {
        match s {
            "left" => Ok(Side::Left),
            "right" => Ok(Side::Right),
            other => Err(UnknownName {
                what: "side",
                accepted: "\"left\" or \"right\"",
                got: other.to_owned(),
            }),
        }
    }
}

impl std::str::FromStr for TurnKind {
    type Err = UnknownName;

    /// `"normal"`, `"quick"` or `"serial"` (lower case, as scripts write them).
    fn from_str(s: &str) -> Result<Self, UnknownName> {
        match s {
            "normal" => Ok(TurnKind::Normal),
            "quick" => Ok(TurnKind::Quick),
            "serial" => Ok(TurnKind::Serial),
            other => Err(UnknownName {
                what: "kind",
                accepted: "\"normal\", \"quick\" or \"serial\"",
                got: other.to_owned(),
            }),
        }
    }
}

/// Which motion a [`MotionPlayer`] is playing: one variant per [`MotionRequest`] (one per turn
/// kind) plus [`MotionKind::Idle`]. Steering and the inspector branch on this;
/// [`MotionKind::name`] is the name scripts, traces and records show.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum MotionKind {
    /// At rest with nothing queued.
    Idle,
    /// [`MotionRequest::Swim`].
    Swim,
    /// [`MotionRequest::Accelerate`].
    Accelerate,
    /// [`MotionRequest::Stop`].
    Stop,
    /// [`MotionRequest::Turn`] of [`TurnKind::Normal`].
    NormalTurn,
    /// [`MotionRequest::Turn`] of [`TurnKind::Quick`].
    QuickTurn,
    /// [`MotionRequest::Turn`] of [`TurnKind::Serial`].
    SerialTurn,
    /// [`MotionRequest::Ascend`].
    Ascend,
    /// [`MotionRequest::Descend`].
    Descend,
}

impl MotionKind {
    /// The motion's name: `"idle"`, `"swim"`, `"accelerate"`, `"stop"`, `"normal_turn"`,
    /// `"quick_turn"`, `"serial_turn"`, `"ascend"` or `"descend"`.
    pub fn name(self) -> &'static str {
        match self {
            MotionKind::Idle => "idle",
            MotionKind::Swim => "swim",
            MotionKind::Accelerate => "accelerate",
            MotionKind::Stop => "stop",
            MotionKind::NormalTurn => "normal_turn",
            MotionKind::QuickTurn => "quick_turn",
            MotionKind::SerialTurn => "serial_turn",
            MotionKind::Ascend => "ascend",
            MotionKind::Descend => "descend",
        }
    }

    /// Whether this is one of the three turns.
    pub fn is_turn(self) -> bool {
        matches!(
            self,
            MotionKind::NormalTurn | MotionKind::QuickTurn | MotionKind::SerialTurn
        )
    }
}

impl std::fmt::Display for MotionKind {
    /// Writes [`MotionKind::name`].
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl MotionRequest {
    /// Checks the request's numbers: speeds and heights finite and ≥ 0, durations finite and
    /// ≥ 0, turn angles finite in (0, 2π].
    pub fn validate(&self) -> Result<(), MotionError> {
        let speed_why = "speed must not be negative";
        let duration_why = "duration must not be negative";
        match *self {
            MotionRequest::Swim { speed } => check("speed", speed, speed >= 0.0, speed_why),
            MotionRequest::Accelerate { speed, duration } => {
                check("speed", speed, speed >= 0.0, speed_why)?;
                check("duration", duration, duration >= 0.0, duration_why)
            }
            MotionRequest::Stop { duration } => {
                check("duration", duration, duration >= 0.0, duration_why)
            }
            MotionRequest::Turn { angle, .. } => check(
                "angle",
                angle,
                angle > 0.0 && angle <= std::f32::consts::TAU,
                "turn angle must lie in (0, 2π] radians; use `side` for the direction",
            ),
            MotionRequest::Ascend { height } => check(
                "height",
                height,
                height >= 0.0,
                "height must not be negative (use Descend to sink)",
            ),
            MotionRequest::Descend { depth } => check(
                "depth",
                depth,
                depth >= 0.0,
                "depth must not be negative (use Ascend to rise)",
            ),
        }
    }

    /// The motion [`MotionPlayer::current_kind`] reports while this request plays.
    pub fn kind(&self) -> MotionKind {
        match self {
            MotionRequest::Swim { .. } => MotionKind::Swim,
            MotionRequest::Accelerate { .. } => MotionKind::Accelerate,
            MotionRequest::Stop { .. } => MotionKind::Stop,
            MotionRequest::Turn { kind, .. } => kind.motion(),
            MotionRequest::Ascend { .. } => MotionKind::Ascend,
            MotionRequest::Descend { .. } => MotionKind::Descend,
        }
    }

    /// The name [`MotionPlayer::current_name`] reports while this request plays
    /// ([`MotionKind::name`] of [`MotionRequest::kind`]).
    pub fn name(&self) -> &'static str {
        self.kind().name()
    }
}

impl RootState {
    /// Unit forward vector: (cos h · cos pitch, sin pitch, −sin h · cos pitch).
    pub fn forward(&self) -> Vec3 {
        let (sh, ch) = self.heading.sin_cos();
        let (sp, cp) = self.pitch.sin_cos();
        Vec3::new(ch * cp, sp, -sh * cp)
    }

    /// Unit vector to the fish's left in the horizontal plane: (−sin h, 0, −cos h).
    pub fn left(&self) -> Vec3 {
        let (sh, ch) = self.heading.sin_cos();
        Vec3::new(-sh, 0.0, -ch)
    }

    /// The root's rotation: heading about +y, then pitch about the fish's own +z (nose up), so
    /// that the model's +x axis maps onto [`RootState::forward`].
    pub fn rotation(&self) -> glam::Quat {
        glam::Quat::from_rotation_y(self.heading) * glam::Quat::from_rotation_z(self.pitch)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sides_and_turn_kinds_parse_from_their_script_names() {
        assert_eq!("left".parse(), Ok(Side::Left));
        assert_eq!("right".parse(), Ok(Side::Right));
        assert_eq!("normal".parse(), Ok(TurnKind::Normal));
        assert_eq!("quick".parse(), Ok(TurnKind::Quick));
        assert_eq!("serial".parse(), Ok(TurnKind::Serial));
        let e = "Left".parse::<Side>().unwrap_err();
        assert_eq!(
            e.to_string(),
            "side must be \"left\" or \"right\", got \"Left\""
        );
        let e = "sideways".parse::<TurnKind>().unwrap_err();
        assert_eq!(
            e.to_string(),
            "kind must be \"normal\", \"quick\" or \"serial\", got \"sideways\""
        );
    }

    #[test]
    fn motion_kinds_name_the_requests_that_play_them() {
        let turn = |kind| MotionRequest::Turn {
            kind,
            angle: 1.0,
            side: Side::Left,
        };
        let cases = [
            (MotionRequest::Swim { speed: 1.0 }, "swim"),
            (
                MotionRequest::Accelerate {
                    speed: 1.0,
                    duration: 1.0,
                },
                "accelerate",
            ),
            (MotionRequest::Stop { duration: 1.0 }, "stop"),
            (turn(TurnKind::Normal), "normal_turn"),
            (turn(TurnKind::Quick), "quick_turn"),
            (turn(TurnKind::Serial), "serial_turn"),
            (MotionRequest::Ascend { height: 1.0 }, "ascend"),
            (MotionRequest::Descend { depth: 1.0 }, "descend"),
        ];
        for (request, name) in cases {
            assert_eq!(request.kind().name(), name);
            assert_eq!(request.name(), name);
            assert_eq!(request.kind().to_string(), name);
            assert_eq!(
                request.kind().is_turn(),
                matches!(request, MotionRequest::Turn { .. })
            );
        }
        assert_eq!(MotionPlayer::new().current_kind(), MotionKind::Idle);
        assert_eq!(MotionPlayer::new().current_name(), "idle");
    }
}

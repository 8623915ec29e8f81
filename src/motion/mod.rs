//! Motion layer (paper sections 3.4–3.5, equations (2)–(7), Table 1).
//!
//! CONTRACT (written before the implementation so the world, the Lua host and the renderer can be
//! built against it in parallel): the public types and signatures in this file are the interface;
//! the motion work fills in the bodies and may add to it, but does not change these signatures
//! without telling the integrator.
//!
//! Conventions shared by every layer:
//! - Lengths are in the units of the species' body length `l` (Table 1 uses l = 50).
//! - World axes: +y is up. `heading` is radians counter-clockwise seen from above; heading 0
//!   faces +x, so forward = (cos h · cos pitch, sin pitch, −sin h · cos pitch). A left turn
//!   increases heading. `pitch` is radians, positive nose-up.
//! - `lateral` displacement of the midline is positive towards the fish's left; a joint's local
//!   `yaw` is positive when it bends the body towards the fish's left.
//! - `Side` follows the paper's `d`: −1 left, +1 right.

use glam::Vec3;

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
}

/// One motion request, as a behaviour script issues it (Fig. 10: played to completion in order).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum MotionRequest {
    /// Steady swim at `speed` (length units / s) until the next request.
    Swim { speed: f32 },
    /// Change speed to `speed` over `duration` seconds, then keep swimming.
    Accelerate { speed: f32, duration: f32 },
    /// Come to rest over `duration` seconds.
    Stop { duration: f32 },
    /// Turn by `angle` radians (> 0) to `side`.
    Turn {
        kind: TurnKind,
        angle: f32,
        side: Side,
    },
    /// Rise by `height` length units (pitch up, then level out).
    Ascend { height: f32 },
    /// Sink by `depth` length units (pitch down, then level out).
    Descend { depth: f32 },
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
}

/// Errors of the motion layer: each names the value and why it is rejected.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum MotionError {
    /// A parameter is NaN, infinite or out of its range.
    #[error("invalid motion parameter {name} = {value}: {why}")]
    InvalidParam {
        name: &'static str,
        value: f32,
        why: String,
    },
}

/// Plays a queue of [`MotionRequest`]s for one fish, integrating the wave phase over time.
///
/// Allocation happens only when the queue grows; `step` never allocates.
#[derive(Debug, Clone)]
pub struct MotionPlayer {
    _private: (),
}

impl MotionPlayer {
    /// A player at rest with an empty queue.
    pub fn new() -> Self {
        todo!("motion work")
    }
    /// Queues `request` after the ones already queued. Rejects NaN / out-of-range values.
    pub fn push(&mut self, request: MotionRequest) -> Result<(), MotionError> {
        let _ = request;
        todo!("motion work")
    }
    /// Drops the queue and starts `request` now, blending from the current body shape.
    pub fn interrupt(&mut self, request: MotionRequest) -> Result<(), MotionError> {
        let _ = request;
        todo!("motion work")
    }
    /// Number of requests waiting behind the current one.
    pub fn queue_len(&self) -> usize {
        todo!("motion work")
    }
    /// Name of the motion now playing (`"swim"`, `"accelerate"`, `"stop"`, `"normal_turn"`,
    /// `"quick_turn"`, `"serial_turn"`, `"ascend"`, `"descend"`, `"idle"`).
    pub fn current_name(&self) -> &'static str {
        todo!("motion work")
    }
    /// Advances by `dt` seconds: updates `root` (locomotion) and writes the midline's lateral
    /// displacement at each entry of `body.joints_x` into `lateral` and each driven joint's local
    /// yaw (radians) into `yaw`. Panics only on mismatched slice lengths (a programming error).
    pub fn step(
        &mut self,
        dt: f32,
        params: &MotionParams,
        body: &Body,
        root: &mut RootState,
        lateral: &mut [f32],
        yaw: &mut [f32],
    ) {
        let _ = (dt, params, body, root, lateral, yaw);
        todo!("motion work")
    }
}

impl Default for MotionPlayer {
    fn default() -> Self {
        Self::new()
    }
}

//! The body's shape at one midline sample: the paper's F of equations (3)–(7) for one motion, and
//! the rigid chain that the joint yaws pose.

use std::f32::consts::{PI, TAU};

use super::active::{Active, Plan};
use super::table::{WaveSample, WaveTable};
use super::{QUICK_TURN_BEND_GAIN, SERIAL_TURN_BEND_GAIN};
use crate::motion::TurnKind;
use crate::motion::wave;

/// Per-step values every shape evaluation shares.
pub(super) struct ShapeContext {
    pub(super) gain: f32,
    /// sin φ, cos φ of the swim wave's phase.
    pub(super) phase: (f32, f32),
    pub(super) tt: f32,
    pub(super) f: f32,
}

/// A motion's turn terms for this step (the same at every sample): its [`MotionTerms`], which
/// the GPU pose pass reads too, and what the table-driven F_st adds to them.
pub(super) struct TurnStep {
    terms: MotionTerms,
    /// sin and cos of the terms' 2π·ω''·t.
    sin_cos: (f32, f32),
    /// The table's turn wavelength is the motion's (else F_st is evaluated directly).
    tabled: bool,
}

impl TurnStep {
    pub(super) fn new(a: &Active, c: &ShapeContext, table: &WaveTable) -> Self {
        let terms = MotionTerms::of(a, c.tt);
        if terms.kind == MotionTerms::STROKE_TURN && terms.ip != 0.0 {
            TurnStep {
                terms,
                sin_cos: terms.omega_t.sin_cos(),
                tabled: terms.wavelength.to_bits() == table.turn_wavelength.to_bits(),
            }
        } else {
            TurnStep {
                terms,
                sin_cos: (0.0, 1.0),
                tabled: true,
            }
        }
    }
}

/// The body shape's inputs that change from step to step, for a pass that samples the shape
/// itself (the GPU pose pass; see [`super::MotionPlayer::shape_terms`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ShapeTerms {
    /// The swim wave's phase φ, radians.
    pub phase: f32,
    /// The swim wave's speed gain.
    pub gain: f32,
    /// The current motion's weight in the cross-fade (1: no previous motion).
    pub weight: f32,
    /// The current motion's turn terms.
    pub current: MotionTerms,
    /// The previous motion's (plain when there is none).
    pub previous: MotionTerms,
}

/// One motion's turn terms at the step (what [`shape`] reads of it besides the sample). Plain
/// data in the GPU pose pass's layout: it is the record's `GpuMotionShape`
/// (`crate::skin::pose_program`), read by `shaders/pose.wgsl`'s `MotionShape`.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
pub struct MotionTerms {
    /// [`MotionTerms::PLAIN_KIND`], [`MotionTerms::NORMAL_TURN`] or [`MotionTerms::STROKE_TURN`].
    pub kind: u32,
    /// The turn's side d.
    pub d: f32,
    /// I_p at the motion's time, eq. (7).
    pub ip: f32,
    /// F_st's gain over the swim amplitude (quick or serial turn).
    pub bend: f32,
    /// 2π·ω''·t of F_st.
    pub omega_t: f32,
    /// F_st's wavelength along the body, length units.
    pub wavelength: f32,
    /// strokes·π: the phase after which F_st's last lobe has left the body.
    pub stroke_end: f32,
    /// Padding to 32 bytes.
    pub _pad: u32,
}

impl MotionTerms {
    /// No turn term: the shape is the swim wave.
    pub const PLAIN_KIND: u32 = 0;
    /// A normal turn: eq. (5).
    pub const NORMAL_TURN: u32 = 1;
    /// A quick or serial turn: eq. (6), one lobe per stroke.
    pub const STROKE_TURN: u32 = 2;
    /// A motion without turn terms.
    pub const PLAIN: Self = Self {
        kind: Self::PLAIN_KIND,
        d: 0.0,
        ip: 0.0,
        bend: 0.0,
        omega_t: 0.0,
        wavelength: 1.0,
        stroke_end: 0.0,
        _pad: 0,
    };

    /// Motion `a`'s terms (Tt = `tt`): the one place a motion's plan becomes its turn terms,
    /// for the CPU's [`shape`] (through [`TurnStep`]) and the GPU pass alike.
    pub(super) fn of(a: &Active, tt: f32) -> Self {
        let Plan::Turn {
            kind,
            d,
            wavelength,
            strokes,
            ..
        } = a.plan
        else {
            return Self::PLAIN;
        };
        let ip = a.ip(a.elapsed_s);
        match kind {
            TurnKind::Normal => Self {
                kind: Self::NORMAL_TURN,
                d,
                ip,
                ..Self::PLAIN
            },
            TurnKind::Quick | TurnKind::Serial => Self {
                kind: Self::STROKE_TURN,
                d,
                ip,
                bend: if kind == TurnKind::Quick {
                    QUICK_TURN_BEND_GAIN
                } else {
                    SERIAL_TURN_BEND_GAIN
                },
                omega_t: if ip != 0.0 {
                    TAU * wave::omega_2(tt) * a.elapsed_s
                } else {
                    0.0
                },
                wavelength,
                stroke_end: strokes as f32 * PI,
                _pad: 0,
            },
        }
    }
}

/// The paper's F (positive to the fish's right) of motion `a` at midline sample `s` (see
/// [`WaveTable`]); `turn` holds the motion's turn terms for this step.
pub(super) fn shape(a: &Active, c: &ShapeContext, turn: &TurnStep, s: &WaveSample) -> f32 {
    // sin(2π·x'/λ − φ) (λ' in front of the pivot): eq. (3)/(4) without the amplitude.
    let (sin_phi, cos_phi) = c.phase;
    let travelling = s.swim.0 * cos_phi - s.swim.1 * sin_phi;
    let swim = s.amp * c.gain * travelling;
    let m = &turn.terms;
    let (ip, xp, amp) = (m.ip, s.xp, s.amp);
    if m.kind == MotionTerms::PLAIN_KIND || ip == 0.0 || xp <= 0.0 {
        // Not a turn, or the turn functions only change the part behind the pivot (paper
        // 3.5.2). A sample on the pivot (x' = 0, as the black porgy's first joint is) has
        // A(x) = 0, so its swim and turn waves are both 0 and (7) gives 0 = `swim`: skip them.
        return swim;
    }
    let t = if m.kind == MotionTerms::NORMAL_TURN {
        // Eq. (5), F_nt = A(x)·(sin(2π·x'/λ − φ) + d)·f: behind the pivot its sine is the swim
        // wave's.
        amp * (travelling + m.d) * c.f
    } else {
        // One |sin| lobe per stroke: the bend enters at the pivot when the stroke starts and
        // runs to the tail; before it arrives (and after the last stroke) a point is not bent,
        // so no lobe of a stroke that never happened shows.
        let theta = m.omega_t - TAU * xp / m.wavelength;
        if theta < 0.0 || theta > m.stroke_end {
            0.0
        } else {
            let a_st = amp * m.bend * c.f;
            if turn.tabled {
                // Eq. (6), F_st = A·d·|sin(2π·x'/Λ'' − 2π·ω''·t)|, by angle subtraction.
                let (sin_t, cos_t) = turn.sin_cos;
                a_st * m.d * (s.turn.0 * cos_t - s.turn.1 * sin_t).abs()
            } else {
                wave::f_st(a_st, xp, m.wavelength, a.elapsed_s, c.tt, m.d)
            }
        }
    };
    wave::t_locomotion(swim, t, ip)
}

/// Sideways displacement (positive left) of each `joints_x` sample of the rigid chain that starts
/// `head_lateral` to the side, leaves the head at `head_yaw` and bends by `yaw` at each driven
/// joint. Segment lengths are Δx·l.
pub(super) fn posed_lateral(
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

//! [`WaveTable`]: the body wave's per-body constants, built once per species.

use std::f32::consts::TAU;

use super::TURN_WAVELENGTH_BODY_LENGTHS;
use crate::motion::wave;
use crate::motion::{Body, MotionParams};

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
///
/// [`MotionPlayer::step_with`]: super::MotionPlayer::step_with
/// [`MotionPlayer::step`]: super::MotionPlayer::step
#[derive(Debug, Clone, Default)]
pub struct WaveTable {
    /// The parameters and midline samples it was built for, bit for bit.
    params_bits: [u32; 11],
    joints_x_bits: Vec<u32>,
    /// Wavelength of the quick/serial turn wave along the body (as `Active::start` plans it).
    pub(super) turn_wavelength: f32,
    /// Head first, then one per `joints_x` entry.
    pub(super) samples: Vec<WaveSample>,
}

/// One midline sample's constants (see [`WaveTable`]).
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct WaveSample {
    /// x' = x·l − p·l, length units.
    pub(super) xp: f32,
    /// A(x), length units (before the speed gain).
    pub(super) amp: f32,
    /// sin and cos of the swim wave's spatial argument: 2π·x'/λ' in front of the pivot, 2π·x'/λ
    /// behind it (also F_nt's argument there).
    pub(super) swim: (f32, f32),
    /// sin and cos of F_st's spatial argument 2π·x'/Λ''.
    pub(super) turn: (f32, f32),
}

fn param_bits(params: &MotionParams) -> [u32; 11] {
    // Every field named, none skipped with `..`: a new parameter does not compile until it is
    // decided here whether the table depends on it.
    let MotionParams {
        p,
        s,
        l,
        max_amp,
        lambda,
        omega,
        tt,
        f,
        turn_angle,
        // Not read when the table is built.
        turn_axis: _,
        front_amp,
        front_wave,
    } = *params;
    [
        front_amp,
        f32::from(match front_wave {
            wave::FrontWave::Recoil => 0u8,
            wave::FrontWave::Travelling => 1,
            wave::FrontWave::Anguilliform => 2,
        }),
        p,
        s,
        l,
        max_amp,
        lambda,
        omega,
        tt,
        f,
        turn_angle,
    ]
    .map(f32::to_bits)
}

/// The quick/serial turn wave's wavelength along the body, length units: λ'' = 2·Tt is a period;
/// the swim wave's phase speed ω' at cruising speed turns it into a length along the body, at
/// least [`TURN_WAVELENGTH_BODY_LENGTHS`]·l so the bend stays one smooth C instead of folding.
pub(super) fn turn_wavelength(params: &MotionParams) -> f32 {
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

    /// Each midline sample's constants, head first: x' and A(x) (length units), and the sine
    /// and cosine of the swim wave's spatial argument (for the GPU pose pass's shape step).
    pub(crate) fn shape_samples(&self) -> impl Iterator<Item = (f32, f32, (f32, f32))> + '_ {
        self.samples.iter().map(|s| (s.xp, s.amp, s.swim))
    }

    /// Rebuilds in place for `params` and `body` (allocates only to grow).
    pub(super) fn rebuild(&mut self, params: &MotionParams, body: &Body) {
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
                    let swim =
                        wave::swim_argument(xp, params.lambda, lambda_prime, params.front_wave);
                    WaveSample {
                        xp,
                        amp: wave::swim_amplitude(
                            xl,
                            p,
                            l,
                            params.max_amp,
                            (params.front_amp, params.front_wave),
                        ),
                        swim: swim.sin_cos(),
                        turn: (TAU * xp / wavelength).sin_cos(),
                    }
                }),
        );
    }
}

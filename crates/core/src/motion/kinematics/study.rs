//! A kinematic study of one fish, as `shoal kinematics` runs it: the fish swimming steadily at
//! each speed asked for, measured with [`super::analyze`], and the published ranges biologists
//! report for its swimming mode (docs/motion.md cites each).

use serde::Serialize;

use super::{Kinematics, KinematicsError, MidlineSeries, analyze, default_stations, record_swim};
use crate::motion::{Body, FrontWave, MotionError, MotionParams};

/// Why a study could not measure a fish.
#[derive(Debug, thiserror::Error)]
pub enum StudyError {
    /// The swim could not be played (a motion parameter out of range).
    #[error(transparent)]
    Motion(#[from] MotionError),
    /// The sampled midline could not be analysed at one speed.
    #[error("{name} at {speed} body lengths per second: {source}")]
    Analysis {
        /// The subject's name.
        name: String,
        /// The speed, body lengths per second.
        speed: f32,
        /// Why.
        source: KinematicsError,
    },
}

/// Which published data the plot and the text compare with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// Carangiform swimmers (bass, mackerel, porgies): amplitude mostly at the tail.
    Carangiform,
    /// Anguilliform swimmers (eels): the whole body undulates.
    Anguilliform,
}

impl Mode {
    /// The mode a species swims in, by its front wave: a wave running from the snout
    /// ([`FrontWave::Travelling`], [`FrontWave::Anguilliform`]) is anguilliform, a front
    /// recoiling about the pivot carangiform.
    pub fn of(params: &MotionParams) -> Self {
        match params.front_wave {
            FrontWave::Travelling | FrontWave::Anguilliform => Mode::Anguilliform,
            FrontWave::Recoil => Mode::Carangiform,
        }
    }
}

/// Fastest speed accepted, body lengths per second (sustained swimming rarely exceeds 10 L/s).
pub const MAX_SPEED_BODY_LENGTHS_PER_S: f32 = 20.0;
/// Seconds of steady swimming measured at each speed.
pub const SECONDS: f32 = 8.0;
/// Midline samples per second.
pub const RATE_HZ: f32 = 480.0;

/// What is measured: a named set of motion parameters on a body.
#[derive(Debug, Clone)]
pub struct Subject {
    /// `black_porgy`, `ex1`, …
    pub name: String,
    /// Where it came from (a species file, or "Table 1").
    pub source: String,
    /// Motion parameters.
    pub params: MotionParams,
    /// The body the motion drives (the species' rig, or the paper's 6-joint body).
    pub body: Body,
    /// The published data it is compared with.
    pub mode: Mode,
}

/// One speed's measurement.
#[derive(Debug, Clone, Serialize)]
pub struct Measurement {
    /// The speed asked for, body lengths per second.
    pub requested_speed_body_lengths_per_s: f32,
    /// What was measured.
    #[serde(flatten)]
    pub kinematics: Kinematics,
    /// The sampled midlines (for the plot; not printed).
    #[serde(skip)]
    pub series: MidlineSeries,
}

/// Measures `subject` at each speed.
pub fn measure(subject: &Subject, speeds: &[f32]) -> Result<Vec<Measurement>, StudyError> {
    let stations = default_stations();
    speeds
        .iter()
        .map(|&v| {
            let series = record_swim(
                &subject.params,
                &subject.body,
                v,
                SECONDS,
                RATE_HZ,
                &stations,
            )?;
            let k = analyze(&series).map_err(|source| StudyError::Analysis {
                name: subject.name.clone(),
                speed: v,
                source,
            })?;
            Ok(Measurement {
                requested_speed_body_lengths_per_s: v,
                kinematics: k,
                series,
            })
        })
        .collect()
}

/// A published range a quantity should fall in.
#[derive(Debug, Clone, Copy)]
pub struct Range {
    /// The quantity, as the table names it.
    pub what: &'static str,
    /// Lower bound.
    pub lo: f32,
    /// Upper bound.
    pub hi: f32,
    /// Where it comes from (docs/motion.md cites each, with the figure or table and how sure
    /// we are).
    pub source: &'static str,
    /// The measured value it is compared with.
    pub measured: fn(&Kinematics) -> f32,
}

impl Range {
    /// Whether `k`'s value lies in the range.
    pub fn holds(&self, k: &Kinematics) -> bool {
        (self.lo..=self.hi).contains(&(self.measured)(k))
    }
}

fn snout(k: &Kinematics) -> f32 {
    k.envelope.first().map_or(f32::NAN, |p| p.amplitude)
}

fn tail(k: &Kinematics) -> f32 {
    k.envelope.last().map_or(f32::NAN, |p| p.amplitude)
}

fn smallest(k: &Kinematics) -> f32 {
    k.envelope
        .iter()
        .map(|p| p.amplitude)
        .fold(f32::INFINITY, f32::min)
}

/// The published ranges for `mode` (docs/motion.md, "Sources", cites each: paper and where in
/// it). The tests hold every shipped species of that mode to all of them, at 0.5 – 3 L/s.
/// Where the eel sources give no number, the anguilliform range is the sea lamprey's measured
/// value ± 20 % ([`LAMPREY`]; fishmechr's `lampreydata`, `tests/data/midline/lamprey.csv`).
pub fn published(mode: Mode) -> (&'static str, &'static [Range]) {
    match mode {
        Mode::Carangiform => (
            "carangiform",
            &[
                Range {
                    what: "snout amplitude a(0) (L)",
                    lo: 0.004,
                    hi: 0.03,
                    source: "Jayne & Lauder 1995 abstract (bass 0.004-0.012) to the mackerel model's 0.02",
                    measured: snout,
                },
                Range {
                    what: "smallest amplitude at x (L)",
                    lo: 0.15,
                    hi: 0.35,
                    source: "Jayne & Lauder 1995 abstract (rise from ~0.25 L); mackerel model 0.25 L",
                    measured: |k| k.min_amplitude_x,
                },
                Range {
                    what: "smallest amplitude (L)",
                    lo: 0.0,
                    hi: 0.012,
                    source: "Jayne & Lauder 1995 abstract (first caudal vertebra <= 0.012 L)",
                    measured: smallest,
                },
                Range {
                    what: "tail amplitude a(1) (L)",
                    lo: 0.05,
                    hi: 0.11,
                    source: "Jayne & Lauder 1995 abstract (0.053-0.066 L); Bainbridge 1958 (A/2 ~ 0.1 L)",
                    measured: tail,
                },
                Range {
                    what: "tail excursion A, peak to peak (L)",
                    lo: 0.16,
                    hi: 0.22,
                    source: "Bainbridge 1958 abstract (about one-fifth of L)",
                    measured: |k| k.tail_amplitude_peak_to_peak,
                },
                Range {
                    what: "body wavelength λb (L)",
                    lo: 0.7,
                    hi: 1.2,
                    source: "Webb et al. 1984 abstract (trout 0.72-1.07 L); bonito 1.20 L (JEB 206:2749)",
                    measured: |k| k.wavelength,
                },
                Range {
                    what: "Strouhal number",
                    lo: 0.2,
                    hi: 0.4,
                    source: "Saadat et al. 2017 abstract (0.2-0.4)",
                    measured: |k| k.strouhal,
                },
                Range {
                    what: "stride length (L)",
                    lo: 0.5,
                    hi: 0.8,
                    source: "Bainbridge 1958 abstract: V = L(3f-4)/4 gives 0.55-0.75 L",
                    measured: |k| k.stride_length,
                },
            ],
        ),
        Mode::Anguilliform => (
            "anguilliform",
            &[
                Range {
                    what: "snout amplitude a(0) (L)",
                    lo: 0.0,
                    hi: LAMPREY.snout,
                    source: "at most the lamprey's measured 0.028 L; Gillis 1998, D'Août & Aerts 1999 abstracts: minimal",
                    measured: snout,
                },
                Range {
                    what: "smallest amplitude at x (L)",
                    lo: 0.0,
                    hi: 0.15,
                    source: "lamprey measured 0.11 L; D'Août & Aerts 1999 abstract: head yaw minimal",
                    measured: |k| k.min_amplitude_x,
                },
                Range {
                    what: "smallest amplitude (L)",
                    lo: 0.0,
                    hi: 0.02,
                    source: "lamprey measured 0.017 L; Gillis 1998 abstract: front not undulating",
                    measured: smallest,
                },
                Range {
                    what: "tail amplitude a(1) (L)",
                    lo: 0.07,
                    hi: 0.09,
                    source: "Gillis 1998 abstract (0.08 L); D'Août & Aerts 1999 abstract (0.075 L)",
                    measured: tail,
                },
                Range {
                    what: "body wavelength λb (L)",
                    lo: 0.8 * LAMPREY.wavelength,
                    hi: 1.2 * LAMPREY.wavelength,
                    source: "lamprey measured 0.67 L, ± 20 %",
                    measured: |k| k.wavelength,
                },
                Range {
                    what: "waves on the body",
                    lo: 1.05,
                    hi: 1.2 / LAMPREY.wavelength,
                    source: "more than one; lamprey measured 1.49, + 20 %",
                    measured: |k| k.waves_on_body,
                },
                Range {
                    what: "Strouhal number",
                    lo: 0.25,
                    hi: 0.4,
                    source: "Tytell 2004, Proc. R. Soc. B abstract: close to 0.32 at 0.6-1.9 L/s",
                    measured: |k| k.strouhal,
                },
                Range {
                    what: "stride length (L)",
                    lo: 0.8 * LAMPREY.stride_length,
                    hi: 1.2 * LAMPREY.stride_length,
                    source: "lamprey measured 0.44 L, ± 20 %",
                    measured: |k| k.stride_length,
                },
                Range {
                    what: "slip U/V",
                    lo: 0.8 * LAMPREY.slip,
                    hi: 1.2 * LAMPREY.slip,
                    source: "lamprey measured 0.65, ± 20 %",
                    measured: |k| k.slip,
                },
            ],
        ),
    }
}

/// What `shoal kinematics --midline tests/data/midline/lamprey.csv` measures on fishmechr's sea
/// lamprey (a test re-measures it and fails if these drift): the anguilliform ranges that the
/// eel sources give no number for are built from it.
pub struct LampreyFigures {
    /// a(0), L.
    pub snout: f32,
    /// λb, L.
    pub wavelength: f32,
    /// U/f, L.
    pub stride_length: f32,
    /// U/V.
    pub slip: f32,
}

/// The sea lamprey's measured figures (see [`LampreyFigures`]).
pub const LAMPREY: LampreyFigures = LampreyFigures {
    snout: 0.028,
    wavelength: 0.67,
    stride_length: 0.44,
    slip: 0.65,
};

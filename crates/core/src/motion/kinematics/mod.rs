//! Swimming kinematics measured the way fish biologists measure them, from sampled midlines.
//!
//! Biologists film a fish swimming steadily, digitise its midline frame by frame and report a
//! handful of numbers (Jayne & Lauder 1995; Webb et al. 1984; the sources and where in them are
//! listed in docs/motion.md). This module
//! does the same to *our* fish: [`record_swim`] plays a steady swim on the motion layer and samples
//! the posed midline (the chain a renderer draws, not the wave parameters) at stations along the
//! body; [`analyze`] turns any such series into [`Kinematics`]. `analyze` is a pure function of
//! the samples, so it is tested on synthetic travelling waves with known answers.
//!
//! Definitions (all lengths in body lengths L, `x` from the snout (0) to the tail tip (1)):
//! - **lateral displacement** y(x, t): sideways distance of the midline from the line the fish
//!   travels along, positive to the fish's left.
//! - **tail-beat frequency** f: upward zero crossings of the tail tip's y (about its mean) per
//!   second, over whole beats.
//! - **amplitude envelope** a(x): half the peak-to-peak y at station x over whole beats (the
//!   "amplitude" or z_max of most kinematic papers).
//! - **tail amplitude** A: the tail tip's *peak-to-peak* excursion, 2·a(1) (Bainbridge 1958's
//!   "amplitude", and the A of the Strouhal number).
//! - **body wavelength** λ_b: 2π over the rate at which the phase of y at frequency f lags along
//!   the posterior half of the body (0.5–1 L), a least-squares fit; for a steady travelling wave
//!   this is the crest-to-crest distance.
//! - **waves on the body**: 1/λ_b, how many body wavelengths fit on the body (more than one in
//!   anguilliform swimmers).
//! - **wave speed** V = f·λ_b; **swimming speed** U: distance travelled over time.
//! - **stride length** U/f: distance per tail beat; **slip** U/V; **Strouhal number** St = f·A/U.

mod midline;
mod study;

use std::f32::consts::TAU;

use glam::Vec3;
use serde::Serialize;

pub use midline::{
    FIRST_WINDOW_S, MIN_TRAVEL_BODY_LENGTHS_PER_S, MeasuredMidline, MidlineError, MidlineInfo,
    MidlineMeasurement, measure_midline, parse_midline, read_midline,
};
pub use study::{
    LAMPREY, LampreyFigures, MAX_SPEED_BODY_LENGTHS_PER_S, Measurement, Mode, RATE_HZ, Range,
    SECONDS, StudyError, Subject, measure, published,
};

use super::{
    Body, MidlinePoseJob, MotionError, MotionParams, MotionPlayer, MotionRequest, RootState,
};

/// Stations along the body at which [`record_swim`] samples the midline by default: 21, every
/// 0.05 body lengths from the snout (0) to the tail tip (1).
pub fn default_stations() -> Vec<f32> {
    (0..=20).map(|i| i as f32 / 20.0).collect()
}

/// Midline samples over time: the input of [`analyze`].
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MidlineSeries {
    /// Samples per second.
    pub rate_hz: f32,
    /// Stations, fractions of body length from the snout (0) to the tail tip (1), increasing.
    pub stations: Vec<f32>,
    /// Lateral displacement, body lengths, positive to the fish's left: frame-major
    /// (`lateral[k * stations.len() + i]` is station `i` at time `k / rate_hz`).
    pub lateral: Vec<f32>,
    /// Distance travelled along the path at each frame, body lengths.
    pub forward: Vec<f32>,
}

impl MidlineSeries {
    /// Number of frames.
    pub fn num_frames(&self) -> usize {
        self.forward.len()
    }

    /// The lateral displacements of frame `k`, one per station.
    pub fn frame(&self, k: usize) -> &[f32] {
        let n = self.stations.len();
        &self.lateral[k * n..(k + 1) * n]
    }
}

/// One station of the amplitude envelope.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct EnvelopePoint {
    /// Station, fraction of body length from the snout.
    pub x: f32,
    /// Half the peak-to-peak lateral displacement there, body lengths.
    pub amplitude: f32,
}

/// What [`analyze`] measures (definitions in the module docs). Lengths in body lengths L.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Kinematics {
    /// Swimming speed U, body lengths per second.
    pub speed_body_lengths_per_s: f32,
    /// Tail-beat frequency f, hertz.
    pub tail_beat_hz: f32,
    /// Whole tail beats analysed.
    pub num_beats: usize,
    /// Peak-to-peak excursion of the tail tip, A.
    pub tail_amplitude_peak_to_peak: f32,
    /// Half peak-to-peak lateral displacement at each station, snout to tail tip.
    pub envelope: Vec<EnvelopePoint>,
    /// Station with the smallest amplitude, fraction of body length.
    pub min_amplitude_x: f32,
    /// Body wavelength λ_b, body lengths.
    pub wavelength: f32,
    /// Body wavelengths on the body, 1/λ_b.
    pub waves_on_body: f32,
    /// Wave speed V = f·λ_b, body lengths per second.
    pub wave_speed_body_lengths_per_s: f32,
    /// Stride length U/f, body lengths per tail beat.
    pub stride_length: f32,
    /// Slip U/V.
    pub slip: f32,
    /// Strouhal number St = f·A/U.
    pub strouhal: f32,
}

impl Kinematics {
    /// The envelope's amplitude at station `x` (linear between stations), body lengths.
    pub fn amplitude_at(&self, x: f32) -> f32 {
        let e = &self.envelope;
        match e.iter().position(|p| p.x >= x) {
            Some(0) => e[0].amplitude,
            Some(i) => {
                let (a, b) = (e[i - 1], e[i]);
                a.amplitude + (x - a.x) / (b.x - a.x) * (b.amplitude - a.amplitude)
            }
            None => e.last().map_or(0.0, |p| p.amplitude),
        }
    }
}

/// Why a midline series cannot be analysed.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum KinematicsError {
    /// The series' arrays disagree, or the stations are not increasing from snout to tail tip.
    #[error("malformed midline series: {why}")]
    Malformed {
        /// What is wrong.
        why: String,
    },
    /// The tail did not beat at least twice (three upward crossings of its mean line).
    #[error(
        "the tail tip crossed its mean line upwards {crossings} time(s); at least 3 (two whole \
         beats) are needed: record longer, or the fish is not beating its tail"
    )]
    TooFewBeats {
        /// Upward crossings found.
        crossings: usize,
    },
    /// The fish did not move forward, so stride, slip and Strouhal number are undefined.
    #[error(
        "the fish moved {speed} body lengths per second; stride length, slip and Strouhal \
         number need forward motion"
    )]
    NotSwimming {
        /// Measured speed, body lengths per second.
        speed: f32,
    },
}

/// Times (seconds) at which `y` (about its mean `mean`) crosses upwards, by linear interpolation.
fn upward_crossings(y: impl Iterator<Item = f32>, mean: f32, dt: f32) -> Vec<f32> {
    let mut out = Vec::new();
    let mut prev: Option<f32> = None;
    for (k, v) in y.enumerate() {
        let v = v - mean;
        if let Some(p) = prev
            && p < 0.0
            && v >= 0.0
        {
            let u = -p / (v - p);
            out.push((k as f32 - 1.0 + u) * dt);
        }
        prev = Some(v);
    }
    out
}

/// Measures `series` (definitions in the module docs).
///
/// Fails if the arrays disagree or the stations are not increasing within [0, 1] with the last
/// one at the tail tip, if the tail does not beat at least twice, or if the fish does not move
/// forward.
pub fn analyze(series: &MidlineSeries) -> Result<Kinematics, KinematicsError> {
    let malformed = |why: String| Err(KinematicsError::Malformed { why });
    let n = series.stations.len();
    let frames = series.num_frames();
    if n < 2 {
        return malformed(format!(
            "{n} stations; at least the snout and the tail tip are needed"
        ));
    }
    if series.lateral.len() != n * frames {
        return malformed(format!(
            "{} lateral samples for {frames} frames × {n} stations",
            series.lateral.len()
        ));
    }
    if !(series.rate_hz.is_finite() && series.rate_hz > 0.0) {
        return malformed(format!("rate_hz = {} must be positive", series.rate_hz));
    }
    if series.stations.windows(2).any(|w| w[1] <= w[0])
        || series.stations[0] < 0.0
        || series.stations[n - 1] != 1.0
    {
        return malformed(format!(
            "stations {:?} must increase within [0, 1] and end at the tail tip (1)",
            series.stations
        ));
    }
    if series
        .lateral
        .iter()
        .chain(&series.forward)
        .any(|v| !v.is_finite())
    {
        return malformed("a sample is not a finite number".to_owned());
    }
    let dt = 1.0 / series.rate_hz;
    let tail = |k: usize| series.lateral[k * n + n - 1];
    let tail_mean = (0..frames).map(tail).sum::<f32>() / frames.max(1) as f32;
    let crossings = upward_crossings((0..frames).map(tail), tail_mean, dt);
    if crossings.len() < 3 {
        return Err(KinematicsError::TooFewBeats {
            crossings: crossings.len(),
        });
    }
    let num_beats = crossings.len() - 1;
    let (t0, t1) = (crossings[0], crossings[num_beats]);
    let tail_beat_hz = num_beats as f32 / (t1 - t0);
    // Whole frames inside the whole beats.
    let k0 = (t0 / dt).ceil() as usize;
    let k1 = ((t1 / dt).floor() as usize).min(frames - 1);

    let speed = (series.forward[k1] - series.forward[k0]) / ((k1 - k0) as f32 * dt);
    if speed.is_nan() || speed <= 0.0 {
        return Err(KinematicsError::NotSwimming { speed });
    }

    // Envelope, and each station's phase at the tail-beat frequency (a one-bin Fourier transform
    // over the whole beats).
    let mut envelope = Vec::with_capacity(n);
    let mut phase = Vec::with_capacity(n);
    let omega = TAU * tail_beat_hz;
    for (i, &x) in series.stations.iter().enumerate() {
        let (mut lo, mut hi) = (f32::INFINITY, f32::NEG_INFINITY);
        let (mut re, mut im) = (0.0f64, 0.0f64);
        for k in k0..k1 {
            let y = series.lateral[k * n + i];
            lo = lo.min(y);
            hi = hi.max(y);
            let (s, c) = (omega * k as f32 * dt).sin_cos();
            re += f64::from(y * c);
            im -= f64::from(y * s);
        }
        envelope.push(EnvelopePoint {
            x,
            amplitude: 0.5 * (hi - lo),
        });
        phase.push(im.atan2(re) as f32);
    }
    // Unwrap along the body so the phase is continuous from snout to tail.
    for i in 1..n {
        let mut d = phase[i] - phase[i - 1];
        while d > std::f32::consts::PI {
            d -= TAU;
        }
        while d < -std::f32::consts::PI {
            d += TAU;
        }
        phase[i] = phase[i - 1] + d;
    }
    // A tail-ward travelling wave y = a·sin(2π(x/λ − f·t)) has phase −2π·x/λ + const.
    let fit: Vec<(f32, f32)> = series
        .stations
        .iter()
        .zip(&phase)
        .filter(|(x, _)| **x >= 0.5 - 1e-6)
        .map(|(&x, &p)| (x, p))
        .collect();
    let slope = if fit.len() >= 2 {
        let m = fit.len() as f32;
        let mx = fit.iter().map(|p| p.0).sum::<f32>() / m;
        let my = fit.iter().map(|p| p.1).sum::<f32>() / m;
        let sxy: f32 = fit.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
        let sxx: f32 = fit.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
        sxy / sxx
    } else {
        (phase[n - 1] - phase[0]) / (series.stations[n - 1] - series.stations[0])
    };
    let wavelength = if slope < 0.0 {
        TAU / -slope
    } else {
        f32::INFINITY
    };
    let waves_on_body = 1.0 / wavelength;
    let wave_speed = wavelength * tail_beat_hz;
    let tail_amplitude = 2.0 * envelope[n - 1].amplitude;
    let min_amplitude_x = envelope
        .iter()
        .min_by(|a, b| a.amplitude.total_cmp(&b.amplitude))
        .map_or(0.0, |p| p.x);
    Ok(Kinematics {
        speed_body_lengths_per_s: speed,
        tail_beat_hz,
        num_beats,
        tail_amplitude_peak_to_peak: tail_amplitude,
        envelope,
        min_amplitude_x,
        wavelength,
        waves_on_body,
        wave_speed_body_lengths_per_s: wave_speed,
        stride_length: speed / tail_beat_hz,
        slip: speed / wave_speed,
        strouhal: tail_beat_hz * tail_amplitude / speed,
    })
}

/// Seconds of swimming [`record_swim`] lets pass before it starts sampling.
pub const SETTLE_S: f32 = 1.0;

/// Plays a steady swim at `speed_body_lengths_per_s` with `params` on `body` and samples the
/// posed midline (head, driven joints and tail tip joined by straight segments, exactly the chain
/// [`MidlinePoseJob`] places) at `stations` for `seconds` at `rate_hz`, after [`SETTLE_S`].
///
/// The fish starts at the requested speed (no ramp). Fails on invalid parameters or body, a
/// speed that is not a positive finite number, `seconds` or `rate_hz` not positive, or more than
/// [`super::record::MAX_FRAMES`] frames.
pub fn record_swim(
    params: &MotionParams,
    body: &Body,
    speed_body_lengths_per_s: f32,
    seconds: f32,
    rate_hz: f32,
    stations: &[f32],
) -> Result<MidlineSeries, MotionError> {
    params.validate()?;
    body.validate()?;
    let positive = |name: &'static str, v: f32| {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(MotionError::InvalidParam {
                name,
                value: v,
                why: "must be a positive number".to_owned(),
            })
        }
    };
    positive("speed", speed_body_lengths_per_s)?;
    positive("seconds", seconds)?;
    positive("rate", rate_hz)?;
    let settle = (SETTLE_S * rate_hz).round() as usize;
    let steps = (seconds * rate_hz).round() as usize;
    if settle + steps + 1 > super::record::MAX_FRAMES {
        return Err(MotionError::InvalidParam {
            name: "seconds",
            value: seconds,
            why: format!(
                "{} frames; at most {} are allowed",
                settle + steps + 1,
                super::record::MAX_FRAMES
            ),
        });
    }
    let l = params.l;
    let speed = speed_body_lengths_per_s * l;
    let mut player = MotionPlayer::new();
    player.push(MotionRequest::Swim { speed })?;
    let mut root = RootState {
        speed,
        ..RootState::default()
    };
    let mut lateral = vec![0.0; body.joints_x.len()];
    let mut yaw = vec![0.0; body.num_joints()];
    let mut points = vec![Vec3::ZERO; body.joints_x.len() + 1];
    // Arc length of each chain point from the snout, fractions of body length.
    let chain_x: Vec<f32> = std::iter::once(0.0)
        .chain(body.joints_x.iter().copied())
        .collect();
    let dt = 1.0 / rate_hz;
    let mut series = MidlineSeries {
        rate_hz,
        stations: stations.to_vec(),
        lateral: Vec::with_capacity((steps + 1) * stations.len()),
        forward: Vec::with_capacity(steps + 1),
    };
    for k in 0..=settle + steps {
        player.step(
            if k == 0 { 0.0 } else { dt },
            params,
            body,
            &mut root,
            &mut lateral,
            &mut yaw,
        );
        if k < settle {
            continue;
        }
        // The chain in the root's own frame (heading 0, at the origin): sideways is −z.
        let frame_root = RootState {
            pos: Vec3::ZERO,
            heading: 0.0,
            pitch: 0.0,
            speed: root.speed,
        };
        MidlinePoseJob {
            root: &frame_root,
            body,
            l,
            head_lateral: player.head_lateral(),
            head_yaw: player.head_yaw(),
            yaw: &yaw,
            points: &mut points,
        }
        .run()?;
        for &s in stations {
            let i = chain_x
                .iter()
                .rposition(|&x| x <= s)
                .unwrap_or(0)
                .min(chain_x.len() - 2);
            let u = ((s - chain_x[i]) / (chain_x[i + 1] - chain_x[i])).clamp(0.0, 1.0);
            let p = points[i].lerp(points[i + 1], u);
            series.lateral.push(-p.z / l);
        }
        // The straight swim keeps the heading it started with (0): the path is the x axis.
        series.forward.push(root.pos.x / l);
    }
    Ok(series)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// y(x, t) = a(x)·sin(2π(x/λ − f·t)), the fish moving at `speed`.
    fn synthetic(
        envelope: impl Fn(f32) -> f32,
        wavelength: f32,
        f: f32,
        speed: f32,
        seconds: f32,
    ) -> MidlineSeries {
        let rate_hz = 200.0;
        let stations = default_stations();
        let frames = (seconds * rate_hz) as usize + 1;
        let mut lateral = Vec::new();
        let mut forward = Vec::new();
        for k in 0..frames {
            let t = k as f32 / rate_hz;
            for &x in &stations {
                lateral.push(envelope(x) * (TAU * (x / wavelength - f * t)).sin());
            }
            forward.push(speed * t);
        }
        MidlineSeries {
            rate_hz,
            stations,
            lateral,
            forward,
        }
    }

    /// A synthetic carangiform-like envelope with a known answer (0.02 − 0.0825x + 0.1625x²: a
    /// small snout amplitude, a quietest point near 0.25 L, 0.1 L at the tail); not a citation.
    fn synthetic_envelope(x: f32) -> f32 {
        0.02 - 0.0825 * x + 0.1625 * x * x
    }

    #[test]
    fn test_travelling_wave_known_answers() {
        // f = 2 Hz, λ = 0.9 L, U = 1.2 L/s, over 3.3 s. The tail tip y = a·sin(2π/0.9 − 4π·t)
        // crosses upwards where its argument is π (mod 2π): t = 0.306 + 0.5·k s, k = 0 … 5, so
        // six crossings, five whole beats.
        let k = analyze(&synthetic(synthetic_envelope, 0.9, 2.0, 1.2, 3.3)).unwrap();
        assert!((k.tail_beat_hz - 2.0).abs() < 0.01, "{}", k.tail_beat_hz);
        assert_eq!(k.num_beats, 5);
        assert!((k.speed_body_lengths_per_s - 1.2).abs() < 1e-3);
        for p in &k.envelope {
            assert!(
                (p.amplitude - synthetic_envelope(p.x)).abs() < 1e-3,
                "a({}) = {} vs {}",
                p.x,
                p.amplitude,
                synthetic_envelope(p.x)
            );
        }
        assert!((k.tail_amplitude_peak_to_peak - 0.2).abs() < 2e-3);
        assert!((k.wavelength - 0.9).abs() < 0.01, "{}", k.wavelength);
        assert!(
            (k.waves_on_body - 1.0 / 0.9).abs() < 0.02,
            "{}",
            k.waves_on_body
        );
        assert!((k.wave_speed_body_lengths_per_s - 1.8).abs() < 0.03);
        assert!((k.stride_length - 0.6).abs() < 0.01);
        assert!((k.slip - 1.2 / 1.8).abs() < 0.01);
        assert!((k.strouhal - 2.0 * 0.2 / 1.2).abs() < 0.01);
        // The synthetic_envelope's envelope is smallest at x = 0.0825 / 0.325 ≈ 0.25.
        assert!(
            (k.min_amplitude_x - 0.25).abs() < 0.03,
            "{}",
            k.min_amplitude_x
        );
        assert!((k.amplitude_at(0.525) - synthetic_envelope(0.525)).abs() < 2e-3);
    }

    #[test]
    fn test_short_wave_and_uniform_envelope() {
        // An eel-like wave: λ = 0.6 L, 1.67 waves on the body, f = 3 Hz.
        let k = analyze(&synthetic(|_| 0.05, 0.6, 3.0, 1.0, 2.0)).unwrap();
        assert!((k.wavelength - 0.6).abs() < 0.01, "{}", k.wavelength);
        assert!(
            (k.waves_on_body - 1.0 / 0.6).abs() < 0.03,
            "{}",
            k.waves_on_body
        );
        assert!((k.tail_beat_hz - 3.0).abs() < 0.02);
        assert!(k.envelope.iter().all(|p| (p.amplitude - 0.05).abs() < 1e-3));
    }

    #[test]
    fn test_bad_series_are_named() {
        let good = synthetic(synthetic_envelope, 0.9, 2.0, 1.2, 3.0);
        let mut s = good.clone();
        s.lateral.pop();
        assert!(matches!(
            analyze(&s),
            Err(KinematicsError::Malformed { .. })
        ));
        let mut s = good.clone();
        s.stations[20] = 0.9;
        assert!(matches!(
            analyze(&s),
            Err(KinematicsError::Malformed { .. })
        ));
        let mut s = good.clone();
        s.lateral[5] = f32::NAN;
        assert!(matches!(
            analyze(&s),
            Err(KinematicsError::Malformed { .. })
        ));
        // One beat only.
        let s = synthetic(synthetic_envelope, 0.9, 2.0, 1.2, 0.8);
        assert!(matches!(
            analyze(&s),
            Err(KinematicsError::TooFewBeats { .. })
        ));
        // A fish beating on the spot.
        let s = synthetic(synthetic_envelope, 0.9, 2.0, 0.0, 3.0);
        assert!(matches!(
            analyze(&s),
            Err(KinematicsError::NotSwimming { .. })
        ));
    }

    #[test]
    fn test_recorded_swim_beats_at_the_parameters_frequency() {
        // The measurement agrees with what the parameters imply (ω'/λ) for the Table 1 fish.
        let params = MotionParams::BLACK_PORGY;
        let series = record_swim(
            &params,
            &Body::black_porgy(),
            1.0,
            4.0,
            240.0,
            &default_stations(),
        )
        .unwrap();
        let k = analyze(&series).unwrap();
        let expected = params.tail_beat_hz(params.s);
        assert!(
            (k.tail_beat_hz - expected).abs() < 0.02 * expected,
            "{}",
            k.tail_beat_hz
        );
        assert!((k.speed_body_lengths_per_s - 1.0).abs() < 1e-3);
        assert!(matches!(
            record_swim(
                &params,
                &Body::black_porgy(),
                f32::NAN,
                4.0,
                240.0,
                &default_stations()
            ),
            Err(MotionError::InvalidParam { name: "speed", .. })
        ));
    }
}

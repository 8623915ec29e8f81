//! Sampling a preset's motion at a fixed rate: what `shoal motion` prints and `shoal plot` draws.

use serde::Serialize;

use super::{Body, MotionError, MotionParams, MotionPlayer, Preset, RootState};

/// Longest recording, seconds.
pub const MAX_SECONDS: f32 = 3600.0;
/// Highest sampling rate, hertz.
pub const MAX_RATE_HZ: f32 = 10_000.0;
/// Most frames a recording may hold.
pub const MAX_FRAMES: usize = 1_000_000;

/// The parameters a recording was made with: the [`MotionParams`] fields plus the preset's turn.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RecordedParams {
    /// p, s, l, max_amp, lambda, omega, tt (seconds), f, turn_angle (radians).
    #[serde(flatten)]
    pub params: MotionParams,
    /// The paper's d: −1 left, 0 straight, 1 right.
    pub d: i32,
    /// `"normal"`, `"quick"`, `"serial"` or `null` for a straight swim.
    pub turn: Option<&'static str>,
}

/// One sampled instant.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct RecordedFrame {
    /// Seconds since the start.
    pub t: f32,
    /// The motion playing ([`MotionPlayer::current_name`]).
    pub motion: &'static str,
    /// Midline displacement at each `joints_x`, length units, positive to the fish's left.
    pub lateral: Vec<f32>,
    /// Each driven joint's local yaw, radians, positive bends the body to the left.
    pub yaw: Vec<f32>,
    /// The root: `pos` [x, y, z], `heading`, `pitch` (radians), `speed` (length units / s).
    pub root: RootState,
    /// The head's offset from the travel line ([`MotionPlayer::head_lateral`]); not printed.
    #[serde(skip)]
    pub head_lateral: f32,
    /// The head segment's yaw ([`MotionPlayer::head_yaw`]); not printed.
    #[serde(skip)]
    pub head_yaw: f32,
}

/// A preset's motion sampled at `rate_hz` (the JSON shape `shoal motion` prints).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Recording {
    /// Preset name.
    pub preset: &'static str,
    /// Parameters used.
    pub params: RecordedParams,
    /// Samples per second.
    pub rate_hz: f32,
    /// Driven joints' positions, fractions of body length from head, then the tail tip (1.0).
    pub joints_x: Vec<f32>,
    /// Frames at t = 0, 1/rate, …, seconds.
    pub frames: Vec<RecordedFrame>,
}

/// Plays `preset` (its demonstration request, from [`Preset::initial_root`]) on `body` for
/// `seconds` and samples it `rate_hz` times per second, including t = 0.
///
/// Fails if the preset or body is invalid, or `seconds` / `rate_hz` are not finite and positive
/// (or exceed [`MAX_SECONDS`], [`MAX_RATE_HZ`], [`MAX_FRAMES`]).
pub fn record_preset(
    preset: &Preset,
    body: &Body,
    seconds: f32,
    rate_hz: f32,
) -> Result<Recording, MotionError> {
    preset.validate()?;
    body.validate()?;
    let range = |name: &'static str, value: f32, max: f32, unit: &str| {
        if value.is_finite() && value > 0.0 && value <= max {
            Ok(())
        } else {
            Err(MotionError::InvalidParam {
                name,
                value,
                why: format!("must be a positive number of {unit}, at most {max}"),
            })
        }
    };
    range("seconds", seconds, MAX_SECONDS, "seconds")?;
    range("rate", rate_hz, MAX_RATE_HZ, "samples per second")?;
    let steps = (seconds * rate_hz).round() as usize;
    if steps + 1 > MAX_FRAMES {
        return Err(MotionError::InvalidParam {
            name: "seconds",
            value: seconds,
            why: format!(
                "{} frames at {rate_hz} Hz; at most {MAX_FRAMES} are allowed",
                steps + 1
            ),
        });
    }
    let params: MotionParams = preset.params;
    let mut player = MotionPlayer::new();
    player.push(preset.request()?)?;
    let mut root = preset.initial_root();
    let mut lateral = vec![0.0; body.joints_x.len()];
    let mut yaw = vec![0.0; body.num_joints()];
    let dt = 1.0 / rate_hz;
    let mut frames = Vec::with_capacity(steps + 1);
    for k in 0..=steps {
        player.step(
            if k == 0 { 0.0 } else { dt },
            &params,
            body,
            &mut root,
            &mut lateral,
            &mut yaw,
        );
        frames.push(RecordedFrame {
            t: k as f32 * dt,
            motion: player.current_name(),
            lateral: lateral.clone(),
            yaw: yaw.clone(),
            root,
            head_lateral: player.head_lateral(),
            head_yaw: player.head_yaw(),
        });
    }
    Ok(Recording {
        preset: preset.name,
        params: RecordedParams {
            params,
            d: preset.d,
            turn: preset.turn.map(|kind| match kind {
                super::TurnKind::Normal => "normal",
                super::TurnKind::Quick => "quick",
                super::TurnKind::Serial => "serial",
            }),
        },
        rate_hz,
        joints_x: body.joints_x.clone(),
        frames,
    })
}

impl Recording {
    /// The recording as CSV: `#` comment lines with the preset, parameters and joints_x, a
    /// header, then one row per frame (t, motion, root x, y, z, heading, pitch, speed, each
    /// `lateral_<i>`, each `yaw_<i>`).
    pub fn to_csv(&self) -> String {
        use std::fmt::Write as _;
        let p = &self.params.params;
        let mut out = String::new();
        let _ = writeln!(out, "# preset={} rate_hz={}", self.preset, self.rate_hz);
        let _ = writeln!(
            out,
            "# p={} s={} l={} max_amp={} lambda={} omega={} tt={} f={} turn_angle={} d={} turn={}",
            p.p,
            p.s,
            p.l,
            p.max_amp,
            p.lambda,
            p.omega,
            p.tt,
            p.f,
            p.turn_angle,
            self.params.d,
            self.params.turn.unwrap_or("none")
        );
        let joints: Vec<String> = self.joints_x.iter().map(|x| x.to_string()).collect();
        let _ = writeln!(out, "# joints_x={}", joints.join(";"));
        out.push_str("t,motion,x,y,z,heading,pitch,speed");
        for i in 0..self.joints_x.len() {
            let _ = write!(out, ",lateral_{i}");
        }
        for i in 0..self.joints_x.len().saturating_sub(1) {
            let _ = write!(out, ",yaw_{i}");
        }
        out.push('\n');
        for f in &self.frames {
            let r = &f.root;
            let _ = write!(
                out,
                "{},{},{},{},{},{},{},{}",
                f.t, f.motion, r.pos.x, r.pos.y, r.pos.z, r.heading, r.pitch, r.speed
            );
            for v in f.lateral.iter().chain(f.yaw.iter()) {
                let _ = write!(out, ",{v}");
            }
            out.push('\n');
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn test_recording_shape_and_limits() {
        let preset = Preset::by_name("ex1").unwrap();
        let body = Body::black_porgy();
        let rec = record_preset(&preset, &body, 1.0, 10.0).unwrap();
        assert_eq!(rec.frames.len(), 11);
        assert_eq!(rec.frames[10].t, 1.0);
        // Cruising at s = 50 from the start: one second covers 50 length units.
        assert!((rec.frames[10].root.pos.x - 50.0).abs() < 1e-3);
        let json = serde_json::to_value(&rec).unwrap();
        // serde_json's map sorts keys; the text keeps the struct's order.
        let keys: Vec<&str> = json
            .as_object()
            .unwrap()
            .keys()
            .map(|k| k.as_str())
            .collect();
        assert_eq!(keys, ["frames", "joints_x", "params", "preset", "rate_hz"]);
        let text = serde_json::to_string(&rec).unwrap();
        assert!(
            text.starts_with("{\"preset\":\"ex1\",\"params\":{\"p\":0.4,"),
            "{text}"
        );
        let frame = json["frames"][3].as_object().unwrap();
        let keys: Vec<&str> = frame.keys().map(|k| k.as_str()).collect();
        assert_eq!(keys, ["lateral", "motion", "root", "t", "yaw"]);
        assert_eq!(
            json["frames"][3]["root"]["pos"].as_array().unwrap().len(),
            3
        );
        assert_eq!(json["params"]["p"], serde_json::json!(0.4f32));
        assert!(json["params"]["turn"].is_null());
        let csv = rec.to_csv();
        assert_eq!(csv.lines().filter(|l| !l.starts_with('#')).count(), 12);
        assert!(csv.contains("lateral_6,yaw_0"));
        for (name, seconds, rate) in [
            ("seconds", 0.0, 60.0),
            ("seconds", f32::NAN, 60.0),
            ("rate", 1.0, -60.0),
            ("seconds", 3000.0, 1000.0),
        ] {
            let err = record_preset(&preset, &body, seconds, rate).unwrap_err();
            assert!(
                matches!(err, MotionError::InvalidParam { name: n, .. } if n == name),
                "{err}"
            );
        }
    }
}

//! A measured animal's midline, read from a CSV file and turned into the same [`MidlineSeries`]
//! that [`super::record_swim`] samples from our fish, so that [`super::analyze`] measures both
//! the same way.
//!
//! **File format** (`shoal kinematics --midline FILE.csv`): a header row naming at least the
//! columns `t`, `point`, `x` and `y` (in any order; other columns are ignored), then one row per
//! point per frame. `t` is the time in seconds, evenly spaced; `point` is an integer numbering
//! the midline points from the head (smallest) to the tail tip (largest), listed in increasing
//! order within a frame, the same points in every frame; `x`, `y` are the point's position in
//! any length unit (mm, pixels), the same for both. Lines starting with `#` are comments.
//!
//! **What is done to it** (after the fishmechr vignette's steps 3–4, Tytell's package; see
//! docs/motion.md):
//! - body length L: the midline's arc length (sum of its segments), averaged over frames; each
//!   point's station is its mean arc length from the head over L (0 … 1);
//! - centre: the centroid of the midline's segments weighted by their length;
//! - swimming axis: each frame's principal axis (of its points about the centre), pointing from
//!   tail to head, averaged with the centre over a window of one tail beat (moving average);
//!   the tail beat is found in a first pass with a 0.5 s window;
//! - lateral displacement: the distance of each point from the smoothed centre across the
//!   smoothed axis (positive counterclockwise of it in the file's x–y axes), over L;
//! - distance travelled: the smoothed centre's motion along the smoothed axis, over L, plus
//!   `flow_speed · t` for an animal holding station in a flow tank.

use std::path::{Path, PathBuf};

use glam::DVec2;
use serde::Serialize;

use super::{Kinematics, KinematicsError, MidlineSeries, analyze};

/// Slowest travel through the frame accepted as swimming, body lengths per second, without a
/// flow speed: half the slowest steady swimming the sources in docs/motion.md report (0.5 L/s);
/// an animal holding station in a flow tank drifts slower than this.
pub const MIN_TRAVEL_BODY_LENGTHS_PER_S: f64 = 0.25;
/// Seconds of the first pass's smoothing window, before the tail beat is known.
pub const FIRST_WINDOW_S: f64 = 0.5;

/// Why a midline file cannot be measured. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum MidlineError {
    /// The file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The CSV itself is malformed (unbalanced quotes, ragged rows).
    #[error("{path}: line {line}: {why}")]
    Csv {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// What the CSV reader said.
        why: String,
    },
    /// A required column is missing from the header.
    #[error(
        "{path}: line 1: no column '{column}' in the header {header:?}; a midline file needs the \
         columns t, point, x, y"
    )]
    MissingColumn {
        /// The file.
        path: PathBuf,
        /// The missing column.
        column: &'static str,
        /// The header as read.
        header: Vec<String>,
    },
    /// A field is not a finite number (or `point` not an integer).
    #[error("{path}: line {line}, column {field}: '{value}' is not {what}")]
    BadNumber {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// The column.
        field: &'static str,
        /// The text found.
        value: String,
        /// What was expected.
        what: &'static str,
    },
    /// Rows are not in order: time going back, or points not increasing from head to tail.
    #[error("{path}: line {line}, column {field}: {why}")]
    OutOfOrder {
        /// The file.
        path: PathBuf,
        /// 1-based line.
        line: u64,
        /// The column at fault.
        field: &'static str,
        /// What is out of order.
        why: String,
    },
    /// Too few frames or points to measure anything.
    #[error("{path}: {why}")]
    TooLittle {
        /// The file.
        path: PathBuf,
        /// What is missing.
        why: String,
    },
    /// The midline's measures could not be computed.
    #[error("{path}: {source}")]
    Analysis {
        /// The file.
        path: PathBuf,
        /// Why.
        source: KinematicsError,
    },
    /// The animal did not travel and no flow speed was given.
    #[error(
        "{path}: the animal travelled {speed:.3} body lengths per second through the frame; \
         stride length, slip and Strouhal number need its swimming speed: if it swam in a flow \
         tank, give the flow speed with --flow-speed (body lengths per second)"
    )]
    NotTravelling {
        /// The file.
        path: PathBuf,
        /// Measured travel, body lengths per second.
        speed: f64,
    },
}

/// A midline file as read: frames of points.
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredMidline {
    /// The file it came from.
    pub path: PathBuf,
    /// Time of each frame, seconds.
    pub times: Vec<f64>,
    /// The point numbers, head to tail.
    pub points: Vec<i64>,
    /// Positions, frame-major (`xy[k * points.len() + i]`), file units.
    pub xy: Vec<DVec2>,
    /// The 1-based line of each frame's first row (for messages).
    pub lines: Vec<u64>,
}

impl MeasuredMidline {
    /// Number of frames.
    pub fn num_frames(&self) -> usize {
        self.times.len()
    }

    fn frame(&self, k: usize) -> &[DVec2] {
        let n = self.points.len();
        &self.xy[k * n..(k + 1) * n]
    }
}

/// Reads a midline file (format in the module docs).
pub fn read_midline(path: &Path) -> Result<MeasuredMidline, MidlineError> {
    let text = std::fs::read_to_string(path).map_err(|source| MidlineError::Io {
        path: path.to_owned(),
        source,
    })?;
    parse_midline(&text, path)
}

/// Parses a midline file's text; `path` names it in errors.
pub fn parse_midline(text: &str, path: &Path) -> Result<MeasuredMidline, MidlineError> {
    let p = || path.to_owned();
    let mut reader = csv::ReaderBuilder::new()
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let csv_err = |e: csv::Error| MidlineError::Csv {
        path: p(),
        line: e.position().map_or(0, |q| q.line()),
        why: e.to_string(),
    };
    let header: Vec<String> = reader
        .headers()
        .map_err(csv_err)?
        .iter()
        .map(str::to_owned)
        .collect();
    let col = |column: &'static str| {
        header
            .iter()
            .position(|h| h == column)
            .ok_or_else(|| MidlineError::MissingColumn {
                path: p(),
                column,
                header: header.clone(),
            })
    };
    let (ct, cp, cx, cy) = (col("t")?, col("point")?, col("x")?, col("y")?);
    let mut m = MeasuredMidline {
        path: p(),
        times: Vec::new(),
        points: Vec::new(),
        xy: Vec::new(),
        lines: Vec::new(),
    };
    // Points of the frame being read.
    let mut current: Vec<i64> = Vec::new();
    let mut record = csv::StringRecord::new();
    loop {
        match reader.read_record(&mut record) {
            Ok(true) => {}
            Ok(false) => break,
            Err(e) => return Err(csv_err(e)),
        }
        let line = record.position().map_or(0, |q| q.line());
        let field = |i: usize, name: &'static str| -> Result<&str, MidlineError> {
            record.get(i).ok_or_else(|| MidlineError::BadNumber {
                path: p(),
                line,
                field: name,
                value: String::new(),
                what: "present",
            })
        };
        let number = |i: usize, name: &'static str| -> Result<f64, MidlineError> {
            let s = field(i, name)?;
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| MidlineError::BadNumber {
                    path: p(),
                    line,
                    field: name,
                    value: s.to_owned(),
                    what: "a finite number",
                })
        };
        let t = number(ct, "t")?;
        let s = field(cp, "point")?;
        let point = s.parse::<i64>().map_err(|_| MidlineError::BadNumber {
            path: p(),
            line,
            field: "point",
            value: s.to_owned(),
            what: "an integer",
        })?;
        let xy = DVec2::new(number(cx, "x")?, number(cy, "y")?);
        let out_of_order = |field: &'static str, why: String| MidlineError::OutOfOrder {
            path: p(),
            line,
            field,
            why,
        };
        let new_frame = m.times.last().is_none_or(|&last| t != last);
        if new_frame {
            if let Some(&last) = m.times.last() {
                if t < last {
                    return Err(out_of_order(
                        "t",
                        format!("time {t} comes after {last}; rows must be in time order"),
                    ));
                }
                close_frame(&mut m, &current)?;
            }
            m.times.push(t);
            m.lines.push(line);
            current.clear();
        } else if let Some(&prev) = current.last()
            && point <= prev
        {
            return Err(out_of_order(
                "point",
                format!(
                    "point {point} follows point {prev} at t = {t}; points must increase from \
                     head to tail within a frame"
                ),
            ));
        }
        current.push(point);
        m.xy.push(xy);
    }
    if m.times.is_empty() {
        return Err(MidlineError::TooLittle {
            path: p(),
            why: "no rows after the header".to_owned(),
        });
    }
    close_frame(&mut m, &current)?;
    if m.points.len() < 3 {
        return Err(MidlineError::TooLittle {
            path: p(),
            why: format!(
                "{} point(s) per frame; at least 3 (head, middle, tail tip) are needed",
                m.points.len()
            ),
        });
    }
    if m.num_frames() < 3 {
        return Err(MidlineError::TooLittle {
            path: p(),
            why: format!(
                "{} frame(s); a tail beat needs many frames (at least two whole beats)",
                m.num_frames()
            ),
        });
    }
    let dt = (m.times[m.num_frames() - 1] - m.times[0]) / (m.num_frames() - 1) as f64;
    for k in 1..m.num_frames() {
        let step = m.times[k] - m.times[k - 1];
        if (step - dt).abs() > 0.05 * dt {
            return Err(MidlineError::OutOfOrder {
                path: p(),
                line: m.lines[k],
                field: "t",
                why: format!(
                    "time step {step:.6} s differs from the mean {dt:.6} s; frames must be \
                     evenly spaced (fill or drop missing frames)"
                ),
            });
        }
    }
    Ok(m)
}

/// Checks that the frame just read lists the same points as the first one.
fn close_frame(m: &mut MeasuredMidline, current: &[i64]) -> Result<(), MidlineError> {
    if m.points.is_empty() {
        m.points = current.to_vec();
        return Ok(());
    }
    if current != m.points.as_slice() {
        let k = m.times.len() - 1;
        return Err(MidlineError::OutOfOrder {
            path: m.path.clone(),
            line: m.lines[k],
            field: "point",
            why: format!(
                "the frame at t = {} has points {current:?}, the first frame {:?}; every frame \
                 needs the same points",
                m.times[k], m.points
            ),
        });
    }
    Ok(())
}

/// What was found about the animal besides its kinematics.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MidlineInfo {
    /// The file.
    pub file: String,
    /// Frames read.
    pub frames: usize,
    /// Points per frame.
    pub points: usize,
    /// Samples per second.
    pub rate_hz: f32,
    /// Body length L, in the file's length unit (the midline's mean arc length).
    pub body_length: f32,
    /// Mean swimming direction in the file's x–y axes (unit vector, tail to head).
    pub direction: [f32; 2],
    /// Frames in the smoothing window of the centre and axis (one tail beat).
    pub smoothing_frames: usize,
    /// Speed through the frame, body lengths per second (before any flow speed).
    pub travel_body_lengths_per_s: f32,
    /// The flow speed added, body lengths per second, if given.
    pub flow_speed_body_lengths_per_s: Option<f32>,
}

/// A measured animal's kinematics.
#[derive(Debug, Clone, Serialize)]
pub struct MidlineMeasurement {
    /// About the file.
    pub info: MidlineInfo,
    /// What was measured.
    #[serde(flatten)]
    pub kinematics: Kinematics,
    /// The series measured (for the plot; not printed).
    #[serde(skip)]
    pub series: MidlineSeries,
}

/// Centred moving average of `v` over `window` frames (shorter at the ends).
fn moving_average(v: &[DVec2], window: usize) -> Vec<DVec2> {
    let h = window / 2;
    (0..v.len())
        .map(|k| {
            let (a, b) = (k.saturating_sub(h), (k + h + 1).min(v.len()));
            v[a..b].iter().copied().sum::<DVec2>() / (b - a) as f64
        })
        .collect()
}

/// The series of `m` with the centre and axis smoothed over `window` frames, and the speed
/// through the frame (L/s).
fn to_series(
    m: &MeasuredMidline,
    window: usize,
    body_length: f64,
    stations: &[f32],
    flow: f64,
    rate_hz: f64,
) -> (MidlineSeries, f64, DVec2) {
    let n = m.points.len();
    let frames = m.num_frames();
    let mut centres = Vec::with_capacity(frames);
    let mut axes = Vec::with_capacity(frames);
    for k in 0..frames {
        let f = m.frame(k);
        let (mut c, mut w) = (DVec2::ZERO, 0.0);
        for s in f.windows(2) {
            let len = s[0].distance(s[1]);
            c += 0.5 * (s[0] + s[1]) * len;
            w += len;
        }
        let c = if w > 0.0 {
            c / w
        } else {
            f.iter().copied().sum::<DVec2>() / n as f64
        };
        // Principal axis of the points about the centre (2×2 covariance, largest eigenvector).
        let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
        for &q in f {
            let d = q - c;
            sxx += d.x * d.x;
            sxy += d.x * d.y;
            syy += d.y * d.y;
        }
        let angle = 0.5 * (2.0 * sxy).atan2(sxx - syy);
        let mut a = DVec2::from_angle(angle);
        if a.dot(f[0] - f[n - 1]) < 0.0 {
            a = -a;
        }
        centres.push(c);
        axes.push(a);
    }
    let centres = moving_average(&centres, window);
    let axes: Vec<DVec2> = moving_average(&axes, window)
        .into_iter()
        .map(|a| a.normalize_or(DVec2::X))
        .collect();
    let mut lateral = Vec::with_capacity(frames * n);
    let mut forward = Vec::with_capacity(frames);
    let mut travelled = 0.0;
    for k in 0..frames {
        if k > 0 {
            travelled += (centres[k] - centres[k - 1]).dot(axes[k]) / body_length;
        }
        let normal = axes[k].perp();
        for &q in m.frame(k) {
            lateral.push(((q - centres[k]).dot(normal) / body_length) as f32);
        }
        forward.push(travelled + flow * k as f64 / rate_hz);
    }
    let seconds = (frames - 1) as f64 / rate_hz;
    let travel_speed = travelled / seconds;
    let direction = axes.iter().copied().sum::<DVec2>().normalize_or(DVec2::X);
    (
        MidlineSeries {
            rate_hz: rate_hz as f32,
            stations: stations.to_vec(),
            lateral,
            forward: forward.into_iter().map(|v| v as f32).collect(),
        },
        travel_speed,
        direction,
    )
}

/// Measures a midline file: the same [`Kinematics`] as for our fish. `flow_speed` (body lengths
/// per second) is added to the animal's travel through the frame, for a flow tank; without it
/// an animal that does not travel is an error.
pub fn measure_midline(
    m: &MeasuredMidline,
    flow_speed: Option<f32>,
) -> Result<MidlineMeasurement, MidlineError> {
    let p = || m.path.clone();
    let n = m.points.len();
    let frames = m.num_frames();
    let rate_hz = (frames - 1) as f64 / (m.times[frames - 1] - m.times[0]);
    // Body length and stations from the arc length.
    let mut arc = vec![0.0f64; n];
    let mut length = 0.0;
    for k in 0..frames {
        let f = m.frame(k);
        let mut s = 0.0;
        let mut along = vec![0.0; n];
        for i in 1..n {
            s += f[i - 1].distance(f[i]);
            along[i] = s;
        }
        length += s;
        if s > 0.0 {
            for i in 0..n {
                arc[i] += along[i] / s;
            }
        }
    }
    let body_length = length / frames as f64;
    if body_length <= 0.0 {
        return Err(MidlineError::TooLittle {
            path: p(),
            why: "every point of every frame is in the same place: the midline has no length"
                .to_owned(),
        });
    }
    let mut stations: Vec<f32> = arc.iter().map(|a| (a / frames as f64) as f32).collect();
    stations[0] = 0.0;
    stations[n - 1] = 1.0;
    if let Some(i) = (1..n).find(|&i| stations[i] <= stations[i - 1]) {
        return Err(MidlineError::OutOfOrder {
            path: p(),
            line: m.lines[0],
            field: "point",
            why: format!(
                "point {} is not further from the head than point {} on average: points must \
                 run along the midline from head to tail",
                m.points[i],
                m.points[i - 1]
            ),
        });
    }
    let flow = f64::from(flow_speed.unwrap_or(0.0));
    let analysis = |source| MidlineError::Analysis { path: p(), source };
    let first_window = ((FIRST_WINDOW_S * rate_hz).round() as usize).max(1);
    let (series, _, _) = to_series(m, first_window, body_length, &stations, flow, rate_hz);
    let first = match analyze(&series) {
        Ok(k) => k.tail_beat_hz,
        Err(KinematicsError::NotSwimming { .. }) if flow_speed.is_none() => {
            // Only the frequency is needed here; measure it as if swimming.
            let moving = MidlineSeries {
                forward: (0..frames).map(|k| k as f32).collect(),
                ..series
            };
            analyze(&moving).map_err(analysis)?.tail_beat_hz
        }
        Err(e) => return Err(analysis(e)),
    };
    let window = ((rate_hz / f64::from(first)).round() as usize).max(1);
    let (series, travel, direction) = to_series(m, window, body_length, &stations, flow, rate_hz);
    if flow_speed.is_none() && travel.abs() < MIN_TRAVEL_BODY_LENGTHS_PER_S {
        return Err(MidlineError::NotTravelling {
            path: p(),
            speed: travel,
        });
    }
    let kinematics = analyze(&series).map_err(analysis)?;
    Ok(MidlineMeasurement {
        info: MidlineInfo {
            file: m.path.display().to_string(),
            frames,
            points: n,
            rate_hz: rate_hz as f32,
            body_length: body_length as f32,
            direction: [direction.x as f32, direction.y as f32],
            smoothing_frames: window,
            travel_body_lengths_per_s: travel as f32,
            flow_speed_body_lengths_per_s: flow_speed,
        },
        kinematics,
        series,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A travelling wave y = a(s)·sin(2π(s/λ − f·t)) on a body of `length` units swimming at
    /// `speed` L/s along `heading` (radians) in the file's axes, sampled at 100 Hz for 3 s, as
    /// the CSV text of a midline file.
    fn synthetic_csv(length: f64, heading: f64, speed: f64) -> String {
        let (f, lambda, n) = (2.5, 0.7, 15);
        let dir = DVec2::from_angle(heading);
        let mut out = String::from("# a synthetic eel\nt,point,x,y\n");
        for k in 0..300 {
            let t = k as f64 / 100.0;
            for i in 0..n {
                let s = i as f64 / (n - 1) as f64;
                let a = 0.02 + 0.06 * s * s;
                let y = a * (TAU_F64 * (s / lambda - f * t)).sin();
                // Head at the front: the body trails behind the head along −dir.
                let p = (speed * t - s) * dir + y * dir.perp();
                let p = p * length + DVec2::new(500.0, -200.0);
                out += &format!("{t},{},{},{}\n", i + 1, p.x, p.y);
            }
        }
        out
    }

    const TAU_F64: f64 = std::f64::consts::TAU;

    #[test]
    fn test_any_unit_and_direction_give_the_same_measures() {
        for (length, heading) in [(1.0, 0.0), (153.0, 2.5), (600.0, -1.0)] {
            let text = synthetic_csv(length, heading, 0.8);
            let m = parse_midline(&text, Path::new("eel.csv")).unwrap();
            let r = measure_midline(&m, None).unwrap();
            let k = &r.kinematics;
            assert!((k.tail_beat_hz - 2.5).abs() < 0.05, "{}", k.tail_beat_hz);
            // Arc length of the undulating midline is a little over the straight length.
            assert!((f64::from(r.info.body_length) / length - 1.0).abs() < 0.08);
            assert!((k.speed_body_lengths_per_s - 0.8).abs() < 0.08, "{k:?}");
            assert!((k.wavelength - 0.7).abs() < 0.07, "{}", k.wavelength);
            let d = DVec2::new(r.info.direction[0].into(), r.info.direction[1].into());
            assert!(d.dot(DVec2::from_angle(heading)) > 0.99, "{d}");
            // Tail half-amplitude 0.08 L (less the part the centre's recoil takes).
            let tail = k.envelope.last().unwrap().amplitude;
            assert!((tail - 0.08).abs() < 0.02, "{tail}");
        }
    }

    #[test]
    fn test_bad_text_names_line_and_column() {
        let p = Path::new("f.csv");
        let err = |text: &str| parse_midline(text, p).unwrap_err().to_string();
        assert!(err("t,point,x\n0,1,2\n").contains("no column 'y'"));
        let e = err("t,point,x,y\n0,1,0,0\n0,2,1,inf\n");
        assert!(e.contains("f.csv: line 3, column y"), "{e}");
        let e = err("t,point,x,y\n0,1,0,0\n0,2,1,0\n0.1,2,0,0\n0.1,1,1,0\n");
        assert!(e.contains("line 5, column point"), "{e}");
        let e = err("t,point,x,y\n0,1,0,0\n0,2,1,0\n0.1,1,0,0\n0.1,3,1,0\n");
        assert!(e.contains("every frame needs the same points"), "{e}");
        let e = err("t,point,x,y\n0.1,1,0,0\n0.0,1,1,0\n");
        assert!(e.contains("line 3, column t"), "{e}");
    }
}

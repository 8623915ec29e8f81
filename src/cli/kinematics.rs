//! `shoal kinematics`: measure a fish's steady swimming as biologists do (tail-beat frequency,
//! amplitude envelope, body wavelength, wave speed, stride length, slip, Strouhal number) from
//! the simulated midline, and compare it with published data.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context as _, anyhow, bail};
use plotters::coord::Shift;
use plotters::prelude::*;
use serde::Serialize;

use crate::motion::kinematics::{self, Kinematics, MidlineSeries};
use crate::motion::{Body, FrontWave, MotionParams, Preset};
use crate::script::{Limits, ScriptHost};
use crate::world::Species;

/// Text printed by `shoal kinematics --help` after the options: every definition.
const DEFINITIONS: &str = "\
Measured on the posed midline (head, driven joints and tail tip joined by straight segments, as \
rendered), sampled at 21 stations from snout (0) to tail tip (1) for 8 s at 480 Hz after 1 s of \
steady swimming. Lengths are in body lengths L.
  U   speed: distance travelled / time
  f   tail-beat frequency: upward crossings of the tail tip's mean line per second
  A   tail amplitude: the tail tip's PEAK-TO-PEAK excursion
  a(x) envelope: HALF the peak-to-peak lateral displacement at station x
  λb  body wavelength: 2π / (phase lag per body length), fitted over 0.5-1 L
  waves on body: 1/λb
  V   wave speed f·λb;  stride length U/f;  slip U/V;  Strouhal number St = f·A/U";

/// Which published data the plot and the text compare with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Mode {
    /// Carangiform swimmers (bass, mackerel, porgies): amplitude mostly at the tail.
    Carangiform,
    /// Anguilliform swimmers (eels): the whole body undulates.
    Anguilliform,
}

impl Mode {
    /// The mode a species swims in, by its front wave: a wave running from the snout
    /// ([`FrontWave::Travelling`]) is anguilliform, a front recoiling about the pivot carangiform.
    pub fn of(params: &MotionParams) -> Self {
        match params.front_wave {
            FrontWave::Travelling => Mode::Anguilliform,
            FrontWave::Recoil => Mode::Carangiform,
        }
    }
}

/// Arguments of `shoal kinematics`.
#[derive(Debug, Clone, clap::Args)]
#[command(after_long_help = DEFINITIONS)]
pub struct Args {
    /// A species file: `scripts/species/NAME.lua` (or a path to a .lua file). Default
    /// black_porgy.
    #[arg(long, conflicts_with = "preset")]
    pub species: Option<String>,
    /// A Table 1 preset's parameters (ex1 … ex4), swimming straight on the black porgy body.
    #[arg(long)]
    pub preset: Option<String>,
    /// Swimming speeds, body lengths per second, comma-separated (default: the cruising speed).
    #[arg(long, value_delimiter = ',', allow_hyphen_values = true)]
    pub speed: Vec<f32>,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Also draw the envelope and the midlines over one beat, with published data, into this PNG.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Published data to compare with (default: anguilliform for a species whose front wave
    /// travels from the snout, like the eel's; else carangiform).
    #[arg(long, value_enum)]
    pub mode: Option<Mode>,
}

/// Fastest speed accepted, body lengths per second (sustained swimming rarely exceeds 10 L/s).
pub const MAX_SPEED_BODY_LENGTHS_PER_S: f32 = 20.0;
const SECONDS: f32 = 8.0;
const RATE_HZ: f32 = 480.0;

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

/// Resolves `--species` / `--preset` (species files under `root`/scripts, assets under
/// `root`/assets).
pub fn subject(args: &Args, root: &Path) -> anyhow::Result<Subject> {
    if let Some(name) = &args.preset {
        let preset = Preset::by_name(name)?;
        return Ok(Subject {
            name: preset.name.to_owned(),
            source: "Table 1 (swimming straight)".to_owned(),
            params: preset.params,
            body: Body::black_porgy(),
            mode: args.mode.unwrap_or(Mode::Carangiform),
        });
    }
    let name = args.species.as_deref().unwrap_or("black_porgy");
    let scripts = root.join("scripts");
    let path = if name.ends_with(".lua") {
        PathBuf::from(name)
    } else {
        scripts.join("species").join(format!("{name}.lua"))
    };
    if !path.is_file() {
        let mut known: Vec<String> = std::fs::read_dir(scripts.join("species"))
            .map(|d| {
                d.filter_map(|e| e.ok())
                    .filter_map(|e| {
                        e.file_name()
                            .to_str()
                            .and_then(|n| n.strip_suffix(".lua"))
                            .map(str::to_owned)
                    })
                    .collect()
            })
            .unwrap_or_default();
        known.sort();
        bail!(
            "unknown species {name:?}: no file {}; species here: {}",
            path.display(),
            if known.is_empty() {
                "none".to_owned()
            } else {
                known.join(", ")
            }
        );
    }
    let host = ScriptHost::new(&scripts, Limits::default())
        .with_context(|| format!("starting Lua for {}", scripts.display()))?;
    let display = path.display().to_string();
    let value = host
        .load_data_file(&path)
        .with_context(|| format!("reading {display}"))?;
    let mlua::Value::Table(table) = value else {
        bail!("{display}: a species file must return a table");
    };
    let file = crate::script::scene::species_from_table(host.lua(), &display, table)
        .map_err(|e| anyhow!(e))?;
    let desc = file.desc;
    desc.motion
        .validate()
        .with_context(|| format!("{display}: motion"))?;
    let species_name = desc.name.clone();
    let assets = root.join("assets");
    let species = Species::load(desc, &assets)
        .with_context(|| format!("{display}: loading its model from {}", assets.display()))?;
    Ok(Subject {
        mode: args.mode.unwrap_or(Mode::of(&species.desc.motion)),
        name: species_name,
        source: display,
        params: species.desc.motion,
        body: species.rig.body.clone(),
    })
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

/// The speeds to measure: `--speed`, checked, or the cruising speed.
pub fn speeds(args: &Args, params: &MotionParams) -> anyhow::Result<Vec<f32>> {
    if args.speed.is_empty() {
        return Ok(vec![params.s / params.l]);
    }
    for &v in &args.speed {
        if !(v.is_finite() && v > 0.0 && v <= MAX_SPEED_BODY_LENGTHS_PER_S) {
            bail!(
                "--speed {v}: each speed must be a number of body lengths per second in \
                 (0, {MAX_SPEED_BODY_LENGTHS_PER_S}]"
            );
        }
    }
    Ok(args.speed.clone())
}

/// Measures `subject` at each speed.
pub fn measure(subject: &Subject, speeds: &[f32]) -> anyhow::Result<Vec<Measurement>> {
    let stations = kinematics::default_stations();
    speeds
        .iter()
        .map(|&v| {
            let series = kinematics::record_swim(
                &subject.params,
                &subject.body,
                v,
                SECONDS,
                RATE_HZ,
                &stations,
            )?;
            let k = kinematics::analyze(&series)
                .with_context(|| format!("{} at {v} body lengths per second", subject.name))?;
            Ok(Measurement {
                requested_speed_body_lengths_per_s: v,
                kinematics: k,
                series,
            })
        })
        .collect()
}

#[derive(Serialize)]
struct Report<'a> {
    name: &'a str,
    source: &'a str,
    mode: Mode,
    params: MotionParams,
    joints_x: &'a [f32],
    definitions: serde_json::Value,
    measurements: &'a [Measurement],
}

fn definitions_json() -> serde_json::Value {
    serde_json::json!({
        "midline": "posed chain (head, driven joints, tail tip) sampled at 21 stations, snout 0 to tail tip 1, 480 Hz for 8 s after 1 s of steady swimming; lengths in body lengths",
        "speed_body_lengths_per_s": "U: distance travelled over time",
        "tail_beat_hz": "f: upward crossings of the tail tip's mean line per second, over whole beats",
        "tail_amplitude_peak_to_peak": "A: the tail tip's peak-to-peak lateral excursion",
        "envelope": "a(x): half the peak-to-peak lateral displacement at station x",
        "min_amplitude_x": "station with the smallest a(x)",
        "wavelength": "λb: 2π / phase lag per body length of the lateral motion at f, least-squares over 0.5-1 L",
        "waves_on_body": "1/λb: body wavelengths on the body",
        "wave_speed_body_lengths_per_s": "V = f·λb",
        "stride_length": "U/f: distance per tail beat",
        "slip": "U/V",
        "strouhal": "St = f·A/U",
    })
}

fn text_report(subject: &Subject, ms: &[Measurement]) -> String {
    use std::fmt::Write as _;
    let p = &subject.params;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{} ({}): p = {}, turn axis = {}, l = {}, λ = {:.2} L, maxAmp = {:.3} L, front wave {} \
         at {:.3} L, {} driven joints",
        subject.name,
        subject.source,
        p.p,
        p.turn_axis_fraction(),
        p.l,
        p.lambda / p.l,
        p.max_amp / p.l,
        match p.front_wave {
            FrontWave::Recoil => "recoil",
            FrontWave::Travelling => "travelling",
        },
        p.front_amp,
        subject.body.num_joints()
    );
    let _ = writeln!(
        out,
        "measured on the posed midline, {RATE_HZ} Hz for {SECONDS} s after {} s of steady swimming; lengths in body lengths L\n",
        kinematics::SETTLE_S
    );
    let _ = write!(out, "{:<34}", "requested speed (L/s)");
    for m in ms {
        let _ = write!(
            out,
            "{:>9}",
            format!("{}", m.requested_speed_body_lengths_per_s)
        );
    }
    out.push('\n');
    type Row = (&'static str, fn(&Kinematics) -> f32, usize);
    let rows: [Row; 11] = [
        ("speed U (L/s)", |k| k.speed_body_lengths_per_s, 3),
        ("tail-beat frequency f (Hz)", |k| k.tail_beat_hz, 2),
        (
            "tail amplitude A, peak-to-peak (L)",
            |k| k.tail_amplitude_peak_to_peak,
            3,
        ),
        ("body wavelength λb (L)", |k| k.wavelength, 2),
        ("waves on the body", |k| k.waves_on_body, 2),
        ("wave speed V (L/s)", |k| k.wave_speed_body_lengths_per_s, 2),
        ("stride length U/f (L)", |k| k.stride_length, 2),
        ("slip U/V", |k| k.slip, 2),
        ("Strouhal number f·A/U", |k| k.strouhal, 2),
        ("snout amplitude a(0) (L)", |k| k.envelope[0].amplitude, 3),
        ("smallest amplitude at x", |k| k.min_amplitude_x, 2),
    ];
    for (label, get, digits) in rows {
        let _ = write!(out, "{label:<34}");
        for m in ms {
            let _ = write!(out, "{:>9.digits$}", get(&m.kinematics));
        }
        out.push('\n');
    }
    let _ = writeln!(out, "\nenvelope a(x), half peak-to-peak (L):");
    for i in 0..=10 {
        let x = i as f32 / 10.0;
        let _ = write!(out, "  x = {x:.1}{:<25}", "");
        for m in ms {
            let _ = write!(out, "{:>9.3}", m.kinematics.amplitude_at(x));
        }
        out.push('\n');
    }
    let (name, ranges) = published(subject.mode);
    let _ = writeln!(
        out,
        "\npublished ({name}; sources in docs/motion.md), and whether each speed is inside:"
    );
    for r in ranges {
        let _ = write!(out, "  {:<34}{:>6.3} – {:<6.3}", r.what, r.lo, r.hi);
        for m in ms {
            let _ = write!(
                out,
                " {}",
                if r.holds(&m.kinematics) { "in " } else { "OUT" }
            );
        }
        let _ = writeln!(out, "  {}", r.source);
    }
    let _ = writeln!(out, "\n{DEFINITIONS}");
    out
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

/// The published ranges for `mode` (docs/motion.md cites each and says how sure it is). The
/// tests hold every shipped species of that mode to all of them, at 0.5 – 3 L/s.
pub fn published(mode: Mode) -> (&'static str, &'static [Range]) {
    match mode {
        Mode::Carangiform => (
            "carangiform",
            &[
                Range {
                    what: "snout amplitude a(0) (L)",
                    lo: 0.004,
                    hi: 0.03,
                    source: "Jayne & Lauder 1995 (bass) to Videler & Hess 1984 (mackerel)",
                    measured: snout,
                },
                Range {
                    what: "smallest amplitude at x (L)",
                    lo: 0.15,
                    hi: 0.35,
                    source: "Jayne & Lauder 1995 (rise from ~0.25 L); mackerel fit ~0.25 L",
                    measured: |k| k.min_amplitude_x,
                },
                Range {
                    what: "smallest amplitude (L)",
                    lo: 0.0,
                    hi: 0.012,
                    source: "Jayne & Lauder 1995 (≤ snout's 0.012 L); mackerel fit 0.0095 L",
                    measured: smallest,
                },
                Range {
                    what: "tail amplitude a(1) (L)",
                    lo: 0.05,
                    hi: 0.11,
                    source: "Jayne & Lauder 1995; Bainbridge 1958 (A ≈ 0.2 L)",
                    measured: tail,
                },
                Range {
                    what: "tail excursion A, peak to peak (L)",
                    lo: 0.16,
                    hi: 0.22,
                    source: "Bainbridge 1958 (≈ 0.2 L)",
                    measured: |k| k.tail_amplitude_peak_to_peak,
                },
                Range {
                    what: "body wavelength λb (L)",
                    lo: 0.8,
                    hi: 1.2,
                    source: "Videler 1993; Videler & Hess 1984",
                    measured: |k| k.wavelength,
                },
                Range {
                    what: "Strouhal number",
                    lo: 0.2,
                    hi: 0.4,
                    source: "Taylor, Nudds & Thomas 2003",
                    measured: |k| k.strouhal,
                },
                Range {
                    what: "stride length (L)",
                    lo: 0.5,
                    hi: 1.0,
                    source: "Bainbridge 1958; Videler 1993",
                    measured: |k| k.stride_length,
                },
                Range {
                    what: "slip U/V",
                    lo: 0.5,
                    hi: 0.9,
                    source: "Videler 1993",
                    measured: |k| k.slip,
                },
            ],
        ),
        Mode::Anguilliform => (
            "anguilliform",
            &[
                Range {
                    what: "snout amplitude a(0) (L)",
                    lo: 0.025,
                    hi: 0.1,
                    source: "Tytell & Lauder 2004 (eel head, from memory, unverified)",
                    measured: snout,
                },
                Range {
                    what: "smallest amplitude at x (L)",
                    lo: 0.0,
                    hi: 0.5,
                    source: "D'Août & Aerts 1999 (eels: head yaw minimal, rising to the tail)",
                    measured: |k| k.min_amplitude_x,
                },
                Range {
                    what: "smallest amplitude (L)",
                    lo: 0.01,
                    hi: 0.05,
                    source: "whole body undulates (Gray 1933; Tytell & Lauder 2004)",
                    measured: smallest,
                },
                Range {
                    what: "tail amplitude a(1) (L)",
                    lo: 0.05,
                    hi: 0.11,
                    source: "Gillis 1998 (≈ 0.08 L); D'Août & Aerts 1999 (≈ 0.075 L)",
                    measured: tail,
                },
                Range {
                    what: "body wavelength λb (L)",
                    lo: 0.5,
                    hi: 0.95,
                    source: "Gillis 1996; Tytell & Lauder 2004",
                    measured: |k| k.wavelength,
                },
                Range {
                    what: "waves on the body",
                    lo: 1.05,
                    hi: 2.0,
                    source: "anguilliform: more than one wave (Gillis 1996)",
                    measured: |k| k.waves_on_body,
                },
                Range {
                    what: "Strouhal number",
                    lo: 0.2,
                    hi: 0.45,
                    source: "Tytell, Proc. R. Soc. B (eels ≈ 0.32); Borazjani & Sotiropoulos 2009",
                    measured: |k| k.strouhal,
                },
                Range {
                    what: "stride length (L)",
                    lo: 0.3,
                    hi: 0.8,
                    source: "Gillis 1998; Tytell 2004",
                    measured: |k| k.stride_length,
                },
                Range {
                    what: "slip U/V",
                    lo: 0.4,
                    hi: 0.9,
                    source: "Gillis 1998; Tytell 2004",
                    measured: |k| k.slip,
                },
            ],
        ),
    }
}

/// Published envelope curves: (label, (x, a(x)) points, colour).
type Curves = Vec<(String, Vec<(f32, f32)>, RGBColor)>;
/// Published ranges at one station: (label, x, lowest a, highest a).
type Bars = Vec<(String, f32, f32, f32)>;

/// The envelope published for `mode`, as (x, a(x)) curves and (x, lo, hi) bars, with labels.
fn published_envelope(mode: Mode) -> (Curves, Bars) {
    let mackerel: Vec<(f32, f32)> = (0..=50)
        .map(|i| {
            let x = i as f32 / 50.0;
            (x, 0.02 - 0.0825 * x + 0.1625 * x * x)
        })
        .collect();
    // Anguilliform envelope a(x) = 0.1·e^(x − 1) L: the form CFD studies of eel swimming
    // (Borazjani & Sotiropoulos 2009) are remembered to fit to Tytell & Lauder's (2004) eels.
    // Not verified: only the papers' abstracts could be checked, and they do not give it.
    let eel: Vec<(f32, f32)> = (0..=50)
        .map(|i| {
            let x = i as f32 / 50.0;
            (x, 0.1 * (x - 1.0).exp())
        })
        .collect();
    let grey = RGBColor(150, 150, 150);
    match mode {
        Mode::Carangiform => (
            vec![(
                "mackerel, Videler & Hess 1984 (fit)".to_owned(),
                mackerel,
                BLACK,
            )],
            vec![
                (
                    "bass snout, Jayne & Lauder 1995".to_owned(),
                    0.0,
                    0.004,
                    0.012,
                ),
                (
                    "bass tail tip, Jayne & Lauder 1995".to_owned(),
                    1.0,
                    0.053,
                    0.066,
                ),
            ],
        ),
        Mode::Anguilliform => (
            vec![
                (
                    "eel, 0.1·exp(x − 1) after Tytell & Lauder 2004 (fit from memory, unverified)"
                        .to_owned(),
                    eel,
                    BLACK,
                ),
                (
                    "carangiform for contrast: mackerel, Videler & Hess 1984 (fit)".to_owned(),
                    mackerel,
                    grey,
                ),
            ],
            vec![
                (
                    "eel head, 0.025 – 0.1 L (Tytell & Lauder 2004, from memory, unverified)"
                        .to_owned(),
                    0.0,
                    0.025,
                    0.1,
                ),
                (
                    "eel tail tip: ≈ 0.08 L Gillis 1998, ≈ 0.075 L D'Août & Aerts 1999".to_owned(),
                    1.0,
                    0.075,
                    0.085,
                ),
            ],
        ),
    }
}

fn plot_err<E: std::fmt::Debug>(e: E) -> anyhow::Error {
    anyhow!("drawing failed: {e:?}")
}

/// Draws the envelope (each speed, with published data) and the midlines over one beat.
pub fn plot(subject: &Subject, ms: &[Measurement], out: &Path) -> anyhow::Result<()> {
    let area = BitMapBackend::new(out, (1400, 650)).into_drawing_area();
    area.fill(&WHITE).map_err(plot_err)?;
    let (header, panels) = area.split_vertically(44);
    header
        .draw(&Text::new(
            format!(
                "{}: measured amplitude envelope and midlines ({} reference data)",
                subject.name,
                match subject.mode {
                    Mode::Carangiform => "carangiform",
                    Mode::Anguilliform => "anguilliform",
                }
            ),
            (16, 10),
            ("sans-serif", 24).into_font().color(&BLACK),
        ))
        .map_err(plot_err)?;
    let (left, right) = panels.split_horizontally(700);
    let y_max = ms
        .iter()
        .flat_map(|m| m.kinematics.envelope.iter().map(|p| p.amplitude))
        .fold(0.12f32, f32::max)
        * 1.1;
    draw_envelope(&left, subject, ms, y_max)?;
    draw_midlines(&right, ms, y_max)?;
    area.present()
        .with_context(|| format!("writing {}", out.display()))?;
    Ok(())
}

/// The left panel: the measured amplitude envelope at each speed over the published data.
fn draw_envelope(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    subject: &Subject,
    ms: &[Measurement],
    y_max: f32,
) -> anyhow::Result<()> {
    let mut chart = ChartBuilder::on(area)
        .margin(14)
        .caption(
            "amplitude envelope a(x), half peak-to-peak",
            ("sans-serif", 18),
        )
        .x_label_area_size(40)
        .y_label_area_size(56)
        .build_cartesian_2d(0f32..1.02f32, 0f32..y_max)
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_desc("position along the body, snout (0) → tail tip (1), L")
        .y_desc("amplitude, body lengths")
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(plot_err)?;
    let (curves, bars) = published_envelope(subject.mode);
    // The anguilliform plot shows the carangiform curve only for contrast, in grey.
    for (label, pts, curve_color) in curves {
        chart
            .draw_series(DashedLineSeries::new(
                pts,
                8,
                5,
                curve_color.stroke_width(2),
            ))
            .map_err(plot_err)?
            .label(label)
            .legend(move |(x, y)| {
                PathElement::new([(x, y), (x + 20, y)], curve_color.stroke_width(2))
            });
    }
    for (i, (label, x, lo, hi)) in bars.into_iter().enumerate() {
        let color = RGBColor(90, 90, 90);
        let x = x.clamp(0.008, 1.01);
        chart
            .draw_series(std::iter::once(PathElement::new(
                [(x, lo), (x, hi)],
                color.stroke_width(6),
            )))
            .map_err(plot_err)?
            .label(label)
            .legend(move |(px, py)| {
                PathElement::new(
                    [(px + 10, py - 6 + i as i32), (px + 10, py + 6)],
                    color.stroke_width(5),
                )
            });
    }
    let n = ms.len().max(2) as f32;
    for (i, m) in ms.iter().enumerate() {
        let color = HSLColor(0.62 * (1.0 - f64::from(i as f32 / (n - 1.0))), 0.85, 0.45);
        chart
            .draw_series(LineSeries::new(
                m.kinematics.envelope.iter().map(|p| (p.x, p.amplitude)),
                color.stroke_width(3),
            ))
            .map_err(plot_err)?
            .label(format!(
                "ours at {} L/s",
                m.requested_speed_body_lengths_per_s
            ))
            .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], color.stroke_width(3)));
    }
    chart
        .configure_series_labels()
        .position(SeriesLabelPosition::UpperLeft)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK.mix(0.3))
        .label_font(("sans-serif", 15))
        .draw()
        .map_err(plot_err)?;
    Ok(())
}

/// The right panel: the midline over one tail beat at the first speed, within its envelope.
fn draw_midlines(
    area: &DrawingArea<BitMapBackend<'_>, Shift>,
    ms: &[Measurement],
    y_max: f32,
) -> anyhow::Result<()> {
    let m = &ms[0];
    let s = &m.series;
    let frames = (s.rate_hz / m.kinematics.tail_beat_hz).round() as usize;
    let lat_max = y_max.max(0.12) * 1.2;
    let mut chart = ChartBuilder::on(area)
        .margin(14)
        .caption(
            format!(
                "midline over one tail beat at {} L/s (blue → red = time)",
                m.requested_speed_body_lengths_per_s
            ),
            ("sans-serif", 18),
        )
        .x_label_area_size(40)
        .y_label_area_size(56)
        .build_cartesian_2d(0f32..1.02f32, -lat_max..lat_max)
        .map_err(plot_err)?;
    chart
        .configure_mesh()
        .x_desc("position along the body, snout (0) → tail tip (1), L")
        .y_desc("lateral displacement (+ = left), L")
        .light_line_style(WHITE.mix(0.0))
        .draw()
        .map_err(plot_err)?;
    let snapshots = 10;
    for j in 0..snapshots {
        let k = (frames * j / snapshots).min(s.num_frames() - 1);
        let color = HSLColor(0.62 * (1.0 - j as f64 / (snapshots - 1) as f64), 0.85, 0.42);
        chart
            .draw_series(LineSeries::new(
                s.stations.iter().copied().zip(s.frame(k).iter().copied()),
                color.stroke_width(2),
            ))
            .map_err(plot_err)?;
    }
    for sign in [-1.0f32, 1.0] {
        chart
            .draw_series(DashedLineSeries::new(
                m.kinematics
                    .envelope
                    .iter()
                    .map(|p| (p.x, sign * p.amplitude)),
                6,
                4,
                RGBColor(120, 120, 120).stroke_width(1),
            ))
            .map_err(plot_err)?;
    }
    Ok(())
}

/// Runs `shoal kinematics`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    if let Some(dir) = args.plot.as_deref().and_then(Path::parent)
        && !dir.as_os_str().is_empty()
        && !dir.is_dir()
    {
        bail!(
            "--plot {}: the directory {} does not exist",
            args.plot.as_deref().unwrap_or(dir).display(),
            dir.display()
        );
    }
    // Species files of ./scripts when there is one, else of the source tree.
    let subject = subject(&args, &super::ScriptsArg::default().resolve()?.root)?;
    let speeds = speeds(&args, &subject.params)?;
    let ms = measure(&subject, &speeds)?;
    if let Some(path) = &args.plot {
        plot(&subject, &ms, path)?;
        log::info!("wrote {}", path.display());
    }
    let text = if args.json {
        serde_json::to_string_pretty(&Report {
            name: &subject.name,
            source: &subject.source,
            mode: subject.mode,
            params: subject.params,
            joints_x: &subject.body.joints_x,
            definitions: definitions_json(),
            measurements: &ms,
        })? + "\n"
    } else {
        text_report(&subject, &ms)
    };
    let mut stdout = std::io::stdout().lock();
    match stdout.write_all(text.as_bytes()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        other => other.context("writing to stdout")?,
    }
    Ok(ExitCode::SUCCESS)
}

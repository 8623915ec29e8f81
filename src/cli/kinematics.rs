//! `shoal kinematics`: measure a fish's steady swimming as biologists do (tail-beat frequency,
//! amplitude envelope, body wavelength, wave speed, stride length, slip, Strouhal number) from
//! the simulated midline, and compare it with published data.

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context as _, bail};
use serde::Serialize;

use shoal_core::motion::kinematics::{
    self, Kinematics, MAX_SPEED_BODY_LENGTHS_PER_S, Measurement, MidlineMeasurement, Mode, RATE_HZ,
    SECONDS, Subject, measure, measure_midline, published, read_midline,
};
use shoal_core::motion::{FrontWave, MotionParams};
use shoal_script::kinematics::subject;
use shoal_script::plot::kinematics::{plot, plot_midline};

/// `--mode`: which published data to compare with.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum ModeArg {
    /// Carangiform swimmers (bass, mackerel, porgies): amplitude mostly at the tail.
    Carangiform,
    /// Anguilliform swimmers (eels): the whole body undulates.
    Anguilliform,
}

impl From<ModeArg> for Mode {
    fn from(m: ModeArg) -> Self {
        match m {
            ModeArg::Carangiform => Mode::Carangiform,
            ModeArg::Anguilliform => Mode::Anguilliform,
        }
    }
}

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
    #[arg(long, value_enum, conflicts_with = "midline")]
    pub mode: Option<ModeArg>,
    /// Measure a real animal instead: a CSV midline with the columns t (s), point (head to
    /// tail), x, y (any length unit); see docs/motion.md.
    #[arg(long, conflicts_with_all = ["species", "preset", "speed"])]
    pub midline: Option<PathBuf>,
    /// With --midline: the flow speed of a flow tank, body lengths per second, added to the
    /// animal's travel through the frame.
    #[arg(long, requires = "midline", allow_hyphen_values = true)]
    pub flow_speed: Option<f32>,
    /// With --midline: also measure this shoal species at the animal's speed and draw its
    /// envelope over the animal's (--plot) and print it beside (text).
    #[arg(long, requires = "midline")]
    pub compare_species: Option<String>,
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
            FrontWave::Anguilliform => "anguilliform (whole-body envelope)",
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
    let ks: Vec<&Kinematics> = ms.iter().map(|m| &m.kinematics).collect();
    write_measure_rows(&mut out, &ks, 9, "snout amplitude a(0) (L)");
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
    if let Some(file) = &args.midline {
        return run_midline(&args, file);
    }
    // Species files of ./scripts when there is one, else of the source tree.
    let subject = subject(
        args.species.as_deref(),
        args.preset.as_deref(),
        args.mode.map(Mode::from),
        &super::ScriptsArg::default().resolve()?.root,
    )?;
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
    print(&text)
}

fn print(text: &str) -> anyhow::Result<ExitCode> {
    let mut stdout = std::io::stdout().lock();
    match stdout.write_all(text.as_bytes()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        other => other.context("writing to stdout")?,
    }
    Ok(ExitCode::SUCCESS)
}

#[derive(Serialize)]
struct MidlineReport<'a> {
    name: String,
    definitions: serde_json::Value,
    #[serde(flatten)]
    animal: &'a MidlineMeasurement,
    compare_species: Option<&'a Measurement>,
}

/// `shoal kinematics --midline FILE`: a measured animal's kinematics.
fn run_midline(args: &Args, file: &Path) -> anyhow::Result<ExitCode> {
    if let Some(v) = args.flow_speed
        && !(v.is_finite() && (0.0..=MAX_SPEED_BODY_LENGTHS_PER_S).contains(&v))
    {
        bail!(
            "--flow-speed {v}: must be a number of body lengths per second in \
             [0, {MAX_SPEED_BODY_LENGTHS_PER_S}]"
        );
    }
    let midline = read_midline(file)?;
    let animal = measure_midline(&midline, args.flow_speed)?;
    let name = file.file_stem().map_or_else(
        || file.display().to_string(),
        |s| s.to_string_lossy().into_owned(),
    );
    let compare = match &args.compare_species {
        Some(species) => {
            let subject = subject(
                Some(species),
                None,
                None,
                &super::ScriptsArg::default().resolve()?.root,
            )?;
            let speed = animal
                .kinematics
                .speed_body_lengths_per_s
                .clamp(0.05, MAX_SPEED_BODY_LENGTHS_PER_S);
            let m = measure(&subject, &[speed])?.remove(0);
            Some((subject, m))
        }
        None => None,
    };
    let as_measurement = Measurement {
        requested_speed_body_lengths_per_s: animal.kinematics.speed_body_lengths_per_s,
        kinematics: animal.kinematics.clone(),
        series: animal.series.clone(),
    };
    if let Some(path) = &args.plot {
        plot_midline(
            &name,
            &as_measurement,
            compare.as_ref().map(|(s, m)| (s, m)),
            path,
        )?;
        log::info!("wrote {}", path.display());
    }
    if args.json {
        let mut definitions = definitions_json();
        definitions["midline"] = serde_json::json!(MIDLINE_DEFINITION);
        let report = MidlineReport {
            name,
            definitions,
            animal: &animal,
            compare_species: compare.as_ref().map(|(_, m)| m),
        };
        return print(&(serde_json::to_string_pretty(&report)? + "\n"));
    }
    print(&midline_text(&name, &animal, compare.as_ref()))
}

const MIDLINE_DEFINITION: &str = "the file's midline points; body length L = mean arc length; \
stations = mean arc length from the head / L; centre (length-weighted centroid) and swimming axis \
(principal axis, tail to head) averaged over one tail beat; lateral = distance across that axis \
from the centre / L; travel = the centre's motion along the axis / L, plus any --flow-speed";

fn midline_text(
    name: &str,
    a: &MidlineMeasurement,
    compare: Option<&(Subject, Measurement)>,
) -> String {
    use std::fmt::Write as _;
    let i = &a.info;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "{name} ({}): {} frames at {:.1} Hz, {} points; body length L = {:.2} file units; \
         swimming direction ({:.3}, {:.3}); travel {:.3} L/s{}",
        i.file,
        i.frames,
        i.rate_hz,
        i.points,
        i.body_length,
        i.direction[0],
        i.direction[1],
        i.travel_body_lengths_per_s,
        i.flow_speed_body_lengths_per_s
            .map_or(String::new(), |v| format!(" + flow {v} L/s"))
    );
    let _ = writeln!(out, "lengths in body lengths L\n");
    let mut columns: Vec<(String, &Kinematics)> = vec![(name.to_owned(), &a.kinematics)];
    if let Some((s, m)) = compare {
        columns.push((s.name.clone(), &m.kinematics));
    }
    let _ = write!(out, "{:<34}", "");
    for (c, _) in &columns {
        let _ = write!(out, "{c:>14}");
    }
    out.push('\n');
    let ks: Vec<&Kinematics> = columns.iter().map(|(_, k)| *k).collect();
    write_measure_rows(&mut out, &ks, 14, "head amplitude a(0) (L)");
    let _ = writeln!(out, "\nenvelope a(x), half peak-to-peak (L):");
    for j in 0..=10 {
        let x = j as f32 / 10.0;
        let _ = write!(out, "  x = {x:.1}{:<25}", "");
        for (_, k) in &columns {
            let _ = write!(out, "{:>14.3}", k.amplitude_at(x));
        }
        out.push('\n');
    }
    let _ = writeln!(out, "\nmidline: {MIDLINE_DEFINITION}\n\n{DEFINITIONS}");
    out
}

/// The measures' rows of the species table and the midline table: one row per measure, one
/// column of `width` characters per kinematics; the a(0) row is labelled `a0_label` (the
/// species table's "snout", an animal's "head").
fn write_measure_rows(out: &mut String, columns: &[&Kinematics], width: usize, a0_label: &str) {
    use std::fmt::Write as _;
    type Row<'a> = (&'a str, fn(&Kinematics) -> f32, usize);
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
        (a0_label, |k| k.envelope[0].amplitude, 3),
        ("smallest amplitude at x", |k| k.min_amplitude_x, 2),
    ];
    for (label, get, digits) in rows {
        let _ = write!(out, "{label:<34}");
        for k in columns {
            let _ = write!(out, "{:>width$.digits$}", get(k));
        }
        out.push('\n');
    }
}

//! `shoal motion`: print a Table 1 preset's sampled motion as JSON or CSV.

use std::io::Write as _;
use std::process::ExitCode;

use anyhow::Context as _;

use shoal_core::motion::{Body, Preset, Recording, TurnKind, record_preset};

/// Output format of `shoal motion`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Format {
    /// `{"preset", "params", "rate_hz", "joints_x", "frames": [...]}`.
    #[default]
    Json,
    /// `#` comment lines with the parameters, a header, one row per frame.
    Csv,
}

/// Overrides of a preset's Table 1 values, shared by `shoal motion` and `shoal plot`.
#[derive(Debug, Clone, Default, clap::Args)]
pub struct PresetArgs {
    /// Table 1 experiment: ex1 (swim), ex2 (normal turn), ex3 (quick turn), ex4 (serial turn).
    #[arg(long, default_value = "ex1")]
    pub preset: String,
    /// Pivot position p, fraction of body length from the head (λ' > 0 needs p > 0.1424).
    #[arg(long, allow_hyphen_values = true)]
    pub p: Option<f32>,
    /// Speed s, length units per second.
    #[arg(long, allow_hyphen_values = true)]
    pub s: Option<f32>,
    /// Body length l, length units (maxAmp and λ scale with it).
    #[arg(long, allow_hyphen_values = true)]
    pub l: Option<f32>,
    /// Turn direction d: -1 left, 0 straight, 1 right (on ex1, ±1 makes a normal turn).
    #[arg(long, allow_hyphen_values = true)]
    pub d: Option<i32>,
    /// Turning time Tt, SECONDS (Table 1 prints milliseconds: 2000 ms = 2).
    #[arg(long, allow_hyphen_values = true)]
    pub tt: Option<f32>,
    /// Turn amplitude weight f, in [1, 2].
    #[arg(long, allow_hyphen_values = true)]
    pub f: Option<f32>,
    /// Turn angle, DEGREES (default 90).
    #[arg(long, allow_hyphen_values = true)]
    pub angle: Option<f32>,
}

impl PresetArgs {
    /// The preset with the overrides applied, validated.
    pub fn resolve(&self) -> anyhow::Result<Preset> {
        let mut preset = Preset::by_name(&self.preset)?;
        if let Some(l) = self.l {
            preset.params = preset.params.with_length(l);
        }
        let p = &mut preset.params;
        if let Some(v) = self.p {
            p.p = v;
        }
        if let Some(v) = self.s {
            p.s = v;
        }
        if let Some(v) = self.tt {
            if v >= 100.0 {
                log::warn!(
                    "--tt {v} is read as seconds; Table 1 prints milliseconds (2000 ms is --tt 2)"
                );
            }
            p.tt = v;
        }
        if let Some(v) = self.f {
            p.f = v;
        }
        if let Some(degrees) = self.angle {
            // Checked here, in the unit the designer typed (the motion layer speaks radians).
            if !(degrees.is_finite() && degrees > 0.0 && degrees <= 360.0) {
                anyhow::bail!(
                    "--angle {degrees}: the turn angle must be in (0, 360] degrees; the direction \
                     is --d (-1 left, 1 right)"
                );
            }
            p.turn_angle = degrees.to_radians();
        }
        if let Some(d) = self.d {
            preset.d = d;
            if d != 0 && preset.turn.is_none() {
                preset.turn = Some(TurnKind::Normal);
            }
        }
        preset
            .validate()
            .with_context(|| format!("preset {}", preset.name))?;
        Ok(preset)
    }
}

/// Arguments of `shoal motion`.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// Which preset, and overrides of its values.
    #[command(flatten)]
    pub preset: PresetArgs,
    /// Seconds to sample.
    #[arg(long, default_value_t = 4.0, allow_hyphen_values = true)]
    pub seconds: f32,
    /// Samples per second.
    #[arg(long, default_value_t = 60.0, allow_hyphen_values = true)]
    pub rate: f32,
    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Json)]
    pub format: Format,
}

impl Default for Args {
    fn default() -> Self {
        Self {
            preset: PresetArgs {
                preset: "ex1".to_owned(),
                ..PresetArgs::default()
            },
            seconds: 4.0,
            rate: 60.0,
            format: Format::Json,
        }
    }
}

/// Samples the motion `args` describes (the library side of `shoal motion`).
pub fn recording(args: &Args) -> anyhow::Result<Recording> {
    let preset = args.preset.resolve()?;
    Ok(record_preset(
        &preset,
        &Body::black_porgy(),
        args.seconds,
        args.rate,
    )?)
}

/// Runs `shoal motion`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let rec = recording(&args)?;
    let text = match args.format {
        Format::Json => serde_json::to_string(&rec)? + "\n",
        Format::Csv => rec.to_csv(),
    };
    let mut stdout = std::io::stdout().lock();
    // A closed pipe (`| head`) is not an error worth a message.
    match stdout.write_all(text.as_bytes()) {
        Err(e) if e.kind() == std::io::ErrorKind::BrokenPipe => {}
        other => other.context("writing to stdout")?,
    }
    Ok(ExitCode::SUCCESS)
}

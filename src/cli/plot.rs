//! `shoal plot`: draw a preset's body midlines (paper Fig. 4, 6) and, seen from above, the body
//! along its path (Fig. 7–9) into a PNG ([`shoal_script::plot::motion`] draws it).

use std::path::PathBuf;
use std::process::ExitCode;

use super::motion::PresetArgs;
use shoal_script::plot::motion::draw;

/// Arguments of `shoal plot`.
#[derive(Debug, Clone, clap::Args)]
pub struct Args {
    /// Which preset, and overrides of its values.
    #[command(flatten)]
    pub preset: PresetArgs,
    /// PNG to write.
    #[arg(long, default_value = "motion.png")]
    pub out: PathBuf,
    /// Image width, pixels.
    #[arg(long, default_value_t = 1400)]
    pub width: u32,
    /// Image height, pixels.
    #[arg(long, default_value_t = 700)]
    pub height: u32,
}

impl Default for Args {
    fn default() -> Self {
        Self {
            preset: PresetArgs {
                preset: "ex1".to_owned(),
                ..PresetArgs::default()
            },
            out: PathBuf::from("motion.png"),
            width: 1400,
            height: 700,
        }
    }
}

/// Runs `shoal plot`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    if !(200..=8000).contains(&args.width) || !(150..=8000).contains(&args.height) {
        anyhow::bail!(
            "image size {}×{} is out of range: width 200–8000, height 150–8000 pixels",
            args.width,
            args.height
        );
    }
    let preset = args.preset.resolve()?;
    let text = draw(&preset, &args.out, (args.width, args.height))?;
    if !text {
        log::warn!(
            "no usable font found: {} was drawn without text",
            args.out.display()
        );
    }
    log::info!("wrote {}", args.out.display());
    Ok(ExitCode::SUCCESS)
}

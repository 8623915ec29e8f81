//! `shoal set FILE KEY.PATH=VALUE …`: writes values into a species or scene file, changing only
//! those literals ([`shoal_script::edit`], the code path of the panel's "save").

use std::path::PathBuf;
use std::process::ExitCode;

use shoal_script::edit::{Edit, EditOptions, save};

/// Arguments of `shoal set`.
#[derive(Debug, clap::Args)]
#[command(after_help = "Examples:\n  \
    shoal set scripts/species/black_porgy.lua motion.s=70 motion.omega=12\n  \
    shoal set scripts/scenes/default.lua 'obstacles[1].pos={260, 60, -100}' currents[1].radius=175\n\n\
    Only the literals named change: comments, order and spacing stay byte for byte. A key the \
    file does not have yet is added to its table in the file's indentation (missing tables are \
    created). Values are Lua literals: numbers, true/false, \"strings\" (a bare word is a \
    string), and tables like {1, 2, 3}. The result is read as the simulation reads it before \
    anything is written: an unknown key (with a \"did you mean\"), a value of the wrong type or \
    out of range is refused and the file is left as it was. A running aquarium reloads the file \
    as after any save.")]
pub struct Args {
    /// The species file (scripts/species/*.lua) or scene file (scripts/scenes/*.lua).
    pub file: PathBuf,
    /// Edits as KEY.PATH=VALUE: `motion.s=70`, `obstacles[2].radius=50`.
    #[arg(required = true, value_name = "KEY.PATH=VALUE")]
    pub edits: Vec<String>,
    /// Also replace values written as expressions (`max_amp = 80 * 0.16`); the old expression
    /// stays beside the new value in a comment.
    #[arg(long)]
    pub replace_expressions: bool,
}

/// Runs `shoal set`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let edits = args
        .edits
        .iter()
        .map(|e| Edit::parse(e))
        .collect::<Result<Vec<_>, _>>()?;
    let opts = EditOptions {
        replace_expressions: args.replace_expressions,
    };
    // Every refusal names the file (and the line): one line, as it is.
    let saved = save(&args.file, &edits, opts)?;
    let names: Vec<String> = edits
        .iter()
        .map(|e| format!("{} = {}", e.path, e.value.text()))
        .collect();
    if saved.changed {
        println!("{}: set {}", saved.path.display(), names.join(", "));
    } else {
        println!(
            "{}: unchanged (already {})",
            saved.path.display(),
            names.join(", ")
        );
    }
    Ok(ExitCode::SUCCESS)
}

//! The fish a kinematic study measures (`shoal kinematics`), read from a species file (the
//! measuring itself is `shoal_core::motion::kinematics`, which needs no Lua).

use std::path::{Path, PathBuf};

use shoal_core::motion::kinematics::{Mode, Subject};
use shoal_core::motion::{Body, MotionError, Preset};
use shoal_core::world::{Species, WorldError};

use crate::scene::species_from_table;
use crate::{Limits, ScriptError, ScriptHost};

/// Why the fish to measure could not be had.
#[derive(Debug, thiserror::Error)]
pub enum SubjectError {
    /// No such Table 1 preset.
    #[error(transparent)]
    Preset(#[from] MotionError),
    /// No species file of that name.
    #[error("unknown species {name:?}: no file {}; species here: {known}", path.display())]
    UnknownSpecies {
        /// The name asked for.
        name: String,
        /// The file looked for.
        path: PathBuf,
        /// The species that are there, comma-separated ("none" when none).
        known: String,
    },
    /// Lua could not be started over the scripts directory.
    #[error("starting Lua for {}: {source}", scripts.display())]
    Lua {
        /// The scripts directory.
        scripts: PathBuf,
        /// Why.
        source: ScriptError,
    },
    /// The species file could not be run.
    #[error("reading {file}: {source}")]
    Read {
        /// The species file.
        file: String,
        /// Why.
        source: ScriptError,
    },
    /// The species file returned something other than a table.
    #[error("{file}: a species file must return a table")]
    NotATable {
        /// The species file.
        file: String,
    },
    /// The species file's table is not a species (the message names the file and the field).
    #[error(transparent)]
    Invalid(#[from] crate::scene::SpeciesFileError),
    /// The species' motion parameters are out of range.
    #[error("{file}: motion: {source}")]
    Motion {
        /// The species file.
        file: String,
        /// Which parameter, and why.
        source: MotionError,
    },
    /// The species' model could not be loaded.
    #[error("{file}: loading its model from {}: {source}", assets.display())]
    Model {
        /// The species file.
        file: String,
        /// The assets directory.
        assets: PathBuf,
        /// Why.
        source: WorldError,
    },
}

/// The fish `shoal kinematics` measures: a Table 1 `preset` (ex1 … ex4) on the black porgy's
/// body, or a `species` file (a name under `root`/scripts/species, or a path to a .lua file; the
/// black porgy when neither is given) on its model from `root`/assets. `mode` overrides the
/// published data it is compared with (by default the species' own swimming mode).
pub fn subject(
    species: Option<&str>,
    preset: Option<&str>,
    mode: Option<Mode>,
    root: &Path,
) -> Result<Subject, SubjectError> {
    if let Some(name) = preset {
        let preset = Preset::by_name(name)?;
        return Ok(Subject {
            name: preset.name.to_owned(),
            source: "Table 1 (swimming straight)".to_owned(),
            params: preset.params,
            body: Body::black_porgy(),
            mode: mode.unwrap_or(Mode::Carangiform),
        });
    }
    let name = species.unwrap_or("black_porgy");
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
        return Err(SubjectError::UnknownSpecies {
            name: name.to_owned(),
            path,
            known: if known.is_empty() {
                "none".to_owned()
            } else {
                known.join(", ")
            },
        });
    }
    let host =
        ScriptHost::new(&scripts, Limits::default()).map_err(|source| SubjectError::Lua {
            scripts: scripts.clone(),
            source,
        })?;
    let display = path.display().to_string();
    let value = host
        .load_data_file(&path)
        .map_err(|source| SubjectError::Read {
            file: display.clone(),
            source,
        })?;
    let mlua::Value::Table(table) = value else {
        return Err(SubjectError::NotATable { file: display });
    };
    let file = species_from_table(host.lua(), &display, table)?;
    let desc = file.desc;
    desc.motion
        .validate()
        .map_err(|source| SubjectError::Motion {
            file: display.clone(),
            source,
        })?;
    let species_name = desc.name.clone();
    let assets = root.join("assets");
    let species = Species::load(desc, &assets).map_err(|source| SubjectError::Model {
        file: display.clone(),
        assets: assets.clone(),
        source,
    })?;
    Ok(Subject {
        mode: mode.unwrap_or(Mode::of(&species.desc.motion)),
        name: species_name,
        source: display,
        params: species.desc.motion,
        body: species.rig.body.clone(),
    })
}

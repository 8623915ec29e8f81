//! Typed errors of the script host. Every variant names the file (and, for Lua errors, the line)
//! so a designer can act on it.

use std::path::PathBuf;

use shoal_core::world::FishId;

/// An error of the script layer: loading scripts, species and scenes, or running the simulation.
#[derive(Debug, thiserror::Error)]
pub enum ScriptError {
    /// A file could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A Lua error (syntax or runtime), already formatted as `file:line: message`.
    #[error("{0}")]
    Lua(String),
    /// A scene starts more fish than this machine's memory holds (refused before spawning).
    #[error("{file}: {source}")]
    TooManyFish {
        /// The scene file, as shown.
        file: String,
        /// The count, its estimate and the memory available.
        source: shoal_core::world::footprint::TooManyFish,
    },
    /// A data file (species or scene) has a value the host rejects.
    #[error("{file}: {why}")]
    Data {
        /// The file, as shown to the user (`scripts/scenes/default.lua`).
        file: String,
        /// What is wrong and what was expected.
        why: String,
    },
    /// A value of a data file (species or scene) is not of the type its field wants.
    #[error(transparent)]
    Field(Box<crate::scene::FieldError>),
    /// A species file's table is not a species.
    #[error(transparent)]
    Species(Box<crate::scene::SpeciesFileError>),
    /// A scene's number is out of its range.
    #[error("{file}: {source}")]
    Scene {
        /// The scene file, as shown.
        file: String,
        /// Which field, and why.
        source: Box<crate::scene::SceneValueError>,
    },
    /// The world rejected a request made while building or running a scene.
    #[error("{context}: {source}")]
    World {
        /// What the host was doing (`scripts/scenes/default.lua: spawning fish 3`).
        context: String,
        /// The world's error.
        source: shoal_core::world::WorldError,
    },
    /// A file's logpoints do not fit it (see [`crate::logpoints`]).
    #[error("{file}: logpoint: {source}")]
    Logpoint {
        /// The file, as shown to the user.
        file: String,
        /// What is wrong.
        source: crate::logpoints::LogpointError,
    },
    /// The file watcher for hot reload could not start.
    #[error("cannot watch {path} for changes: {why}")]
    Watch {
        /// The directory.
        path: PathBuf,
        /// Why.
        why: String,
    },
}

// The data files' errors are boxed: they are the largest, and every `Result` of the host
// carries a `ScriptError`.
impl From<crate::scene::FieldError> for ScriptError {
    fn from(e: crate::scene::FieldError) -> Self {
        Self::Field(Box::new(e))
    }
}

impl From<crate::scene::SpeciesFileError> for ScriptError {
    fn from(e: crate::scene::SpeciesFileError) -> Self {
        Self::Species(Box::new(e))
    }
}

/// Why a behaviour decision failed. It is already in the console (once per distinct message) and
/// kept for the inspector; the fish keeps whatever motion it had.
#[derive(Debug, thiserror::Error)]
pub enum DecisionError {
    /// The script raised an error or called the API wrongly.
    #[error("{message}")]
    Raised {
        /// The message as the console shows it: `file:line: message`, or `file: message` where
        /// Lua gave no line.
        message: String,
    },
    /// The instruction budget, the time limit or the memory limit stopped the call (enough of
    /// these switch the behaviour off: see [`crate::host::QUARANTINE_AFTER_LIMIT_HITS`]).
    #[error("{message}")]
    Stopped {
        /// The message as the console shows it.
        message: String,
    },
    /// The fish's table (its `memory`, `params`…) could not be made.
    #[error(transparent)]
    NoTable(#[from] ScriptError),
}

/// Why Lua given to a host to evaluate (the console's REPL, watches, the debugger's conditions
/// and `evaluate`) gave no value.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    /// The fish has not run a decision yet, so it has no table to evaluate in: not a fault of
    /// the code.
    #[error("fish #{} has not decided yet: it has no table", .0.index)]
    NotDecided(FishId),
    /// The fish is not in the tank.
    #[error("fish #{} is not in the tank", .0.index)]
    NotInTank(FishId),
    /// The code does not compile.
    #[error("{}", describe(.0))]
    Syntax(mlua::Error),
    /// Running it raised an error or was stopped by a limit.
    #[error("{}", describe(.0))]
    Runtime(mlua::Error),
    /// The environment to run it in could not be made.
    #[error("{}", describe(.0))]
    Setup(mlua::Error),
}

pub use crate::lua_error::describe;

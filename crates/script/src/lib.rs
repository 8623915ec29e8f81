//! shoal-script: the paper's perception, intention and behaviour layers (section 3.1) as Lua,
//! and what is built on running them: recordings, replays and comparisons ([`timeline`]) and
//! scripted behaviour tests ([`testing`]).
//!
//! The paper's architecture puts three decision layers above the motion layer: *perception*
//! (vision and body sensors), *intention* (which goal wins given what is perceived and the
//! fish's drives) and *behaviour* (a sequence of motions reaching that goal: feed-hunting,
//! crowding, escape). In shoal those layers are Lua modules in `scripts/behaviors/` that
//! designers edit while the aquarium runs; everything below them is Rust.
//!
//! - [`sandbox`]: the Lua state — trimmed standard library, `require` confined to `scripts/`,
//!   text-only chunks, an instruction budget per call and a memory limit.
//! - [`strings`]: bounded replacements for the string functions that can run long in C.
//! - [`host`]: one Lua state (a script lane) — modules loaded once per file, per-fish tables with
//!   their `memory`, one protected call per decision, error formatting and deduplication
//!   ([`log`]). [`Simulation`] runs several lanes in parallel.
//! - [`api`]: the `shoal` table scripts program against (documented for editors in
//!   `scripts/types/shoal.lua`).
//! - [`scene`]: species and scene files read through serde.
//! - [`reload`]: the directory watcher behind hot reload.
//! - [`sim`]: [`Simulation`], the fixed-tick loop tying scripts to the [`shoal_core::world`].
//! - [`debug`]: a Debug Adapter Protocol server (breakpoints, steps, variables) for editors.
//! - [`fish_state`]: a lane's per-fish state copied and put back (rewinding a simulation).
//! - [`watchdog`] and [`profiler`]: the budget hook turned on only for long calls, stack samples
//!   per function and allocations per module, with no per-instruction hook.

#![warn(missing_docs)]

pub mod api;
pub mod budget;
pub mod check;
pub mod debug;
pub mod edit;
pub mod error;
pub mod fish_state;
pub mod host;
pub mod kinematics;
pub mod log;
pub mod logpoints;
pub mod lua_error;
pub mod plot;
pub mod profiler;
pub mod reload;
pub mod sandbox;
pub mod scene;
pub mod sim;
pub mod stolen;
pub mod strings;
pub mod testing;
pub mod timeline;
pub mod versions;
pub mod watchdog;

pub use error::{DecisionError, EvalError, ScriptError};
pub use host::ScriptHost;
pub use log::{LogEntry, LogLevel};
pub use sandbox::Limits;
pub use scene::SceneDesc;
pub use sim::{
    BorrowedModel, MeasureResult, ReloadEvent, SetupProgress, SimSnapshot, Simulation, lane_index,
};

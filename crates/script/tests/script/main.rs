//! Integration tests of shoal-script: Lua behaviours, the sandbox, reload and the designer loop (CPU only).
//!
//! One test binary for the crate: each file below was a binary of its own, and each binary
//! linked the whole dependency tree again.

mod common;
mod designer_loop;
mod run_file_fuzz;
mod save;
mod script_api;
mod script_behaviors;
mod script_console;
mod script_hostile;
mod script_lanes;
mod script_lod;
mod script_profile;
mod script_reload;
mod script_sandbox;
mod script_scene;
mod script_snapshot;
mod script_strings;
mod script_types;
mod script_watchdog;
mod timeline_plot;

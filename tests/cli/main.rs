//! Integration tests of the `shoal` command line: each test runs the built binary (the window ones under Xvfb).
//!
//! One test binary for the crate: each file below was a binary of its own, and each binary
//! linked the whole dependency tree again.

mod asset_porgy;
mod asset_species;
mod behavior_suite;
mod bench_peer;
mod closed_pipe;
mod common;
mod dap;
mod designer_folder;
mod export;
mod midline_kinematics;
mod motion_cli;
mod motion_kinematics;
mod motion_plot;
mod render_cli;
mod script_check;
mod set_cli;
mod skin_cli;
mod test_cli;
mod timeline;
mod timeline_compare;
mod window_run;
mod window_split;
mod world_bench_cli;
mod xvfb_common;

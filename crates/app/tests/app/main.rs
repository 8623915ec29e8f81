//! Integration tests of shoal-app: the window's panel and scene driven without a window (egui_kittest), drawing on a real adapter.
//!
//! One test binary for the crate: each file below was a binary of its own, and each binary
//! linked the whole dependency tree again.

mod common;
mod render_pose;
mod render_world;
mod window_panel;
mod window_scene;
mod window_scripts;
mod window_timeline;

//! Integration tests of shoal-render: drawing on a real adapter (lavapipe in CI).
//!
//! One test binary for the crate: each file below was a binary of its own, and each binary
//! linked the whole dependency tree again.

mod common;
mod render_cull;
mod render_lod;
mod render_materials;
mod render_parts;
mod render_reference;
mod render_shaders;
mod render_skinning;

//! Integration tests of shoal-core: CPU only (motion, skeleton, skinning, assets, world).
//!
//! One test binary for the crate: each file below was a binary of its own, and each binary
//! linked the whole dependency tree again.

mod asset_animation;
mod asset_rig;
mod asset_weights;
mod common;
mod layering;
mod motion_common;
mod motion_player;
mod motion_props;
mod skeleton_chain;
mod skin_errors;
mod skin_fuzz;
mod skin_lbs;
mod skin_samples;
mod world_common;
mod world_contact;
mod world_fish;
mod world_food;
mod world_gpu_shape;
mod world_grid;
mod world_pose;
mod world_state;

//! shoal: a sandbox where designers script artificial fish in Lua and watch them swim.
//!
//! The crate follows the seven layers of Kim et al., "Real-time Motion Generating Method for
//! Artificial Fish" (2007). Perception, intention and behaviour are Lua scripts run by
//! [`script`]; everything below them is Rust and flows one way:
//!
//! | paper layer | module |
//! |---|---|
//! | Perception / Intention / Behavior | [`script`] (Lua host), sensor queries answered by [`world`] |
//! | Motion (eq. 2–7, Table 1) | [`motion`] |
//! | Skeletal (section 3.2) | [`skeleton`] |
//! | Skin mesh (eq. 1) | [`skin`], assets built by [`asset`] |
//! | Animation | [`render`] (drawing), [`app`] (the window and its panel) |
//!
//! Around the layers: [`testing`] runs scripted behaviour tests (`shoal test`), [`timeline`]
//! records, replays and compares runs (`shoal record`, `replay`, `diff`).

#![warn(missing_docs)]

pub mod app;
pub mod asset;
pub mod cli;
pub mod math;
pub mod motion;
pub mod render;
pub mod script;
pub mod skeleton;
pub mod skin;
pub mod species;
pub mod testing;
pub mod timeline;
pub mod world;

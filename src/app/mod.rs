//! The aquarium application: the window (`shoal run`), its egui tuning panel, and the adapter
//! that shows a simulation through the renderer.
//!
//! - [`SimView`] is what the app sees of a simulation: whole 60 Hz ticks of a
//!   [`crate::world::World`], plus inspector lines, a log and hot reload where the simulation has
//!   them. [`crate::script::Simulation`] (Lua behaviours) and [`crate::world::bench::RustSim`]
//!   (the built-in Rust driver) implement it, in [`sim`].
//! - [`WorldScene`] turns a [`SimView`] into what [`crate::render::Renderer`] draws (meshes,
//!   palettes, instances, props, overlays) and answers the panel's questions about a fish, by
//!   [`crate::world::FishId`].
//! - `split` holds the split tank's second version of the scripts (`shoal run --split`),
//!   time-locked with the first.
//! - [`Aquarium`] is the window's state and per-frame logic without a window (selection,
//!   camera, time controls, console, panel), so UI tests drive what `shoal run` does;
//!   [`run_window`] puts it in a winit window.
//!
//! The renderer ([`crate::render`]) knows none of this: it takes plain frame data.

mod aquarium;
mod panel;
mod pointer;
mod scene;
pub mod scripts_panel;
pub mod sim;
mod split;
mod timeline;
mod window;

pub use aquarium::{Aquarium, DynScene, pick_fish};
pub use pointer::Pointer;
pub use scene::{FOOD_PELLET_RADIUS, FishInfo, OverlayToggles, WorldScene};
pub use sim::{LogLine, SimError, SimState, SimView};
pub use split::{SplitError, SplitVersions};
pub use timeline::{
    DEFAULT_SPAN_S, Divergence, GHOST_COLOR, NEW_PATH_COLOR, TETHER_COLOR, Timeline,
};
pub use window::{AppError, AppOptions, run_aquarium, run_window};

//! The aquarium application: the window (`shoal run`), its egui tuning panel, and the adapter
//! that shows a simulation through the renderer.
//!
//! - [`Showable`] is what the app sees of a simulation: whole 60 Hz ticks of a
//!   [`shoal_core::world::World`], plus inspector lines, a log and hot reload where the simulation has
//!   them. [`shoal_script::Simulation`] (Lua behaviours) and [`shoal_core::world::driver::WanderPipeline`]
//!   (the built-in Rust driver) implement it, in [`sim`].
//! - [`WorldScene`] turns a [`Showable`] into what [`shoal_render::Renderer`] draws (meshes,
//!   palettes, instances, props, overlays) and answers the panel's questions about a fish, by
//!   [`shoal_core::world::FishId`].
//! - `split` holds the split tank's second version of the scripts (`shoal run --split`),
//!   time-locked with the first.
//! - [`Aquarium`] is the window's state and per-frame logic without a window (selection,
//!   camera, time controls, console, panel), so UI tests drive what `shoal run` does;
//!   [`run_window`] puts it in a winit window.
//!
//! The renderer ([`shoal_render`]) knows none of this: it takes plain frame data.

#![warn(missing_docs)]

mod aquarium;
mod pacing;
mod panel;
mod pointer;
mod scene;
mod scene_edit;
mod scene_view;
pub mod scripts_panel;
pub mod showable;
mod split;
mod timeline;
mod tuned;
mod ui_state;
mod widgets;
mod window;

pub use aquarium::{AppOptions, Aquarium};
pub use pointer::Pointer;
pub use scene::{DynScene, FOOD_PELLET_RADIUS, FishInfo, OverlayToggles, WorldScene};
pub use showable::{LogLine, Showable, SimError, SimState};
pub use split::{SplitError, SplitVersions};
pub use timeline::{
    DEFAULT_SPAN_S, Divergence, GHOST_COLOR, NEW_PATH_COLOR, TETHER_COLOR, Timeline,
};
pub use ui_state::pick_fish;
pub use window::{AppError, run_aquarium, run_window};

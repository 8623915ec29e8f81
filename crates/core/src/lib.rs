//! shoal's core: the paper's layers below the scripts, with no window, GPU or Lua.
//!
//! shoal follows the seven layers of Kim et al., "Real-time Motion Generating Method for
//! Artificial Fish" (2007). This crate holds the Rust layers that need neither a GPU nor a Lua
//! VM, and the world that answers the scripts' sensor queries; the crates above it name it, it
//! names none of them (Cargo enforces the direction):
//!
//! | paper layer | where |
//! |---|---|
//! | Perception / Intention / Behavior | Lua, run by `shoal-script`; sensor queries answered by [`world`] |
//! | Motion (eq. 2–7, Table 1) | [`motion`] |
//! | Skeletal (section 3.2) | [`skeleton`] |
//! | Skin mesh (eq. 1) | [`skin`], assets built by [`asset`], species by [`species`] |
//! | Animation | `shoal-render` (drawing), `shoal-app` (the window and its panel) |

#![warn(missing_docs)]

pub mod asset;
pub mod math;
pub mod motion;
pub mod prefetch;
pub mod skeleton;
pub mod skin;
pub mod species;
pub mod world;

/// The root of the source tree this crate was built from: it holds the shipped `assets/`,
/// `scripts/` and `shaders/`, used where a designer's folder has none of its own.
pub fn source_root() -> &'static std::path::Path {
    // This crate sits at `crates/core` in the source tree.
    let manifest = std::path::Path::new(env!("CARGO_MANIFEST_DIR"));
    manifest.ancestors().nth(2).unwrap_or(manifest)
}

//! Watches `scripts/` for saved files (hot reload).
//!
//! The whole directory tree is watched, not single files: editors save by writing a temporary
//! file and renaming it over the old one, which a per-file watch loses. Events are debounced
//! ([`DEBOUNCE`]) so a save that touches a file several times reloads it once; with the app
//! polling every frame, a save is picked up well within 250 ms.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, channel};
use std::time::Duration;

use notify_debouncer_full::notify::RecursiveMode;
use notify_debouncer_full::{
    DebounceEventResult, Debouncer, RecommendedCache, new_debouncer, notify::RecommendedWatcher,
};

use super::error::ScriptError;

/// Quiet time after the last event of a file before it is reported.
pub const DEBOUNCE: Duration = Duration::from_millis(100);

/// A recursive watch on the script directory.
pub struct ScriptWatcher {
    _debouncer: Debouncer<RecommendedWatcher, RecommendedCache>,
    events: Receiver<DebounceEventResult>,
}

impl ScriptWatcher {
    /// Starts watching `dir` and everything under it.
    pub fn new(dir: &Path) -> Result<Self, ScriptError> {
        let fail = |why: String| ScriptError::Watch {
            path: dir.to_path_buf(),
            why,
        };
        let (tx, rx) = channel();
        let mut debouncer =
            new_debouncer(DEBOUNCE, Some(DEBOUNCE / 4), tx).map_err(|e| fail(e.to_string()))?;
        debouncer
            .watch(dir, RecursiveMode::Recursive)
            .map_err(|e| fail(e.to_string()))?;
        Ok(Self {
            _debouncer: debouncer,
            events: rx,
        })
    }

    /// The `.lua` files changed (written, created or renamed into place) since the last call,
    /// sorted, each once. Never blocks.
    pub fn changed(&self) -> Vec<PathBuf> {
        let mut out = BTreeSet::new();
        while let Ok(result) = self.events.try_recv() {
            let Ok(events) = result else {
                continue;
            };
            for ev in events {
                if ev.kind.is_access() || ev.kind.is_remove() {
                    continue;
                }
                for p in &ev.paths {
                    if p.extension().is_some_and(|e| e == "lua") && p.is_file() {
                        out.insert(p.clone());
                    }
                }
            }
        }
        out.into_iter().collect()
    }
}

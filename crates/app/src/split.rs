//! The split tank (issue 14): a second version of the scripts (B) run beside the first (A) from
//! the same scene and seed, time-locked — every tick A runs, B runs; a seek puts both at the
//! same moment — with the fish whose positions differ between the two listed as the timeline
//! lists the fish that left their ghost (first tick they differed, bit for bit, and how far
//! apart they got). The window draws both views side by side.
//!
//! B lives beside A's history: its own [`Timeline`] (so the slider can take it back too) and
//! its own scene; the comparison reads both histories' per-tick positions.

use std::path::PathBuf;

use super::scene::DynScene;
use super::showable::{Showable, SimError};
use super::timeline::{Divergence, GHOST_COLOR, NEW_PATH_COLOR, Timeline};
use shoal_core::world::{FishId, SpeciesId, TICK_HZ};
use shoal_render::OverlayLine;
use shoal_script::timeline::run_file::{changed_scripts, read_scripts};

/// What the two versions are, for the views' labels and the list of files that differ.
#[derive(Debug, Clone, Default)]
pub struct SplitVersions {
    /// Version A's label (`working tree scripts/`).
    pub a: String,
    /// Version B's label (`git:HEAD~1 (3f2a1c0)`, or its directory).
    pub b: String,
    /// A's and B's scripts directories, to say which files differ (again after a hot reload);
    /// `None` lists none.
    pub dirs: Option<(PathBuf, PathBuf)>,
}

/// Why two simulations cannot be shown as a split tank.
#[derive(Debug, thiserror::Error)]
pub enum SplitError {
    /// The two do not start at the same moment.
    #[error("the two versions start at different ticks (A at {a}, B at {b})")]
    NotInStep {
        /// A's tick.
        a: u64,
        /// B's tick.
        b: u64,
    },
    /// The two have different species (the window draws both with one set of meshes).
    #[error(
        "the two versions have different species (A: {a}; B: {b}); a split tank compares \
         behaviours of the same fish"
    )]
    Species {
        /// A's species, by name.
        a: String,
        /// B's species, by name.
        b: String,
    },
    /// B could not be put back to a state its history kept.
    #[error(transparent)]
    Rewind(#[from] SimError),
    /// B's history has no state to go back to.
    #[error("B has kept no state to go back to")]
    NothingKept,
    /// B's history does not reach the moment A went to.
    #[error(
        "B went to {reached_s:.2} s, not {wanted_s:.2} s: its history does not reach that moment"
    )]
    NotReached {
        /// Where B went, seconds.
        reached_s: f64,
        /// Where A went, seconds.
        wanted_s: f64,
    },
}

/// Version B of the split tank and the comparison with A (see the module docs).
pub struct Split {
    /// Version B's simulation.
    pub(super) scene: DynScene,
    /// B's history (kept states and per-tick positions), seeked with A's.
    pub(super) timeline: Timeline,
    /// Fish whose positions differ between A and B, by the time they first did.
    pub(super) divergences: Vec<Divergence>,
    /// The last tick compared.
    compared_to: u64,
    pub(super) versions: SplitVersions,
    /// Script files (relative paths) that differ between A and B.
    pub(super) changed: Vec<String>,
    /// B's inspector lines for the selected fish.
    pub(super) inspect: Vec<(String, String)>,
    /// B's overlay segments.
    pub(super) overlay: Vec<OverlayLine>,
}

impl Split {
    /// B beside `a` (both at the same tick, with the same species); records B's first moment.
    pub(super) fn new(
        a: &DynScene,
        b: Box<dyn Showable>,
        versions: SplitVersions,
    ) -> Result<(Self, Option<String>), SplitError> {
        let scene = DynScene::new(b);
        let (ta, tb) = (a.world().tick_count(), scene.world().tick_count());
        if ta != tb {
            return Err(SplitError::NotInStep { a: ta, b: tb });
        }
        let kinds = |s: &DynScene| {
            let w = s.world();
            (0..w.num_species())
                .map(|i| {
                    let sp = w.species(SpeciesId(i as u16));
                    (
                        sp.desc.name.clone(),
                        sp.model.mesh.positions.len(),
                        sp.model.skeleton.parents().len(),
                    )
                })
                .collect::<Vec<_>>()
        };
        let (ka, kb) = (kinds(a), kinds(&scene));
        if ka != kb {
            let names = |k: &[(String, usize, usize)]| {
                k.iter()
                    .map(|(n, _, _)| n.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            };
            return Err(SplitError::Species {
                a: names(&ka),
                b: names(&kb),
            });
        }
        let mut split = Self {
            scene,
            timeline: Timeline::default(),
            divergences: Vec::new(),
            compared_to: ta,
            versions,
            changed: Vec::new(),
            inspect: Vec::new(),
            overlay: Vec::new(),
        };
        split.refresh_changed();
        let note = split.timeline.record(split.scene.sim());
        Ok((split, note))
    }

    /// Lists again the script files that differ (after a hot reload).
    pub(super) fn refresh_changed(&mut self) {
        self.changed = match &self.versions.dirs {
            Some((a, b)) => match (read_scripts(a), read_scripts(b)) {
                (Ok(a), Ok(b)) => changed_scripts(&a, &b),
                _ => Vec::new(),
            },
            None => Vec::new(),
        };
    }

    /// Runs B as many ticks as A just ran (`a_history` holds A's positions), recording each in
    /// B's history, then compares the new ticks. Returns B's history notes for the console.
    pub(super) fn follow(&mut self, a_history: &Timeline, ticks: u64) -> Vec<String> {
        let mut notes = Vec::new();
        let timeline = &mut self.timeline;
        self.scene
            .step_ticks(ticks, |sim| notes.extend(timeline.record(sim)));
        if self.scene.take_reloaded() {
            self.refresh_changed();
        }
        self.compare(a_history);
        notes
    }

    /// Compares B's new ticks with A's.
    fn compare(&mut self, a_history: &Timeline) {
        let now = self.scene.world().tick_count();
        self.timeline
            .compare_with(a_history, self.compared_to + 1, now, &mut self.divergences);
        self.compared_to = now;
    }

    /// Takes B to A's moment (`a_history` is A's history, already seeked) and lists again the
    /// fish that differ up to it. Fails, saying why, when B's history cannot reach that tick.
    pub(super) fn seek(&mut self, a_history: &Timeline, tick: u64) -> Result<(), SplitError> {
        let time_s = tick as f64 / TICK_HZ;
        let result = match self.timeline.seek(time_s) {
            Some((state, ticks)) => self
                .scene
                .rewind_to(state, ticks)
                .map_err(SplitError::Rewind),
            None => Err(SplitError::NothingKept),
        };
        self.divergences.clear();
        let from = self.timeline.first_tick().unwrap_or(0);
        let now = self.scene.world().tick_count();
        self.compared_to = from.saturating_sub(1);
        self.compare(a_history);
        result?;
        if now != tick {
            return Err(SplitError::NotReached {
                reached_s: now as f64 / TICK_HZ,
                wanted_s: time_s,
            });
        }
        Ok(())
    }

    /// After a scene restart: B restarted too; forget both histories' comparison.
    pub(super) fn restarted(&mut self) -> Option<String> {
        self.timeline.clear();
        self.divergences.clear();
        self.compared_to = self.scene.world().tick_count();
        self.timeline.record(self.scene.sim())
    }

    /// B's overlays: `toggles`' segments of B's fish, and A's path (faint) beside B's (orange)
    /// over the last `before_s` seconds — for `selected` alone when a fish is selected (its A
    /// path only if it differs), else for every fish that differs from A.
    pub(super) fn refresh_overlay(
        &mut self,
        a_history: &Timeline,
        toggles: super::OverlayToggles,
        selected: Option<FishId>,
        before_s: f64,
    ) {
        self.overlay.clear();
        if toggles.any() {
            self.scene.overlay_lines(toggles, &mut self.overlay);
        }
        let now = self.scene.world().tick_count();
        let from = now.saturating_sub((before_s * TICK_HZ) as u64);
        let fish: Vec<FishId> = match selected {
            Some(id) => vec![id],
            None => self.divergences.iter().map(|d| d.fish).collect(),
        };
        let differing: Vec<FishId> = fish
            .iter()
            .copied()
            .filter(|id| self.divergences.iter().any(|d| d.fish == *id))
            .collect();
        a_history.path_lines(fish, from, now, GHOST_COLOR, &mut self.overlay);
        self.timeline
            .path_lines(differing, from, now, NEW_PATH_COLOR, &mut self.overlay);
    }
}

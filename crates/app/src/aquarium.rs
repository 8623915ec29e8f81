//! [`Aquarium`]: the window's state and per-frame logic without the window — the simulation
//! being shown, the selection and camera, time controls, console, and the views the panel
//! draws — so UI tests can drive exactly what `shoal run` does.

use glam::Vec2;
use winit::event::MouseButton;

use super::scene::{DynScene, OverlayToggles, WorldScene};
use super::showable::Showable;
use super::split::{Split, SplitError, SplitVersions};
use super::timeline::{Divergence, Timeline};
use super::ui_state::{UiState, advance, drop_food_at, refresh_views, seek, select_at};
use shoal_core::world::FishId;
use shoal_render::{Camera, OverlayLine};

/// Options of the window.
#[derive(Debug, Clone, Copy, Default)]
pub struct AppOptions {
    /// Draw this many frames, then close (for tests and scripted runs).
    pub frames: Option<u64>,
    /// Fish selected (and followed) at start.
    pub select: Option<FishId>,
    /// Overlays shown at start.
    pub overlays: OverlayToggles,
    /// MSAA samples a pixel (4 or 1); `None`: 4 on a GPU, 1 on a software renderer
    /// (`default_msaa` in the window).
    pub msaa: Option<u32>,
}

/// The aquarium's panel and view logic without a window: the same panel, pointer routing, fish
/// picking and simulation advance that `shoal run` uses every frame, driven by UI tests
/// (`egui_kittest`) or any other host.
pub struct Aquarium {
    /// The simulation being shown.
    pub scene: DynScene,
    pub(super) ui: UiState,
}

impl Aquarium {
    /// Shows `sim`, with `options.select` selected (and followed) and `options.overlays` on.
    pub fn new(sim: Box<dyn Showable>, options: AppOptions) -> Self {
        let mut scene = WorldScene::new(sim);
        let mut ui = UiState::new(scene.default_camera());
        if let Some(line) = ui.timeline.record(scene.sim()) {
            ui.log(line);
        }
        ui.toggles = options.overlays;
        if let Some(id) = options.select.filter(|&id| scene.world().is_alive(id)) {
            ui.selected = Some(id);
            ui.follow = true;
            ui.species = scene.species_of(id).unwrap_or(0);
            scene.set_selected(Some(id));
        }
        Self { scene, ui }
    }

    /// Opens a recording at the moment the simulation stands at: pauses, and makes the
    /// recording's positions from here on (`ghost`, as [`Timeline::set_ghost`] takes them) the
    /// ghost that playing on is compared with; `note` goes to the console.
    pub fn open_recording(
        &mut self,
        ghost: Vec<(u64, Vec<FishId>, Vec<glam::Vec3>)>,
        note: impl Into<String>,
    ) {
        self.ui.timeline.set_ghost(ghost);
        self.ui.paused = true;
        self.ui.log(note);
    }

    /// A split tank: `a` and `b` (two versions of the scripts, the same scene and seed) side
    /// by side, time-locked. Fails when they do not start at the same
    /// tick or have different species.
    pub fn new_split(
        a: Box<dyn Showable>,
        b: Box<dyn Showable>,
        versions: SplitVersions,
        options: AppOptions,
    ) -> Result<Self, SplitError> {
        let mut aq = Self::new(a, options);
        let (mut split, note) = Split::new(&aq.scene, b, versions)?;
        split.scene.set_selected(aq.ui.selected);
        aq.ui.split = Some(split);
        if let Some(line) = note {
            aq.ui.log(format!("B: {line}"));
        }
        refresh_views(&mut aq.scene, &mut aq.ui);
        Ok(aq)
    }

    /// Draws the tuning panel into `ui` (inspector and plot as of the last [`Aquarium::advance`]).
    pub fn panel(&mut self, ui: &mut egui::Ui) {
        super::panel::panel(ui, &mut self.scene, &mut self.ui);
    }

    /// The window's side panel: [`Aquarium::panel`] in a resizable panel on the right,
    /// scrolling vertically. Returns the panel's rectangle (points) and remembers it in
    /// physical pixels, where the window decides which clicks are the panel's.
    pub fn side_panel(&mut self, ui: &mut egui::Ui) -> egui::Rect {
        // Wide enough for the scripts profile table, or under half a small window; the user
        // can drag it narrower (the table then scrolls sideways) or wider.
        let default = (0.45 * ui.max_rect().width()).min(450.0);
        let shown = egui::Panel::right("tuning")
            .resizable(true)
            .default_size(default)
            .show(ui, |ui| {
                egui::ScrollArea::vertical().show(ui, |ui| self.panel(ui));
            });
        let rect = shown.response.rect;
        self.ui.panel_rect_px = Some(rect * ui.ctx().pixels_per_point());
        rect
    }

    /// One frame's simulation: `frame_dt_s` of real time at the panel's speed (or one tick
    /// after "step", or nothing while paused), then the console, inspector, plot and overlays.
    pub fn advance(&mut self, frame_dt_s: f32) {
        advance(&mut self.scene, &mut self.ui, frame_dt_s);
        refresh_views(&mut self.scene, &mut self.ui);
    }

    /// A left click at `at` (physical pixels in a `size` view); `over_ui` when the panel is
    /// under the pointer, as the window decides it. Picks a fish only in the view.
    pub fn click(&mut self, at: Vec2, size: Vec2, over_ui: bool) {
        self.ui.pointer.moved(at);
        self.ui.pointer.pressed(MouseButton::Left, over_ui);
        if !over_ui {
            self.press_in_view(at, size);
        }
        if let Some(at) = self.ui.pointer.released(MouseButton::Left) {
            self.view_click(at, size);
        }
        self.release_in_view();
    }

    /// A left press in the view at `at` (physical pixels of a `size` view) with "edit scene"
    /// on: picks the rock, current zone or start region there and starts dragging it. True
    /// when it picked one (the press then neither turns the camera nor selects a fish).
    pub fn press_in_view(&mut self, at: Vec2, size: Vec2) -> bool {
        let ui = &mut self.ui;
        ui.press_picked = false;
        if ui.edit_scene
            && ui.split.is_none()
            && !ui.shift
            && let Some(desc) = ui.scene_edits.live()
        {
            match super::scene_view::press(&ui.camera, desc, at, size) {
                Some((item, grab)) => {
                    ui.picked = Some(item);
                    ui.grab = grab;
                    ui.press_picked = true;
                }
                None => ui.picked = None,
            }
        }
        ui.press_picked
    }

    /// The pointer moved to `at` while a press in the view holds an item: it moves there over
    /// its plane, live (the whole drag is one undo step). False when nothing is dragged.
    pub fn drag_in_view(&mut self, at: Vec2, size: Vec2) -> bool {
        let Some(grab) = self.ui.grab else {
            return false;
        };
        let tank = self.scene.world().tank();
        let bounds = (tank.min, tank.max);
        if let Some(desc) = self.ui.scene_edits.live().and_then(|live| {
            super::scene_view::dragged(&self.ui.camera, grab, live, at, size, bounds)
        }) && let Err(e) = self.ui.scene_edits.edit(self.scene.sim_mut(), desc, true)
        {
            self.ui.log(e.to_string());
        }
        refresh_views(&mut self.scene, &mut self.ui);
        true
    }

    /// The button came up: a drag of a scene item ends (its next edit is a new undo step).
    pub fn release_in_view(&mut self) {
        if self.ui.grab.take().is_some() {
            self.ui.scene_edits.end_drag();
        }
    }

    /// With `SHOAL_UI_TRACE` and "edit scene" on, prints where each rock's centre is in a
    /// `size` view (`ui: rock 1 at X,Y`) whenever it moves, so an end-to-end test can drag it.
    pub(super) fn trace_rocks(&mut self, size: Vec2) {
        if !self.ui.trace || !self.ui.edit_scene {
            return;
        }
        let rocks: Vec<glam::Vec3> = self
            .scene
            .world()
            .obstacles()
            .iter()
            .map(|o| o.pos)
            .collect();
        let view_proj = self.ui.camera.view_proj(size.x / size.y.max(1.0));
        for (i, p) in rocks.into_iter().enumerate() {
            let ndc = view_proj.project_point3(p);
            let px = Vec2::new((ndc.x + 1.0) * 0.5 * size.x, (1.0 - ndc.y) * 0.5 * size.y);
            self.ui.trace_line(&format!("rock {}", i + 1), || {
                format!("ui: rock {} at {:.0},{:.0}", i + 1, px.x, px.y)
            });
        }
    }

    /// Turns "edit scene" on or off (the panel's checkbox).
    pub fn set_edit_scene(&mut self, on: bool) {
        self.ui.edit_scene = on;
        if !on {
            self.ui.picked = None;
            self.ui.grab = None;
        }
    }

    /// The scene as the window's edits left it, and the files' scene (what undo and save work
    /// on).
    pub fn edited_scene(&self) -> Option<&shoal_script::scene::SceneDesc> {
        self.ui.scene_edits.live()
    }

    /// A click that ended in the view at `at` (a `size` view): selects the fish there, or,
    /// with shift held, drops food where the click shows (see [`food_drop_point`]). A click
    /// that picked a scene item selects no fish.
    pub(super) fn view_click(&mut self, at: Vec2, size: Vec2) {
        if self.ui.press_picked {
            return;
        }
        if self.ui.shift {
            drop_food_at(&mut self.scene, &mut self.ui, at, size);
        } else {
            select_at(&mut self.scene, &mut self.ui, at, size);
        }
    }

    /// Whether shift is held (the window follows the keyboard's modifiers).
    pub fn set_shift(&mut self, held: bool) {
        self.ui.shift = held;
    }

    /// The split tank's version B (its scene), when this is a split tank.
    pub fn split_scene(&self) -> Option<&DynScene> {
        self.ui.split.as_ref().map(|s| &s.scene)
    }
    /// The split tank's version B, mutably (tests apply edits through it).
    pub fn split_scene_mut(&mut self) -> Option<&mut DynScene> {
        self.ui.split.as_mut().map(|s| &mut s.scene)
    }
    /// The fish whose positions differ between the split tank's A and B, by the time they
    /// first did (empty without a split).
    pub fn split_divergences(&self) -> &[Divergence] {
        self.ui.split.as_ref().map_or(&[], |s| &s.divergences)
    }
    /// Script files (relative paths) that differ between the split tank's A and B.
    pub fn split_changed_files(&self) -> &[String] {
        self.ui.split.as_ref().map_or(&[], |s| &s.changed)
    }
    /// B's overlay segments of the last [`Aquarium::advance`] (empty without a split).
    pub fn split_overlay_lines(&self) -> &[OverlayLine] {
        self.ui.split.as_ref().map_or(&[], |s| &s.overlay)
    }
    /// B's inspector lines for the selected fish (empty without a split).
    pub fn split_inspect(&self) -> &[(String, String)] {
        self.ui.split.as_ref().map_or(&[], |s| &s.inspect)
    }

    /// The selected fish.
    pub fn selected(&self) -> Option<FishId> {
        self.ui.selected
    }
    /// Whether the camera follows the selected fish.
    pub fn following(&self) -> bool {
        self.ui.follow
    }
    /// Whether time is paused.
    pub fn paused(&self) -> bool {
        self.ui.paused
    }
    /// The overlays shown.
    pub fn overlays(&self) -> OverlayToggles {
        self.ui.toggles
    }
    /// The overlay segments of the last [`Aquarium::advance`].
    pub fn overlay_lines(&self) -> &[OverlayLine] {
        &self.ui.overlay
    }
    /// The camera.
    pub fn camera(&self) -> Camera {
        self.ui.camera
    }
    /// The console's lines, oldest first.
    pub fn console(&self) -> impl Iterator<Item = &str> {
        self.ui.log.iter().map(String::as_str)
    }
    /// The Scripts section's state (profile, watches).
    pub fn scripts(&self) -> &super::scripts_panel::ScriptsPanel {
        &self.ui.scripts
    }
    /// The history ring (kept states, per-tick positions, ghost).
    pub fn timeline(&self) -> &Timeline {
        &self.ui.timeline
    }
    /// The fish that left their ghost since the last rewind, by the time they did.
    pub fn divergences(&self) -> &[Divergence] {
        self.ui.timeline.divergences()
    }
    /// Goes to simulated time `time_s` of the history (clamped to it) and pauses, as the
    /// timeline's slider does.
    pub fn seek(&mut self, time_s: f64) {
        seek(&mut self.scene, &mut self.ui, time_s);
        refresh_views(&mut self.scene, &mut self.ui);
    }
}

//! What the window and the panel remember between frames ([`UiState`]), and the per-frame steps
//! on it and the scene: advancing the simulation, seeking, picking a fish, dropping food.

use std::collections::VecDeque;
use std::time::Instant;

use glam::{Vec2, Vec3};

use super::pointer::Pointer;
use super::scene::{DynScene, OverlayToggles, WorldScene};
use super::showable::Showable;
use super::split::Split;
use super::timeline::Timeline;
use shoal_core::world::{FishId, Tank};
use shoal_render::shaders::ShaderWatcher;
use shoal_render::{Camera, OverlayLine, RenderTimings};

/// One frame's times, milliseconds, for the panel's timing table.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct FrameTimes {
    pub sim_ms: f32,
    pub upload_ms: f32,
    pub draw_ms: f32,
    pub frame_ms: f32,
}

/// What the window and the panel remember between frames.
pub(super) struct UiState {
    pub camera: Camera,
    pub follow: bool,
    pub selected: Option<FishId>,
    /// Species shown in the panel's motion parameters (index in species order).
    pub species: usize,
    /// The sliders' unsaved values and the question a save raised.
    pub tuned: super::tuned::Tuned,
    /// The window's edits of the running scene (params, rocks, currents, regions), undo/redo.
    pub scene_edits: super::scene_edit::SceneEdits,
    /// "edit scene" is on: presses in the view pick rocks, current zones and start regions.
    pub edit_scene: bool,
    /// The rock, zone or region picked for editing.
    pub picked: Option<super::scene_edit::Item>,
    /// The drag of the picked item in progress.
    pub grab: Option<super::scene_view::Grab>,
    /// The last press in the view picked a scene item (its click selects no fish).
    pub press_picked: bool,
    pub paused: bool,
    pub step_once: bool,
    pub speed: f32,
    pub toggles: OverlayToggles,
    pub overlay: Vec<OverlayLine>,
    pub log: VecDeque<String>,
    pub wave: Vec<[f64; 2]>,
    pub inspect: Vec<(String, String)>,
    pub times: VecDeque<FrameTimes>,
    /// The renderer's counts of the frame being drawn (fish drawn, culled, triangles …).
    pub render_counts: RenderTimings,
    pub pointer: Pointer,
    pub last_frame: Instant,
    /// Simulated and real seconds of the last frames, for the "behind real time" warning.
    pub pace: VecDeque<(f32, f32)>,
    pub watcher: Option<ShaderWatcher>,
    pub shader_error: Option<String>,
    scratch_log: Vec<super::showable::LogLine>,
    /// History messages of this frame's ticks, for the console.
    scratch_notes: Vec<String>,
    /// Set by the panel's "restart scene" button; handled at the start of the next frame.
    pub restart_requested: bool,
    /// The history ring, ghost and divergences.
    pub timeline: Timeline,
    /// The timeline slider's value, simulated seconds (follows the clock unless dragged).
    pub scrub_s: f64,
    /// Set by the timeline's slider and buttons: go to this time at the start of the next
    /// frame's simulation.
    pub seek_to: Option<f64>,
    /// Draw the ghosts of the run before the last rewind.
    pub show_ghosts: bool,
    /// The timeline slider was being dragged last frame (its value is the designer's, not
    /// the clock's).
    pub scrub_dragging: bool,
    /// `SHOAL_UI_TRACE` is set: console lines, selection changes, the panel's button
    /// rectangles and each presented frame (`ui: frame N`) are also printed on stdout, so an
    /// end-to-end test can click by label and wait in frames.
    pub trace: bool,
    /// The split tank's version B, when `shoal run --split` shows two versions.
    pub split: Option<Split>,
    /// The last line printed for each traced button.
    traced: Vec<(String, String)>,
    /// The panel's rectangle in the last frame, physical pixels.
    pub panel_rect_px: Option<egui::Rect>,
    /// The Scripts section: module profile, console, watches.
    pub scripts: super::scripts_panel::ScriptsPanel,
    /// Shift is held: a click in the view drops food instead of selecting.
    pub shift: bool,
    /// Most ticks the next frame may simulate (the window's frame pacing, see `pacing.rs`;
    /// unbounded elsewhere).
    pub max_ticks: u64,
    /// The window's note on a view drawn a slice at a time (see `pacing.rs`), for the panel.
    pub view_status: Option<String>,
}

impl UiState {
    pub(super) fn new(camera: Camera) -> Self {
        Self {
            camera,
            follow: false,
            selected: None,
            species: 0,
            tuned: Default::default(),
            scene_edits: Default::default(),
            edit_scene: false,
            picked: None,
            grab: None,
            press_picked: false,
            paused: false,
            step_once: false,
            restart_requested: false,
            timeline: Timeline::default(),
            scrub_s: 0.0,
            seek_to: None,
            show_ghosts: true,
            scrub_dragging: false,
            speed: 1.0,
            toggles: OverlayToggles::default(),
            overlay: Vec::new(),
            log: VecDeque::new(),
            wave: Vec::new(),
            inspect: Vec::new(),
            times: VecDeque::new(),
            render_counts: RenderTimings::default(),
            pointer: Pointer::default(),
            last_frame: Instant::now(),
            pace: VecDeque::new(),
            watcher: None,
            shader_error: None,
            scripts: Default::default(),
            shift: false,
            max_ticks: u64::MAX,
            view_status: None,
            scratch_log: Vec::new(),
            scratch_notes: Vec::new(),
            trace: std::env::var_os("SHOAL_UI_TRACE").is_some_and(|v| !v.is_empty()),
            traced: Vec::new(),
            split: None,
            panel_rect_px: None,
        }
    }

    /// With [`UiState::trace`], prints a widget's centre and size in physical pixels whenever it
    /// is drawn somewhere new: `ui: button "quick turn left" at X,Y size WxH`; and
    /// `ui: clicked "quick turn left"` on the frame egui takes a click on it.
    pub fn trace_widget(&mut self, ui: &egui::Ui, label: &str, response: &egui::Response) {
        if self.trace && response.clicked() {
            println!("ui: clicked {label:?}");
        }
        self.trace_line(label, || {
            let r = response.rect * ui.ctx().pixels_per_point();
            format!(
                "ui: button {label:?} at {:.0},{:.0} size {:.0}x{:.0}",
                r.center().x,
                r.center().y,
                r.width(),
                r.height()
            )
        });
    }

    /// With [`UiState::trace`], prints the line `line` makes unless the last line traced under
    /// `key` was the same (without tracing, `line` is not called).
    pub fn trace_line(&mut self, key: &str, line: impl FnOnce() -> String) {
        if !self.trace {
            return;
        }
        let line = line();
        match self.traced.iter_mut().find(|(l, _)| l == key) {
            Some((_, last)) if *last == line => return,
            Some((_, last)) => *last = line.clone(),
            None => self.traced.push((key.to_owned(), line.clone())),
        }
        println!("{line}");
    }

    /// Adds a console line (and logs it).
    pub fn log(&mut self, line: impl Into<String>) {
        let line = line.into();
        if self.trace {
            println!("console: {line}");
        }
        log::info!("{line}");
        self.log.push_back(line);
        while self.log.len() > 300 {
            self.log.pop_front();
        }
    }

    /// Selects `fish` (or nothing) in the panel and the scene; nothing selected stops following.
    pub fn select(&mut self, scene: &mut DynScene, fish: Option<FishId>) {
        self.selected = fish;
        if self.trace {
            println!("selected: {:?}", fish.map(|id| id.index));
        }
        scene.set_selected(fish);
        if let Some(split) = &mut self.split {
            split.scene.set_selected(fish);
        }
        match fish {
            Some(id) => self.species = scene.species_of(id).unwrap_or(0),
            None => self.follow = false,
        }
    }
}

/// The per-frame views of the simulation: the selection (cleared when its fish is gone, never
/// moved to another fish), camera follow, overlay segments, and the selected fish's body wave
/// and inspector.
pub(super) fn refresh_views(scene: &mut DynScene, ui: &mut UiState) {
    if let Some(id) = ui.selected
        && !scene.world().is_alive(id)
    {
        ui.select(scene, None);
        ui.log(format!("fish #{} is gone; nothing is selected", id.index));
    }
    if ui.follow
        && let Some(info) = ui.selected.and_then(|id| scene.fish_info(id))
    {
        ui.camera.target = ui.camera.target.lerp(info.center, 0.15);
    }
    // The scene edits follow the running scene even while the panel's Scene section is
    // folded (a press in the view picks from them).
    let file = scene.sim().scene_file();
    ui.scene_edits
        .observe(scene.sim().scene_desc(), file.as_deref());
    ui.overlay.clear();
    if ui.toggles.any() {
        scene.overlay_lines(ui.toggles, &mut ui.overlay);
    }
    if ui.edit_scene
        && let Some(desc) = ui.scene_edits.live()
    {
        super::scene_view::overlay(desc, ui.picked, &mut ui.overlay);
    }
    if ui.show_ghosts {
        let now = scene.world().time();
        ui.timeline.ghost_lines(
            now,
            GHOST_BEHIND_S,
            GHOST_AHEAD_S,
            ui.selected,
            &mut ui.overlay,
        );
    }
    ui.scripts.refresh(scene, ui.selected);
    match ui.selected {
        Some(id) => {
            scene.body_wave(id, &mut ui.wave);
            ui.inspect = scene.inspect(id);
        }
        None => {
            ui.wave.clear();
            ui.inspect.clear();
        }
    }
    if let Some(split) = &mut ui.split {
        split.inspect = ui
            .selected
            .map_or_else(Vec::new, |id| split.scene.inspect(id));
        let selected = ui.selected.filter(|_| ui.show_ghosts);
        split.refresh_overlay(&ui.timeline, ui.toggles, selected, GHOST_BEHIND_S);
    }
}

/// The fish under `cursor` (physical pixels from the top-left of a `size` view): the nearest
/// whose bounding sphere (shrunk to 80 %, the body is thinner than its sphere) the ray through
/// the pixel hits. CPU only; linear in the number of fish, run on clicks.
pub fn pick_fish<S: Showable>(
    camera: &Camera,
    cursor: Vec2,
    size: Vec2,
    scene: &WorldScene<S>,
) -> Option<FishId> {
    let ray = camera.ray_through_pixel(cursor, size);
    let mut best: Option<(FishId, f32)> = None;
    for &id in scene.world().fish_id_slice() {
        if let Some(info) = scene.fish_info(id)
            && let Some(t) = ray.hit_sphere(info.center, info.radius * 0.8)
            && best.is_none_or(|(_, bt)| t < bt)
        {
            best = Some((id, t));
        }
    }
    best.map(|(id, _)| id)
}

/// Longest real time one frame may simulate, seconds: after a stall (a window drag, a debugger)
/// the aquarium goes on instead of racing to catch up.
pub(super) const MAX_FRAME_DT_S: f32 = 0.1;

/// Ghost and new paths are drawn from this many seconds before the clock…
const GHOST_BEHIND_S: f64 = 20.0;
/// … to this many after it (where the old run went next).
const GHOST_AHEAD_S: f64 = 10.0;

/// Goes to `time_s` of the history (see [`Timeline::seek`]) and pauses; a failure is a
/// console line.
pub(super) fn seek(scene: &mut DynScene, ui: &mut UiState, time_s: f64) {
    ui.paused = true;
    ui.step_once = false;
    let result = match ui.timeline.seek(time_s) {
        Some((state, ticks)) => scene.rewind_to(state, ticks),
        None => {
            ui.log("history: nothing kept to go back to");
            return;
        }
    };
    if let Err(e) = result {
        ui.log(format!("history: cannot go back: {e}"));
    }
    if let Some(split) = &mut ui.split
        && let Err(e) = split.seek(&ui.timeline, scene.world().tick_count())
    {
        ui.log(format!("history: B: {e}"));
    }
    ui.scrub_s = scene.world().time();
}

/// Moves `scene`'s level-of-detail focus to the camera's target and the selected fish (where it
/// is in that scene), if it moved.
fn focus_lod(scene: &mut DynScene, target: Vec3, selected: Option<FishId>) {
    let mut focus = vec![target];
    if let Some(root) = selected.and_then(|id| scene.world().root(id)) {
        focus.push(root.pos);
    }
    if scene.world().lod().focus != focus {
        scene.sim_mut().world_mut().set_lod_focus(focus);
    }
}

/// The simulation part of a frame: advances the scene by the frame's real time × the speed
/// slider (all of it, up to `ui.max_ticks` ticks: past them the world falls behind real time),
/// by exactly one tick after "step", or not at all while paused; then moves the scene's new log
/// lines into the console.
pub(super) fn advance(scene: &mut DynScene, ui: &mut UiState, frame_dt_s: f32) {
    let frame_dt_s = if frame_dt_s.is_finite() {
        frame_dt_s.max(0.0)
    } else {
        0.0
    };
    // Behaviour level of detail focuses where the designer looks: the camera's target and the
    // selected fish — in the split tank on both sides (one camera; the selected fish where it is
    // in each version), so B schedules as A does.
    focus_lod(scene, ui.camera.target, ui.selected);
    if let Some(split) = &mut ui.split {
        focus_lod(&mut split.scene, ui.camera.target, ui.selected);
    }
    let before = scene.time_s();
    let before_tick = scene.world().tick_count();
    let seeking = ui.seek_to.is_some();
    let (timeline, notes, scripts) = (&mut ui.timeline, &mut ui.scratch_notes, &mut ui.scripts);
    let mut pause = None;
    let (max_ticks, mut ran) = (ui.max_ticks, 0u64);
    // After each tick: the history, then the "pause when" condition (stop at the tick it is met),
    // then the frame's tick budget (past it the world falls behind real time).
    // The scene's simulation is a `Box<dyn Showable>`, and `step_until` hands it as it is.
    #[allow(clippy::borrowed_box)]
    let mut after_tick = |sim: &Box<dyn Showable>| {
        notes.extend(timeline.record(sim.as_ref()));
        pause = scripts.check_pause(sim.as_ref());
        ran += 1;
        pause.is_none() && ran < max_ticks
    };
    if let Some(t) = ui.seek_to.take() {
        seek(scene, ui, t);
    } else if ui.step_once {
        let tick = 1.0 / shoal_core::world::TICK_HZ as f32;
        scene.step_until(tick, &mut after_tick);
        ui.step_once = false;
    } else if !ui.paused {
        let wanted = frame_dt_s.min(MAX_FRAME_DT_S) * ui.speed;
        scene.step_until(wanted, &mut after_tick);
        ui.pace
            .push_back((scene.time_s() - before, frame_dt_s * ui.speed));
        while ui.pace.len() > 120 {
            ui.pace.pop_front();
        }
    } else {
        // Paused: nothing runs, but a save is applied now (see `poll_hot_reload`).
        scene.poll_hot_reload();
        if let Some(split) = &mut ui.split {
            split.scene.poll_hot_reload();
            if split.scene.take_reloaded() {
                split.refresh_changed();
            }
        }
    }
    // The split tank's B runs as many ticks as A just did (none after a seek: `seek` took it
    // to A's moment).
    let ran = scene.world().tick_count().saturating_sub(before_tick);
    if let Some(split) = &mut ui.split
        && ran > 0
        && !seeking
    {
        let notes = split.follow(&ui.timeline, ran);
        ui.scratch_notes
            .extend(notes.into_iter().map(|n| format!("B: {n}")));
    }
    for line in std::mem::take(&mut ui.scratch_notes) {
        ui.log(line);
    }
    match pause {
        Some(Ok((fish, line))) => {
            ui.paused = true;
            ui.log(line);
            ui.select(scene, Some(fish));
        }
        Some(Err(e)) => ui.log(e.to_string()),
        None => {}
    }
    scene.drain_log(&mut ui.scratch_log);
    let a_lines = ui.scratch_log.len();
    if let Some(split) = &mut ui.split {
        split.scene.drain_log(&mut ui.scratch_log);
    }
    for (k, line) in std::mem::take(&mut ui.scratch_log).into_iter().enumerate() {
        if let Some(t) = line.error_at_s {
            ui.timeline.note_error(t);
        }
        if k < a_lines {
            ui.log(line.text);
        } else {
            ui.log(format!("B: {}", line.text));
        }
    }
    if let Some(split) = &mut ui.split
        && scene.take_reloaded()
    {
        split.refresh_changed();
    }
}

/// Simulated seconds per requested simulated second over the last frames (1 when keeping up).
pub(super) fn pace_ratio(pace: &VecDeque<(f32, f32)>) -> f32 {
    let (done, wanted) = pace
        .iter()
        .fold((0.0, 0.0), |(d, w), (a, b)| (d + a, w + b));
    if wanted > 0.0 {
        (done / wanted).min(1.0)
    } else {
        1.0
    }
}

/// Selects the fish under `at` (see [`pick_fish`]), or none on open water, and shows its species'
/// parameters in the panel.
///
/// In a split tank `size` is both views side by side (A left, B right, each half as wide): a
/// click in B's half picks among B's fish, and the fish (by [`FishId`]) is selected in both.
pub(super) fn select_at(scene: &mut DynScene, ui: &mut UiState, at: Vec2, size: Vec2) {
    let (at, size, in_b) = view_under(ui, at, size);
    let picked = match &ui.split {
        Some(split) if in_b => pick_fish(&ui.camera, at, size, &split.scene),
        _ => pick_fish(&ui.camera, at, size, scene),
    };
    ui.select(scene, picked);
}

/// The view a click at `at` (a `size` window area) landed in: the pixel within that view, the
/// view's size, and whether it is the split tank's B (its right half).
fn view_under(ui: &UiState, at: Vec2, size: Vec2) -> (Vec2, Vec2, bool) {
    if ui.split.is_none() {
        return (at, size, false);
    }
    let half = Vec2::new((size.x * 0.5).max(1.0), size.y);
    if at.x < half.x {
        (at, half, false)
    } else {
        (at - Vec2::new(half.x, 0.0), half, true)
    }
}

/// How far under the surface a pellet dropped from the window starts, as a fraction of the
/// tank's height (a scene's default drops start 3–5 % under it).
const DROP_BELOW_SURFACE: f32 = 0.03;

/// Where a pellet dropped at `(x, z)` starts: just under the surface, inside the tank.
pub(super) fn surface_above(tank: &Tank, x: f32, z: f32) -> Vec3 {
    let y = tank.max.y - DROP_BELOW_SURFACE * (tank.max.y - tank.min.y);
    Vec3::new(x, y, z).clamp(tank.min, tank.max)
}

/// Where a pellet dropped by a shift+click at `cursor` (physical pixels of a `size` view)
/// starts: under the surface above the point of the tank the click shows — where the ray
/// through the pixel leaves the tank, on its floor or a wall — so it sinks onto what was
/// clicked. `None` when the ray misses the tank.
pub fn food_drop_point(camera: &Camera, cursor: Vec2, size: Vec2, tank: &Tank) -> Option<Vec3> {
    let ray = camera.ray_through_pixel(cursor, size);
    let t = ray.exit_box(tank.min, tank.max)?;
    let hit = ray.origin + ray.dir * t;
    Some(surface_above(tank, hit.x, hit.z))
}

/// Where the panel's "drop food" puts a pellet: above a point two body lengths ahead of the
/// selected fish, else above the middle of the view (the camera's target).
pub(super) fn food_drop_for_panel(scene: &DynScene, ui: &UiState) -> Vec3 {
    let w = scene.world();
    let ahead = ui.selected.and_then(|id| {
        let root = w.root(id)?;
        let l = w
            .species_of(id)
            .map_or(50.0, |s| w.species(s).body_length());
        let (sin, cos) = root.heading.sin_cos();
        Some(root.pos + Vec3::new(cos, 0.0, -sin) * 2.0 * l)
    });
    let at = ahead.unwrap_or(ui.camera.target);
    surface_above(w.tank(), at.x, at.z)
}

/// Drops a pellet at `pos` into the aquarium (and into the split tank's B, so the two stay
/// comparable) and says so in the console. Like the panel's motion requests it is not kept in
/// the history: a scrub back over it re-runs the ticks without it.
pub(super) fn drop_food(scene: &mut DynScene, ui: &mut UiState, pos: Vec3) {
    let id = scene.drop_food(pos);
    if let Some(split) = &mut ui.split {
        split.scene.drop_food(pos);
    }
    let sink = scene.world().food_physics().sink_speed;
    let how = if sink > 0.0 {
        format!("it sinks at {sink} units/s")
    } else {
        "this scene's food does not sink (food_sink_speed)".to_owned()
    };
    ui.log(format!(
        "food #{} dropped at ({:.0}, {:.0}, {:.0}); {how}",
        id.0, pos.x, pos.y, pos.z
    ));
}

/// A shift+click in the view at `at` (a `size` view; in the split tank, either half) drops a
/// pellet where [`food_drop_point`] says.
pub(super) fn drop_food_at(scene: &mut DynScene, ui: &mut UiState, at: Vec2, size: Vec2) {
    let (at, size, _) = view_under(ui, at, size);
    match food_drop_point(&ui.camera, at, size, scene.world().tank()) {
        Some(pos) => drop_food(scene, ui, pos),
        None => ui.log("no food dropped: the click is outside the tank"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use shoal_core::world::bench::bench_world;
    use shoal_core::world::driver::WanderDriver;
    use shoal_core::world::driver::WanderPipeline;
    use shoal_core::world::{Species, SpeciesDesc};

    fn porgies(fish: usize) -> WorldScene<WanderPipeline> {
        let assets = shoal_core::source_root().join("assets");
        let species = Species::load(SpeciesDesc::black_porgy(), &assets).expect("porgy loads");
        WorldScene::new(WanderPipeline::new(
            bench_world(species, fish, 1).expect("the bench world builds"),
            WanderDriver::default(),
        ))
    }

    #[test]
    fn clicking_a_fish_centre_picks_that_fish_and_empty_water_picks_none() {
        let scene = porgies(6);
        let camera = scene.default_camera();
        let size = Vec2::new(800.0, 600.0);
        let view_proj = camera.view_proj(size.x / size.y);
        let mut picked_any = false;
        for &id in scene.world().fish_id_slice() {
            let c = scene.fish_info(id).unwrap().center;
            let ndc = view_proj.project_point3(c);
            let px = Vec2::new((ndc.x + 1.0) * 0.5 * size.x, (1.0 - ndc.y) * 0.5 * size.y);
            let got = pick_fish(&camera, px, size, &scene);
            // Another fish may sit in front; whatever is picked must be on the ray, and when
            // it is not this fish, that one must be nearer the eye.
            let got = got.expect("a fish centre hits at least that fish");
            if got == id {
                picked_any = true;
            } else {
                let eye = camera.eye();
                let d_got = (scene.fish_info(got).unwrap().center - eye).length();
                assert!(
                    d_got < (c - eye).length() + 60.0,
                    "picked {got:?} behind {id:?}"
                );
            }
        }
        assert!(picked_any);
        // Straight up from the top-left corner: open water.
        assert_eq!(pick_fish(&camera, Vec2::new(1.0, 1.0), size, &scene), None);
    }

    #[test]
    fn pace_is_one_when_keeping_up_and_the_share_done_when_behind() {
        let mut pace = VecDeque::new();
        assert_eq!(pace_ratio(&pace), 1.0);
        pace.push_back((0.1, 0.1));
        assert_eq!(pace_ratio(&pace), 1.0);
        pace.push_back((0.1, 0.3));
        assert!((pace_ratio(&pace) - 0.5).abs() < 1e-6);
    }
}

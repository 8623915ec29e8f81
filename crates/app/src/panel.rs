//! The tuning panel: one function per section (time, selected fish, motion parameters,
//! overlays, timings, console), drawn top to bottom by [`panel`].

use std::collections::VecDeque;

use super::scene::DynScene;
use super::scene_edit::{
    Item, PARAM_DECIMALS, SceneAsk, SceneSaved, UNIT_DECIMALS, round_f32, round_f64,
};
use super::timeline::{Divergence, clock};
use super::tuned::{Ask, DECIMALS, Keep, SaveOutcome};
use super::ui_state::{
    FrameTimes, MAX_FRAME_DT_S, UiState, drop_food, food_drop_for_panel, pace_ratio,
};
use super::widgets::text_width;
use shoal_core::motion::{MotionParams, MotionRequest, Side, TurnKind};
use shoal_core::world::FishId;
use shoal_script::scene::SceneDesc;

const WARNING: egui::Color32 = egui::Color32::from_rgb(255, 210, 90);
const ERROR: egui::Color32 = egui::Color32::from_rgb(255, 110, 90);

/// The tuning panel.
pub(super) fn panel(ui: &mut egui::Ui, scene: &mut DynScene, st: &mut UiState) {
    ui.heading("shoal");
    scene_shortcuts(ui, scene, st);
    notices(ui, scene, st);
    section(ui, "Time", |ui| time_controls(ui, scene, st));
    section(ui, "Timeline", |ui| timeline(ui, scene, st));
    if st.split.is_some() {
        section(ui, "Split tank", |ui| split_tank(ui, scene, st));
    }
    section(ui, "Selected fish", |ui| selected_fish(ui, scene, st));
    section(ui, "Scripts", |ui| {
        let mut lines = Vec::new();
        super::scripts_panel::show(ui, scene, &mut st.scripts, st.selected, &mut lines);
        for line in lines {
            st.log(line);
        }
    });
    section(ui, "Motion parameters", |ui| {
        motion_parameters(ui, scene, st)
    });
    section(ui, "Scene", |ui| scene_section(ui, scene, st));
    section(ui, "Overlays", |ui| overlays(ui, st));
    section(ui, "Timings (last 120 frames, ms)", |ui| {
        timings(ui, scene, st);
    });
    section(ui, "Console", |ui| console(ui, st));
}

/// Ctrl+Z / Ctrl+Shift+Z: undo and redo the scene edits, wherever the panel is scrolled.
fn scene_shortcuts(ui: &mut egui::Ui, scene: &mut DynScene, st: &mut UiState) {
    let (undo_key, redo_key) = ui.input_mut(|i| {
        let redo = i.consume_shortcut(&egui::KeyboardShortcut::new(
            egui::Modifiers::COMMAND | egui::Modifiers::SHIFT,
            egui::Key::Z,
        ));
        let undo = i.consume_shortcut(&egui::KeyboardShortcut::new(
            egui::Modifiers::COMMAND,
            egui::Key::Z,
        ));
        (undo, redo)
    });
    if undo_key || redo_key {
        scene_undo(scene, st, redo_key);
    }
}

/// A collapsing section, open at start.
fn section(ui: &mut egui::Ui, title: &str, body: impl FnOnce(&mut egui::Ui)) {
    egui::CollapsingHeader::new(title)
        .default_open(true)
        .show(ui, body);
}

/// The scene file changed (offer a restart); a shader failed to compile.
fn notices(ui: &mut egui::Ui, scene: &DynScene, st: &mut UiState) {
    if scene.scene_changed() {
        ui.horizontal_wrapped(|ui| {
            ui.colored_label(WARNING, "the scene file changed");
            if ui.button("restart scene").clicked() {
                st.restart_requested = true;
            }
        });
    }
    if let Some(err) = &st.shader_error {
        ui.colored_label(
            ERROR,
            format!("shader error (previous pipelines still drawing):\n{err}"),
        );
    }
}

/// Pause/play, one step, "drop food", the speed slider and the "behind real time" warning.
fn time_controls(ui: &mut egui::Ui, scene: &mut DynScene, st: &mut UiState) {
    ui.horizontal_wrapped(|ui| {
        let label = if st.paused { "play" } else { "pause" };
        let toggle = ui.button(label);
        st.trace_widget(ui, label, &toggle);
        if toggle.clicked() {
            st.paused = !st.paused;
        }
        let step = ui.button("step");
        st.trace_widget(ui, "step", &step);
        if step.clicked() {
            st.paused = true;
            st.step_once = true;
        }
        let feed = ui
            .button("drop food")
            .on_hover_text("a pellet at the surface, ahead of the selected fish or above the middle of the view; shift+click in the view drops one where you click");
        st.trace_widget(ui, "drop food", &feed);
        if feed.clicked() {
            let pos = food_drop_for_panel(scene, st);
            drop_food(scene, st, pos);
        }
    });
    ui.add(
        egui::Slider::new(&mut st.speed, 0.1..=4.0)
            .logarithmic(true)
            .text("speed ×"),
    );
    let pace = pace_ratio(&st.pace);
    if !st.paused && pace < 0.95 {
        ui.colored_label(
            WARNING,
            format!(
                "behind real time: simulating {:.0} % of the requested speed \
                 (a frame simulates at most {:.0} ms of real time, in at most {:.0} ms of \
                 ticks and at least one)",
                pace * 100.0,
                MAX_FRAME_DT_S * 1e3,
                super::pacing::SIM_BUDGET_MS
            ),
        );
    }
    if let Some(status) = &st.view_status {
        ui.colored_label(WARNING, status);
    }
}

/// The history: its span and size, a slider to scrub to any moment of it, step back one tick,
/// jump to the last script error, the ghosts and the fish that left them.
fn timeline(ui: &mut egui::Ui, scene: &mut DynScene, st: &mut UiState) {
    let tl = &st.timeline;
    let Some((from, to)) = tl.span_s() else {
        ui.label("history: nothing kept yet");
        return;
    };
    let mb = |b: usize| b as f64 / 1e6;
    ui.label(format!(
        "history: {}–{}, {:.1} MB ({} states {:.1} MB, one every {:.0} s; paths {:.1} MB)",
        clock(from),
        clock(to),
        mb(tl.states_bytes() + tl.track_bytes()),
        tl.num_states(),
        mb(tl.states_bytes()),
        tl.keep_every_s(),
        mb(tl.track_bytes()),
    ));
    let now = scene.world().time();
    if !st.scrub_dragging {
        st.scrub_s = now;
    }
    let slider = ui.add_enabled(
        to > from,
        egui::Slider::new(&mut st.scrub_s, from..=to)
            .text("time (s)")
            .fixed_decimals(2),
    );
    st.trace_widget(ui, "time (s)", &slider);
    st.scrub_dragging = slider.dragged();
    // A change of less than half a tick is the slider rounding the clock, not a scrub.
    if slider.changed() && (st.scrub_s - now).abs() > 0.5 / shoal_core::world::TICK_HZ {
        st.seek_to = Some(st.scrub_s);
    }
    let last_error = st.timeline.last_error_s();
    ui.horizontal_wrapped(|ui| {
        let back = ui.add_enabled(now > from, egui::Button::new("step back"));
        st.trace_widget(ui, "step back", &back);
        if back.clicked() {
            st.seek_to = Some(now - 1.0 / shoal_core::world::TICK_HZ);
        }
        let jump = ui.add_enabled(
            last_error.is_some(),
            egui::Button::new("jump to last error"),
        );
        st.trace_widget(ui, "jump to last error", &jump);
        if jump.clicked() {
            st.seek_to = last_error;
        }
        let ghosts = ui.checkbox(&mut st.show_ghosts, "ghosts");
        st.trace_widget(ui, "ghosts", &ghosts);
    });
    if now < to - 1e-9 {
        ui.colored_label(
            WARNING,
            format!(
                "rewound {:.2} s: play or step to run on from here with the scripts loaded now",
                to - now
            ),
        );
    }
    let Some((g0, g1)) = st.timeline.ghost_span_s() else {
        return;
    };
    let divergences = st.timeline.divergences().to_vec();
    ui.label(format!(
        "ghost: {}, {g0:.2}–{g1:.2} s; {} fish left it",
        st.timeline.ghost_source(),
        divergences.len()
    ));
    divergence_list(ui, scene, st, "divergences", &divergences);
}

/// Fish that parted from another run (the ghost, or the split tank's other version), by when
/// they first differed and how far apart they got; a click selects the fish.
fn divergence_list(
    ui: &mut egui::Ui,
    scene: &mut DynScene,
    st: &mut UiState,
    id_salt: &str,
    divergences: &[Divergence],
) {
    egui::ScrollArea::vertical()
        .id_salt(id_salt)
        .max_height(140.0)
        .show(ui, |ui| {
            for d in divergences {
                let label = format!(
                    "fish #{} at {:.2} s, up to {:.1} apart",
                    d.fish.index, d.first_s, d.max_distance
                );
                let row = ui.selectable_label(st.selected == Some(d.fish), &label);
                st.trace_widget(ui, &label, &row);
                if row.clicked() && scene.world().is_alive(d.fish) {
                    st.select(scene, Some(d.fish));
                }
            }
        });
}

/// The split tank: which version is where, the script files that differ, and the fish whose
/// positions differ between A and B.
fn split_tank(ui: &mut egui::Ui, scene: &mut DynScene, st: &mut UiState) {
    let Some(split) = &st.split else { return };
    ui.label(format!("A (left): {}", split.versions.a));
    ui.label(format!("B (right): {}", split.versions.b));
    if split.versions.dirs.is_some() {
        if split.changed.is_empty() {
            ui.label("no script file differs");
        } else {
            ui.label(format!("files that differ: {}", split.changed.join(", ")));
        }
    }
    let divergences = split.divergences.clone();
    ui.label(format!(
        "{} fish differ between A and B (first tick they differed, largest distance)",
        divergences.len()
    ));
    divergence_list(ui, scene, st, "split divergences", &divergences);
}

/// The selected fish: follow/deselect, motion buttons, body wave plot and inspector.
fn selected_fish(ui: &mut egui::Ui, scene: &mut DynScene, st: &mut UiState) {
    let Some(fish) = st.selected else {
        ui.label("click a fish to select it");
        return;
    };
    ui.horizontal_wrapped(|ui| {
        ui.label(format!("fish #{}", fish.index));
        let follow = ui.checkbox(&mut st.follow, "follow");
        st.trace_widget(ui, "follow", &follow);
        let deselect = ui.button("deselect");
        st.trace_widget(ui, "deselect", &deselect);
        if deselect.clicked() {
            st.select(scene, None);
        }
    });
    if st.selected.is_none() {
        return;
    }
    motion_buttons(ui, scene, st, fish);
    body_wave_plot(ui, st);
    let Some(split) = &st.split else {
        // Values wrap at the panel's edge: a long one (a script error's message) would
        // otherwise widen the panel the moment it appears.
        egui::Grid::new("inspector")
            .striped(true)
            .num_columns(2)
            .show(ui, |ui| {
                for (k, v) in &st.inspect {
                    ui.label(k);
                    ui.add(egui::Label::new(v).wrap());
                    ui.end_row();
                }
            });
        return;
    };
    // Split tank: A's and B's lines side by side, by key (A's order, then B's own keys). Each
    // of the three columns gets at most a third of the panel and its values wrap there: a long
    // value (a script error's message) would otherwise widen the panel by its whole length.
    let column = ((ui.available_width() - 2.0 * ui.spacing().item_spacing.x) / 3.0).max(40.0);
    egui::Grid::new("inspector")
        .striped(true)
        .num_columns(3)
        .max_col_width(column)
        .show(ui, |ui| {
            ui.label("");
            ui.strong("A");
            ui.strong("B");
            ui.end_row();
            let b_only = split
                .inspect
                .iter()
                .filter(|(k, _)| st.inspect.iter().all(|(ka, _)| ka != k));
            for (k, _) in st.inspect.iter().chain(b_only) {
                let find = |lines: &[(String, String)]| {
                    lines
                        .iter()
                        .find(|(kk, _)| kk == k)
                        .map_or("—".to_owned(), |(_, v)| v.clone())
                };
                let (a, b) = (find(&st.inspect), find(&split.inspect));
                ui.add(egui::Label::new(k).wrap());
                ui.add(egui::Label::new(&a).wrap());
                if a == b {
                    ui.add(egui::Label::new(b).wrap());
                } else {
                    ui.add(egui::Label::new(egui::RichText::new(b).color(WARNING)).wrap());
                }
                ui.end_row();
            }
        });
}

/// The motion layer's requests, sized from the fish's species (speed, turn angle, length).
fn motion_requests(params: Option<MotionParams>) -> [(&'static str, MotionRequest); 11] {
    let (s, angle, l) = params.map_or((40.0, std::f32::consts::FRAC_PI_2, 50.0), |p| {
        (p.s, p.turn_angle, p.l)
    });
    let turn = |kind, side| MotionRequest::Turn { kind, angle, side };
    [
        ("swim", MotionRequest::Swim { speed: s }),
        (
            "accelerate",
            MotionRequest::Accelerate {
                speed: 2.0 * s,
                duration: 1.0,
            },
        ),
        ("stop", MotionRequest::Stop { duration: 1.0 }),
        ("normal turn left", turn(TurnKind::Normal, Side::Left)),
        ("normal turn right", turn(TurnKind::Normal, Side::Right)),
        ("quick turn left", turn(TurnKind::Quick, Side::Left)),
        ("quick turn right", turn(TurnKind::Quick, Side::Right)),
        ("serial turn left", turn(TurnKind::Serial, Side::Left)),
        ("serial turn right", turn(TurnKind::Serial, Side::Right)),
        ("ascend", MotionRequest::Ascend { height: l }),
        ("descend", MotionRequest::Descend { depth: l }),
    ]
}

/// One button per motion request; a click starts it on `fish` now and says so in the console.
fn motion_buttons(ui: &mut egui::Ui, scene: &mut DynScene, st: &mut UiState, fish: FishId) {
    let params = scene.species_of(fish).and_then(|s| scene.motion_params(s));
    ui.horizontal_wrapped(|ui| {
        for (label, request) in motion_requests(params) {
            let button = ui.button(label);
            st.trace_widget(ui, label, &button);
            if button.clicked() {
                let n = fish.index;
                match scene.request_motion(fish, request) {
                    Ok(()) => st.log(format!("fish #{n}: {label} requested")),
                    Err(e) => st.log(format!("fish #{n}: {label}: {e}")),
                }
                // The split tank's B gets the same request, so the two stay comparable.
                if let Some(split) = &mut st.split
                    && let Err(e) = split.scene.request_motion(fish, request)
                {
                    st.log(format!("B: fish #{n}: {label}: {e}"));
                }
            }
        }
    });
}

/// The selected fish's lateral displacement along its body.
fn body_wave_plot(ui: &mut egui::Ui, st: &UiState) {
    ui.label("body wave (lateral displacement vs position along body)");
    egui_plot::Plot::new("body wave")
        .height(140.0)
        .include_x(0.0)
        .include_x(1.0)
        .include_y(-10.0)
        .include_y(10.0)
        .allow_drag(false)
        .allow_zoom(false)
        .allow_scroll(false)
        .show(ui, |plot| {
            plot.line(egui_plot::Line::new(
                "lateral",
                egui_plot::PlotPoints::from(st.wave.clone()),
            ));
        });
}

/// The species picker and one slider per motion parameter (eq. 2–7, Table 1); an edit applies
/// to the live species at once.
fn motion_parameters(ui: &mut egui::Ui, scene: &mut DynScene, st: &mut UiState) {
    let species = scene.species_names();
    if !species.is_empty() {
        egui::ComboBox::from_label("species")
            .selected_text(species.get(st.species).cloned().unwrap_or_default())
            .show_ui(ui, |ui| {
                for (i, name) in species.iter().enumerate() {
                    ui.selectable_value(&mut st.species, i, name);
                }
            });
    }
    let Some(mut p) = scene.motion_params(st.species) else {
        ui.label("(this scene has no tunable motion)");
        return;
    };
    let file = scene.sim().species_file(st.species);
    if let Keep::Restore(tuned) = st.tuned.observe(st.species, p, file.as_ref()) {
        // The file was reloaded under unsaved tuning: keep the tuning live until the designer
        // answers the question below.
        if let Err(e) = scene.set_motion_params(st.species, tuned) {
            st.log(e.to_string());
        }
        p = tuned;
    }
    let before = p;
    let mut deg = p.turn_angle.to_degrees();
    let sliders: [(&mut f32, std::ops::RangeInclusive<f32>, &str); 10] = [
        (&mut p.p, 0.0..=0.9, "p (pivot, body fraction)"),
        (&mut p.s, 0.0..=200.0, "s (speed, units/s)"),
        (&mut p.l, 5.0..=200.0, "l (body length)"),
        (&mut p.max_amp, 0.0..=30.0, "maxAmp"),
        (&mut p.lambda, 5.0..=200.0, "λ (wavelength)"),
        (&mut p.omega, 0.0..=40.0, "ω (frequency)"),
        (
            &mut p.front_amp,
            0.0..=0.1,
            "snout amplitude (body fraction)",
        ),
        (&mut p.tt, 0.05..=5.0, "Tt (turn time, s)"),
        (&mut p.f, 1.0..=2.0, "f (turn weight)"),
        (&mut deg, 0.0..=180.0, "turn angle (°)"),
    ];
    // The sliders shorten (to 40 points) before their labels would hold the panel wide.
    let widest = sliders
        .iter()
        .map(|(_, _, label)| text_width(ui, label, egui::TextStyle::Body))
        .fold(0.0, f32::max);
    let beside = widest + ui.spacing().interact_size.x + 3.0 * ui.spacing().item_spacing.x;
    ui.spacing_mut().slider_width = (ui.available_width() - beside).clamp(40.0, 100.0);
    // Each slider steps by what it shows, so the value saved is the one on screen. Only edits
    // are clamped and stepped: a file's value off the grid (50 * 1.2 is 60.000004 in f32) or
    // out of the range stays as it is until the designer moves that slider.
    for ((value, range, label), decimals) in sliders.into_iter().zip(DECIMALS) {
        let slider = ui.add(
            egui::Slider::new(value, range)
                .text(label)
                .clamping(egui::SliderClamping::Edits)
                .fixed_decimals(decimals)
                .step_by(10f64.powi(-(decimals as i32))),
        );
        st.trace_widget(ui, label, &slider);
    }
    p.turn_angle = deg.to_radians();
    if p != before {
        match scene.set_motion_params(st.species, p) {
            Ok(()) => st.tuned.tune(st.species, p),
            Err(e) => st.log(e.to_string()),
        }
        // The split tank's B gets the same parameters (a live tweak, not a script version).
        if let Some(split) = &mut st.split
            && let Err(e) = split.scene.set_motion_params(st.species, p)
        {
            st.log(format!("B: {e}"));
        }
    }
    save_tuning(ui, scene, st);
}

/// The unsaved slider values of the shown species, "save to species file" and "revert", and the
/// question a save may raise (an expression in the file; the file changed on disk).
fn save_tuning(ui: &mut egui::Ui, scene: &mut DynScene, st: &mut UiState) {
    let sp = st.species;
    let Some(file) = scene.sim().species_file(sp) else {
        ui.label("(a built-in species: no file to save to)");
        return;
    };
    let name = short_path(&file);
    let changes = st.tuned.changes(sp);
    if changes.is_empty() {
        ui.label(format!("no unsaved changes ({name})"));
    } else {
        ui.colored_label(WARNING, format!("unsaved changes ({name}):"));
        for (key, saved, tuned) in &changes {
            ui.monospace(format!("motion.{key}: {saved} → {tuned}"));
        }
        ui.horizontal_wrapped(|ui| {
            let save = ui.button("save to species file");
            st.trace_widget(ui, "save to species file", &save);
            if save.clicked() {
                let outcome = st.tuned.save(sp, &file, false, false);
                report_save(scene, st, sp, &name, outcome);
            }
            if ui.button("revert").clicked()
                && let Some(saved) = st.tuned.saved(sp)
            {
                match scene.set_motion_params(sp, saved) {
                    Ok(()) => st.tuned.discard(sp, Some(&file)),
                    Err(e) => st.log(e.to_string()),
                }
            }
        });
    }
    match st.tuned.ask.clone() {
        Some(Ask::Expression { species, why }) if species == sp => {
            ui.colored_label(WARNING, why);
            ui.horizontal_wrapped(|ui| {
                if ui.button("replace the expression").clicked() {
                    let outcome = st.tuned.save(sp, &file, false, true);
                    report_save(scene, st, sp, &name, outcome);
                }
                if ui.button("cancel").clicked() {
                    st.tuned.ask = None;
                }
            });
        }
        Some(Ask::DiskChanged { species, .. }) if species == sp => {
            ui.colored_label(
                WARNING,
                format!("{name} changed on disk while the panel had unsaved values for it"),
            );
            ui.horizontal_wrapped(|ui| {
                if ui.button("save my values over it").clicked() {
                    let outcome = st.tuned.save(sp, &file, true, false);
                    report_save(scene, st, sp, &name, outcome);
                }
                if ui.button("take the file's values").clicked()
                    && let Some(saved) = st.tuned.saved(sp)
                {
                    match scene.set_motion_params(sp, saved) {
                        Ok(()) => st.tuned.discard(sp, Some(&file)),
                        Err(e) => st.log(e.to_string()),
                    }
                }
            });
        }
        _ => {}
    }
}

/// The console line of a save; the values as written go live (a slider's float noise under the
/// value it showed is dropped), so the reload the save triggers changes nothing.
fn report_save(
    scene: &mut DynScene,
    st: &mut UiState,
    species: usize,
    name: &str,
    outcome: SaveOutcome,
) {
    match outcome {
        SaveOutcome::Saved(n) => {
            if let Some(saved) = st.tuned.saved(species)
                && scene.motion_params(species) != Some(saved)
                && let Err(e) = scene.set_motion_params(species, saved)
            {
                st.log(e.to_string());
            }
            st.log(format!("{name}: saved {n} value(s)"));
        }
        SaveOutcome::Failed(e) => st.log(format!("save refused: {e}")),
        SaveOutcome::Asked | SaveOutcome::Nothing => {}
    }
}

/// `species/black_porgy.lua` for a file under `scripts/species/`.
fn short_path(file: &std::path::Path) -> String {
    let mut parts: Vec<String> = file
        .components()
        .rev()
        .take(2)
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    parts.reverse();
    parts.join("/")
}

/// The scene's live edits: each group's `params` (numbers as drag values, booleans as
/// checkboxes; the scripts read them as `fish.params` at once), the unsaved changes, "save to
/// scene file", "revert", undo and redo.
fn scene_section(ui: &mut egui::Ui, scene: &mut DynScene, st: &mut UiState) {
    let file = scene.sim().scene_file();
    st.scene_edits
        .observe(scene.sim().scene_desc(), file.as_deref());
    let Some(live) = st.scene_edits.live().cloned() else {
        ui.label("(not built from a scene file: nothing to edit)");
        return;
    };
    let mut desc = live.clone();
    let mut drag = Drag::default();
    for (g, group) in desc.fish.iter_mut().enumerate() {
        let Some(params) = &mut group.params else {
            continue;
        };
        let behavior = group
            .behavior
            .as_deref()
            .map_or(String::new(), |b| format!(", {b}"));
        ui.label(format!("fish[{}] ({}{behavior}):", g + 1, group.species));
        ui.indent(("params", g), |ui| {
            params_controls(
                ui,
                st,
                &format!("fish[{}].params", g + 1),
                params,
                &mut drag,
            );
        });
    }
    scene_items(ui, scene, st, &mut desc, &mut drag);
    // A drag of a value is one undo step.
    if desc != live
        && let Err(e) = st.scene_edits.edit(scene.sim_mut(), desc, drag.dragged)
    {
        st.log(e.to_string());
    }
    if drag.stopped {
        st.scene_edits.end_drag();
    }
    scene_save(ui, scene, st, file.as_deref());
}

/// "edit scene" (presses in the view pick and drag rocks, current zones and start regions),
/// "add rock" / "add current zone", and the picked item's position and size as drag values
/// (edited in `desc`) with "delete"; Ctrl+Z / Ctrl+Shift+Z undo and redo.
fn scene_items(
    ui: &mut egui::Ui,
    scene: &mut DynScene,
    st: &mut UiState,
    desc: &mut SceneDesc,
    drag: &mut Drag,
) {
    let mut on = st.edit_scene;
    let r = ui
        .checkbox(&mut on, "edit scene in the view")
        .on_hover_text("press on a rock, a current zone or a start region in the view and drag it over the floor plane; fish positions are the simulation's, not scene data");
    st.trace_widget(ui, "edit scene in the view", &r);
    if on != st.edit_scene {
        st.edit_scene = on;
        st.picked = None;
        st.grab = None;
    }
    ui.horizontal_wrapped(|ui| {
        let target = st.camera.target;
        for (label, item, radius) in [
            ("add rock", Item::Rock(0), 40.0),
            ("add current zone", Item::Zone(0), 100.0),
        ] {
            let b = ui.button(label);
            st.trace_widget(ui, label, &b);
            if b.clicked() {
                let y = if matches!(item, Item::Rock(_)) {
                    radius * 0.5
                } else {
                    target.y
                };
                let pos = [target.x, y, target.z].map(|v| round_f32(v, UNIT_DECIMALS));
                match st.scene_edits.add(scene.sim_mut(), item, pos, radius) {
                    Ok(i) => {
                        // The new item is the scene's now (and `desc` is shown below).
                        if let Some(live) = st.scene_edits.live() {
                            *desc = live.clone();
                        }
                        st.edit_scene = true;
                        st.picked = Some(match item {
                            Item::Rock(_) => Item::Rock(i),
                            _ => Item::Zone(i),
                        });
                    }
                    Err(e) => st.log(e.to_string()),
                }
            }
        }
    });
    let Some(item) = st.picked else {
        if st.edit_scene {
            ui.label("press on a rock, current zone or start region in the view to pick it");
        }
        return;
    };
    let mut delete = false;
    match item {
        Item::Rock(i) => {
            let Some(o) = desc.obstacles.get_mut(i) else {
                st.picked = None;
                return;
            };
            let at = format!("obstacles[{}]", i + 1);
            ui.strong(format!("rock {at}"));
            vec3(ui, st, drag, &format!("{at}.pos"), &mut o.pos);
            ui.horizontal(|ui| value(ui, st, drag, format!("{at}.radius"), &mut o.radius, 0.0));
            delete = true;
        }
        Item::Zone(i) => {
            let Some(c) = desc.currents.get_mut(i) else {
                st.picked = None;
                return;
            };
            let at = format!("currents[{}]", i + 1);
            ui.strong(format!("current zone {at}"));
            vec3(ui, st, drag, &format!("{at}.pos"), &mut c.pos);
            ui.horizontal(|ui| value(ui, st, drag, format!("{at}.radius"), &mut c.radius, 1.0));
            vec3(ui, st, drag, &format!("{at}.velocity"), &mut c.velocity);
            delete = true;
        }
        Item::Region(g) => {
            let Some(r) = desc.fish.get_mut(g).and_then(|f| f.region.as_mut()) else {
                st.picked = None;
                return;
            };
            let at = format!("fish[{}].region", g + 1);
            ui.strong(format!("start region {at}"));
            vec3(ui, st, drag, &format!("{at}.min"), &mut r.min);
            vec3(ui, st, drag, &format!("{at}.max"), &mut r.max);
        }
    }
    if delete {
        let b = ui.button("delete");
        st.trace_widget(ui, "delete", &b);
        if b.clicked() {
            match st.scene_edits.delete(scene.sim_mut(), item) {
                Ok(()) => {
                    st.picked = None;
                    // The deleted item's values in `desc` are no longer the scene's.
                    if let Some(live) = st.scene_edits.live() {
                        *desc = live.clone();
                    }
                }
                Err(e) => st.log(e.to_string()),
            }
        }
    }
}

/// A scene value (world units) as a drag value labelled `label`, stepping by what it shows.
fn value(
    ui: &mut egui::Ui,
    st: &mut UiState,
    drag: &mut Drag,
    label: String,
    v: &mut f32,
    min: f32,
) {
    let l = ui.label(&label);
    let r = ui
        .add(
            egui::DragValue::new(v)
                .range(min..=f32::MAX)
                .fixed_decimals(UNIT_DECIMALS)
                .speed(1.0),
        )
        .labelled_by(l.id);
    st.trace_widget(ui, &label, &r);
    drag.dragged |= r.dragged();
    drag.stopped |= r.drag_stopped();
    if r.changed() {
        *v = round_f32(*v, UNIT_DECIMALS);
    }
}

/// Three [`value`]s, `at.x`, `at.y`, `at.z`, in a row.
fn vec3(ui: &mut egui::Ui, st: &mut UiState, drag: &mut Drag, at: &str, v: &mut [f32; 3]) {
    // Wrapped: three labelled values in a row would hold the panel wide.
    ui.horizontal_wrapped(|ui| {
        for (k, x) in ["x", "y", "z"].iter().zip(v.iter_mut()) {
            value(ui, st, drag, format!("{at}.{k}"), x, f32::MIN);
        }
    });
}

/// Whether a scene control is being dragged this frame, or its drag ended.
#[derive(Debug, Default)]
struct Drag {
    dragged: bool,
    stopped: bool,
}

/// One control per leaf of a `params` table, labelled with its key path: numbers as drag
/// values stepping by what they show (whole numbers stay whole), booleans as checkboxes,
/// strings shown.
fn params_controls(
    ui: &mut egui::Ui,
    st: &mut UiState,
    at: &str,
    v: &mut serde_json::Value,
    drag: &mut Drag,
) {
    use serde_json::Value as J;
    match v {
        J::Object(map) => {
            for (k, item) in map.iter_mut() {
                params_controls(ui, st, &format!("{at}.{k}"), item, drag);
            }
        }
        J::Array(items) => {
            for (i, item) in items.iter_mut().enumerate() {
                params_controls(ui, st, &format!("{at}[{}]", i + 1), item, drag);
            }
        }
        J::Bool(b) => {
            let r = ui.checkbox(b, at);
            st.trace_widget(ui, at, &r);
        }
        J::Number(n) => {
            let whole = !n.is_f64();
            let mut x = n.as_f64().unwrap_or(0.0);
            let decimals = if whole { 0 } else { PARAM_DECIMALS };
            let r = ui
                .horizontal(|ui| {
                    let label = ui.label(at);
                    ui.add(
                        egui::DragValue::new(&mut x)
                            .fixed_decimals(decimals)
                            .speed(10f64.powi(-(decimals as i32)).max(0.01)),
                    )
                    .labelled_by(label.id)
                })
                .inner;
            st.trace_widget(ui, at, &r);
            drag.dragged |= r.dragged();
            drag.stopped |= r.drag_stopped();
            if r.changed() {
                let new = if whole {
                    Some(serde_json::Number::from(x.round() as i64))
                } else {
                    serde_json::Number::from_f64(round_f64(x, decimals))
                };
                if let Some(new) = new {
                    *n = new;
                }
            }
        }
        J::String(s) => {
            ui.label(format!("{at} = \"{s}\""));
        }
        J::Null => {}
    }
}

/// The scene's unsaved changes, "save to scene file", "revert", undo/redo, and the question a
/// save may raise.
fn scene_save(
    ui: &mut egui::Ui,
    scene: &mut DynScene,
    st: &mut UiState,
    file: Option<&std::path::Path>,
) {
    let Some(file) = file.map(std::path::Path::to_path_buf) else {
        return;
    };
    let name = short_path(&file);
    let changes = st.scene_edits.changes();
    if changes.is_empty() {
        ui.label(format!("no unsaved scene changes ({name})"));
    } else {
        ui.colored_label(WARNING, format!("unsaved scene changes ({name}):"));
        for e in &changes {
            ui.monospace(format!("{} = {}", e.path, e.value.text()));
        }
    }
    ui.horizontal_wrapped(|ui| {
        let save = ui.add_enabled(!changes.is_empty(), egui::Button::new("save to scene file"));
        st.trace_widget(ui, "save to scene file", &save);
        if save.clicked() {
            let outcome = st.scene_edits.save(&file, false, false);
            report_scene_save(st, &name, outcome);
        }
        let revert = ui.add_enabled(!changes.is_empty(), egui::Button::new("revert scene"));
        if revert.clicked()
            && let Err(e) = st.scene_edits.revert(scene.sim_mut())
        {
            st.log(e.to_string());
        }
        let undo = ui.add_enabled(st.scene_edits.can_undo(), egui::Button::new("undo"));
        st.trace_widget(ui, "undo", &undo);
        if undo.clicked() {
            scene_undo(scene, st, false);
        }
        let redo = ui.add_enabled(st.scene_edits.can_redo(), egui::Button::new("redo"));
        st.trace_widget(ui, "redo", &redo);
        if redo.clicked() {
            scene_undo(scene, st, true);
        }
    });
    match st.scene_edits.ask.clone() {
        Some(SceneAsk::Expression(why)) => {
            ui.colored_label(WARNING, why);
            ui.horizontal_wrapped(|ui| {
                if ui.button("replace the expression").clicked() {
                    let outcome = st.scene_edits.save(&file, false, true);
                    report_scene_save(st, &name, outcome);
                }
                if ui.button("cancel").clicked() {
                    st.scene_edits.ask = None;
                }
            });
        }
        Some(SceneAsk::DiskChanged) => {
            ui.colored_label(
                WARNING,
                format!("{name} changed on disk while the window had unsaved edits of it"),
            );
            ui.horizontal_wrapped(|ui| {
                if ui.button("save my scene edits over it").clicked() {
                    let outcome = st.scene_edits.save(&file, true, false);
                    report_scene_save(st, &name, outcome);
                }
                if ui.button("keep the file").clicked() {
                    st.scene_edits.ask = None;
                    st.restart_requested = true;
                }
            });
        }
        None => {}
    }
}

/// Undoes (or, with `redo`, redoes) the last scene edit.
pub(super) fn scene_undo(scene: &mut DynScene, st: &mut UiState, redo: bool) {
    let r = if redo {
        st.scene_edits.redo(scene.sim_mut())
    } else {
        st.scene_edits.undo(scene.sim_mut())
    };
    if let Err(e) = r {
        st.log(e.to_string());
    }
}

/// The console line of a scene save.
fn report_scene_save(st: &mut UiState, name: &str, outcome: SceneSaved) {
    match outcome {
        SceneSaved::Saved(n) => st.log(format!("{name}: saved {n} scene value(s)")),
        SceneSaved::Failed(e) => st.log(format!("save refused: {e}")),
        SceneSaved::Asked | SceneSaved::Nothing => {}
    }
}

/// The debug overlay checkboxes.
fn overlays(ui: &mut egui::Ui, st: &mut UiState) {
    ui.checkbox(&mut st.toggles.skeleton, "skeleton and joints");
    ui.checkbox(&mut st.toggles.midline, "body midline");
    ui.checkbox(&mut st.toggles.velocity, "velocity and heading");
    ui.checkbox(&mut st.toggles.sensors, "sensor ranges");
}

/// Picks one stage's time out of a frame's timings.
type StageOf = fn(&FrameTimes) -> f32;

fn mean_max(times: &VecDeque<FrameTimes>, f: impl Fn(&FrameTimes) -> f32) -> (f32, f32) {
    if times.is_empty() {
        return (0.0, 0.0);
    }
    let sum: f32 = times.iter().map(&f).sum();
    let max = times.iter().map(&f).fold(0.0, f32::max);
    (sum / times.len() as f32, max)
}

/// Frame stage times (mean and max), the simulation's own stages, and the renderer's counts.
fn timings(ui: &mut egui::Ui, scene: &DynScene, st: &UiState) {
    egui::Grid::new("timings").striped(true).show(ui, |ui| {
        ui.label("stage");
        ui.label("mean");
        ui.label("max");
        ui.end_row();
        let rows: [(&str, StageOf); 4] = [
            ("simulation", |t| t.sim_ms),
            ("skinning upload", |t| t.upload_ms),
            ("draw (encode+submit)", |t| t.draw_ms),
            ("frame", |t| t.frame_ms),
        ];
        for (name, f) in rows {
            let (mean, max) = mean_max(&st.times, f);
            ui.label(name);
            ui.label(format!("{mean:.2}"));
            ui.label(format!("{max:.2}"));
            ui.end_row();
        }
        for (name, ms) in scene.stage_timings_ms() {
            ui.label(format!("  sim: {name}"));
            ui.label(format!("{ms:.2}"));
            ui.end_row();
        }
    });
    ui.label(behaviour_lod_line(scene.world()));
    let c = &st.render_counts;
    ui.label(format!(
        "fish drawn {} (per level of detail, full first: {:?}), culled {}; shadows {}",
        c.num_fish_drawn, c.num_fish_per_lod, c.num_fish_culled, c.num_shadows_drawn
    ));
    ui.label(draws_line(c));
}

/// The view's triangles and draw calls: those recorded and, of them, those that drew something
/// (the same on the CPU path; on the GPU path every level's draw is recorded and the culling
/// pass leaves some empty, counted on the GPU and read back a frame or two late).
pub(super) fn draws_line(c: &shoal_render::RenderTimings) -> String {
    let mut line = format!(
        "{} triangles, {} draw calls recorded, {} drew something",
        c.num_triangles, c.num_draw_calls, c.num_nonempty_draw_calls
    );
    if c.counts_frame == 0 {
        line.push_str(" (GPU counts not read back yet)");
    }
    line
}

/// The last tick's behaviour decisions and, with level of detail on, how they fell per band:
/// `decisions 412 this tick; behaviour level of detail on: band 1 120/130 fish, band 2 …, 3
/// woken`.
pub(super) fn behaviour_lod_line(world: &shoal_core::world::World) -> String {
    let c = world.lod_counts();
    if !world.lod().on {
        return format!(
            "decisions {} this tick; behaviour level of detail off ({} scripted fish at full rate)",
            c.total(),
            c.fish[0]
        );
    }
    let bands = (0..usize::from(c.bands))
        .map(|k| {
            let every = world.lod().bands.get(k).map_or(1, |b| b.every);
            format!(
                "band {} (1/{every}) {}/{} fish",
                k + 1,
                c.decisions[k],
                c.fish[k]
            )
        })
        .collect::<Vec<_>>()
        .join(", ");
    format!(
        "decisions {} this tick; behaviour level of detail on: {bands}; {} woken",
        c.total(),
        c.woken
    )
}

/// The console: script errors, reloads, requests; newest at the bottom.
fn console(ui: &mut egui::Ui, st: &mut UiState) {
    if ui.button("clear").clicked() {
        st.log.clear();
    }
    egui::ScrollArea::vertical()
        .max_height(180.0)
        .stick_to_bottom(true)
        .show(ui, |ui| {
            for line in &st.log {
                ui.monospace(line);
            }
        });
}

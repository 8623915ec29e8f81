//! The panel's **Scripts** section (issue 17): what each behaviour module costs (sortable, with
//! bars), a Lua console evaluated in the selected fish's context, and watches — expressions over
//! the selected fish (`memory.hunger`, `percepts.food_distance`, `speed`) plotted over
//! simulated time, several at once.
//!
//! Watches and the console run in the fish's own lane with the sandbox and the budget of a
//! decision; a watch is evaluated once per new tick shown, never by the simulation itself, so
//! watching changes nothing about the run.

use std::collections::VecDeque;

use super::scene::DynScene;
use super::showable::{Showable, SimError};
use shoal_core::world::FishId;
use shoal_script::sim::ModuleProfile;

/// Points kept per watch (at one per frame: a couple of minutes at 60 frames a second).
const WATCH_POINTS: usize = 8192;

/// How the module table is sorted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SortBy {
    /// CPU milliseconds per simulated second, most first.
    #[default]
    Cost,
    /// Decisions, most first.
    Calls,
    /// Errors and limit stops, most first.
    Errors,
    /// Bytes allocated per simulated second, most first.
    Memory,
    /// Module name.
    Name,
}

/// How the top-functions table is sorted.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FunctionSort {
    /// Estimated CPU milliseconds per simulated second of the function's own code, most first.
    #[default]
    SelfTime,
    /// Estimated CPU milliseconds per simulated second with what it calls, most first.
    TotalTime,
    /// Share of its module's samples, most first.
    Share,
    /// Function name.
    Name,
}

/// Rows of the top-functions table.
pub const TOP_FUNCTIONS: usize = 12;

/// One row of the top-functions table: a function of a module.
#[derive(Debug, Clone, PartialEq)]
pub struct TopFunction {
    /// The behaviour module whose decisions ran it.
    pub module: String,
    /// The function's figures.
    pub function: shoal_script::profiler::FunctionProfile,
}

/// One watch expression and what it has shown.
#[derive(Debug, Clone)]
pub struct Watch {
    /// The expression, as typed (`memory.hunger`).
    pub expr: String,
    /// (simulated time, value) of its numeric values (booleans as 0 and 1).
    pub points: VecDeque<[f64; 2]>,
    /// Its last value as text, or why it could not be evaluated.
    pub last: Result<String, String>,
}

/// Why the "pause when" condition could not be evaluated; it is cleared.
#[derive(Debug, thiserror::Error)]
#[error("pause when `{condition}`: {source} (condition cleared)")]
pub struct PauseWhenError {
    /// The condition.
    pub condition: String,
    /// Why it could not be evaluated.
    pub source: SimError,
}

/// Why a logpoint line (`file:line message`) could not be read.
#[derive(Debug, thiserror::Error)]
enum ParseLogpointError {
    /// No `file:line` at its start.
    #[error(
        "`{0}`: expected file:line message, such as behaviors/forage.lua:34 hunger \
         {{fish.memory.hunger}}"
    )]
    NoPlace(String),
    /// The part after the last `:` is not a line number.
    #[error("`{0}`: the line must be a number")]
    BadLine(String),
    /// Nothing after `file:line`.
    #[error("`{0}`: a logpoint needs a message after file:line")]
    NoMessage(String),
}

/// The Scripts section's state.
#[derive(Debug, Default)]
pub struct ScriptsPanel {
    /// The module table's order.
    pub sort: SortBy,
    /// The profile as of the last frame.
    pub profile: Vec<ModuleProfile>,
    /// Whether the profile samples the Lua stacks for the top-functions table (off by default:
    /// see docs/performance.md for what it costs).
    pub sample_functions: bool,
    /// The top-functions table's order.
    pub function_sort: FunctionSort,
    /// The top functions of every module, in `function_sort` order (at most [`TOP_FUNCTIONS`]).
    pub top_functions: Vec<TopFunction>,
    /// The module the flame view shows (the most sampled one when unset or gone).
    pub flame_module: Option<String>,
    /// The console's input line.
    pub repl_input: String,
    /// The new watch's input line.
    pub watch_input: String,
    /// The watches.
    pub watches: Vec<Watch>,
    /// The fish and tick the watches were last evaluated for.
    sampled: Option<(FishId, u64)>,
    /// The "pause when" input line.
    pub pause_input: String,
    /// The "pause when" condition set, evaluated for every fish after every tick.
    pub pause_when: Option<String>,
    /// Fish for which the condition held after the last tick (it pauses when it starts to hold).
    holding: std::collections::HashSet<FishId>,
    /// The logpoint input line (`behaviors/forage.lua:34 hunger {fish.memory.hunger}`).
    pub logpoint_input: String,
    /// The logpoints set: file, line, message.
    pub logpoints: Vec<(String, usize, String)>,
}

/// A watch expression as Lua run in the fish's context: the fish's script fields and its body's
/// state under short names.
fn watch_code(expr: &str, sim: &dyn Showable, fish: FishId) -> String {
    let w = sim.world();
    let (speed, heading, pitch, depth, x, y, z) =
        w.root(fish)
            .map_or((0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0), |r| {
                (
                    r.speed,
                    r.heading,
                    r.pitch,
                    w.tank().depth_of(r.pos.y),
                    r.pos.x,
                    r.pos.y,
                    r.pos.z,
                )
            });
    let num = |v: f32| {
        if v.is_finite() {
            format!("{v:?}")
        } else {
            "(0/0)".to_owned()
        }
    };
    format!(
        "local memory, percepts, intention, params = fish.memory, fish.percepts, fish.intention, \
         fish.params\nlocal speed, heading, pitch, depth = {}, {}, {}, {}\nlocal pos = {{ {}, {}, \
         {} }}\nreturn ({expr}\n)",
        num(speed),
        num(heading),
        num(pitch),
        num(depth),
        num(x),
        num(y),
        num(z)
    )
}

/// A watch value as a plot point: numbers as they are, booleans as 0 and 1.
fn as_number(v: &serde_json::Value) -> Option<f64> {
    match v {
        serde_json::Value::Number(n) => n.as_f64(),
        serde_json::Value::Bool(b) => Some(f64::from(u8::from(*b))),
        _ => None,
    }
}

impl ScriptsPanel {
    /// Adds a watch on `expr` (ignored when blank or already watched).
    pub fn add_watch(&mut self, expr: &str) {
        let expr = expr.trim();
        if expr.is_empty() || self.watches.iter().any(|w| w.expr == expr) {
            return;
        }
        self.watches.push(Watch {
            expr: expr.to_owned(),
            points: VecDeque::new(),
            last: Ok(String::new()),
        });
        self.sampled = None;
    }

    /// After a frame: the profile, and each watch's value for the selected fish at the new
    /// tick. A new fish, or a rewind, starts the plots over from there.
    pub fn refresh(&mut self, scene: &DynScene, selected: Option<FishId>) {
        let sim: &dyn Showable = &**scene.sim();
        self.profile = sim.profile();
        self.sort_profile();
        let Some(fish) = selected else {
            self.sampled = None;
            return;
        };
        let tick = sim.world().tick_count();
        let now = sim.world().time();
        if self.sampled == Some((fish, tick)) {
            return;
        }
        let new_fish = self.sampled.is_none_or(|(f, _)| f != fish);
        self.sampled = Some((fish, tick));
        for w in &mut self.watches {
            if new_fish {
                w.points.clear();
            }
            while w.points.back().is_some_and(|p| p[0] >= now) {
                w.points.pop_back();
            }
            let value = sim.eval_fish(fish, &watch_code(&w.expr, sim, fish));
            w.last = match &value {
                Ok(serde_json::Value::Number(n)) => Ok(n
                    .as_f64()
                    .map_or_else(|| n.to_string(), |f| format!("{f:.4}"))),
                Ok(v) => Ok(v.to_string()),
                Err(e) => Err(e.to_string()),
            };
            if let Some(y) = value.ok().as_ref().and_then(as_number) {
                w.points.push_back([now, y]);
                if w.points.len() > WATCH_POINTS {
                    w.points.pop_front();
                }
            }
        }
    }

    /// Sets (or with `None` clears) the "pause when" condition.
    pub fn set_pause_when(&mut self, condition: Option<&str>) {
        self.pause_when = condition
            .map(str::trim)
            .filter(|c| !c.is_empty())
            .map(str::to_owned);
        self.holding.clear();
    }

    /// After a tick: the first fish (in the world's order) for which the "pause when" condition
    /// has just started to hold, with the console line saying so; or an error line (and the
    /// condition is cleared) when it cannot be evaluated.
    pub fn check_pause(
        &mut self,
        sim: &dyn Showable,
    ) -> Option<Result<(FishId, String), PauseWhenError>> {
        let cond = self.pause_when.clone()?;
        let w = sim.world();
        let mut met = None;
        let ids: Vec<FishId> = w.fish_ids().collect();
        for id in ids {
            let holds = match sim.eval_fish(id, &watch_code(&cond, sim, id)) {
                Ok(v) => !matches!(v, serde_json::Value::Null | serde_json::Value::Bool(false)),
                // A fish that has not decided yet has no table: not an error of the condition.
                Err(SimError::Eval(shoal_script::EvalError::NotDecided(_))) => false,
                Err(source) => {
                    self.set_pause_when(None);
                    return Some(Err(PauseWhenError {
                        condition: cond,
                        source,
                    }));
                }
            };
            let was = if holds {
                !self.holding.insert(id)
            } else {
                self.holding.remove(&id);
                true
            };
            if holds && !was && met.is_none() {
                met = Some(id);
            }
        }
        met.map(|id| {
            Ok((
                id,
                format!(
                    "paused at {:.2} s: fish #{} met `{cond}`",
                    w.time(),
                    id.index
                ),
            ))
        })
    }

    fn sort_profile(&mut self) {
        let p = &mut self.profile;
        match self.sort {
            SortBy::Cost => p.sort_by(|a, b| b.ms_per_sim_s.total_cmp(&a.ms_per_sim_s)),
            SortBy::Calls => p.sort_by_key(|m| std::cmp::Reverse(m.calls)),
            SortBy::Errors => p.sort_by_key(|m| std::cmp::Reverse(m.errors + m.limit_stops)),
            SortBy::Memory => {
                p.sort_by(|a, b| b.alloc_kib_per_sim_s.total_cmp(&a.alloc_kib_per_sim_s));
            }
            SortBy::Name => p.sort_by(|a, b| a.module.cmp(&b.module)),
        }
        let mut top: Vec<TopFunction> = self
            .profile
            .iter()
            .flat_map(|m| {
                m.functions.iter().map(|f| TopFunction {
                    module: m.module.clone(),
                    function: f.clone(),
                })
            })
            .collect();
        let key = |t: &TopFunction| match self.function_sort {
            FunctionSort::SelfTime => t.function.self_ms_per_sim_s,
            FunctionSort::TotalTime => t.function.total_ms_per_sim_s,
            FunctionSort::Share => t.function.self_share,
            FunctionSort::Name => 0.0,
        };
        top.sort_by(|a, b| {
            key(b)
                .total_cmp(&key(a))
                .then_with(|| a.function.frame.name.cmp(&b.function.frame.name))
                .then_with(|| a.module.cmp(&b.module))
                .then_with(|| a.function.frame.cmp(&b.function.frame))
        });
        top.truncate(TOP_FUNCTIONS);
        self.top_functions = top;
    }
}

/// Parses `file:line message`.
fn parse_logpoint(text: &str) -> Result<(String, usize, String), ParseLogpointError> {
    let text = text.trim();
    let (place, message) = text.split_once(char::is_whitespace).unwrap_or((text, ""));
    let (file, line) = place
        .rsplit_once(':')
        .ok_or_else(|| ParseLogpointError::NoPlace(text.to_owned()))?;
    let line: usize = line
        .parse()
        .map_err(|_| ParseLogpointError::BadLine(place.to_owned()))?;
    let message = message.trim();
    if message.is_empty() {
        return Err(ParseLogpointError::NoMessage(text.to_owned()));
    }
    Ok((file.to_owned(), line, message.to_owned()))
}

impl ScriptsPanel {
    /// Sets every logpoint of `file` as the list holds them.
    fn apply_logpoints(&self, scene: &mut DynScene, file: &str) -> Result<(), SimError> {
        let points = self
            .logpoints
            .iter()
            .filter(|(f, _, _)| f == file)
            .map(|(_, line, message)| shoal_script::logpoints::Logpoint {
                line: *line,
                message: message.clone(),
            })
            .collect();
        scene.sim_mut().set_logpoints(file, points)
    }

    /// Adds a logpoint from `file:line message`; the console line says what happened.
    pub fn add_logpoint(&mut self, scene: &mut DynScene, text: &str) -> String {
        let (file, line, message) = match parse_logpoint(text) {
            Ok(p) => p,
            Err(e) => return format!("logpoint: {e}"),
        };
        self.logpoints.push((file.clone(), line, message.clone()));
        match self.apply_logpoints(scene, &file) {
            Ok(()) => format!("logpoint set at {file}:{line}: {message}"),
            Err(e) => {
                self.logpoints.pop();
                let _ = self.apply_logpoints(scene, &file);
                format!("logpoint not set: {e}")
            }
        }
    }

    /// Removes logpoint `i`.
    pub fn remove_logpoint(&mut self, scene: &mut DynScene, i: usize) -> String {
        if i >= self.logpoints.len() {
            return "logpoint: nothing to remove".into();
        }
        let (file, line, _) = self.logpoints.remove(i);
        match self.apply_logpoints(scene, &file) {
            Ok(()) => format!("logpoint removed from {file}:{line}"),
            Err(e) => format!("logpoint: {e}"),
        }
    }
}

fn logpoints(
    ui: &mut egui::Ui,
    scene: &mut DynScene,
    st: &mut ScriptsPanel,
    log: &mut Vec<String>,
) {
    ui.horizontal(|ui| {
        let label = ui.label("logpoint");
        let edit = ui
            .add(
                egui::TextEdit::singleline(&mut st.logpoint_input)
                    .hint_text("behaviors/forage.lua:34 hunger {fish.memory.hunger}")
                    .desired_width(field_width(ui, 260.0, "add logpoint")),
            )
            .labelled_by(label.id);
        let enter = edit.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
        if ui.button("add logpoint").clicked() || enter {
            let text = std::mem::take(&mut st.logpoint_input);
            log.push(st.add_logpoint(scene, &text));
        }
    });
    let mut remove = None;
    for (i, (file, line, message)) in st.logpoints.iter().enumerate() {
        ui.horizontal(|ui| {
            // The button first, so a long message is cut at the panel's edge instead of
            // widening the panel.
            if ui.small_button("remove logpoint").clicked() {
                remove = Some(i);
            }
            ui.add(egui::Label::new(format!("{file}:{line}  {message}")).truncate());
        });
    }
    if let Some(i) = remove {
        log.push(st.remove_logpoint(scene, i));
    }
}

/// Draws the Scripts section. Console lines (the REPL's input and answer) go to `log`.
pub(super) fn show(
    ui: &mut egui::Ui,
    scene: &mut DynScene,
    st: &mut ScriptsPanel,
    selected: Option<FishId>,
    log: &mut Vec<String>,
) {
    module_table(ui, scene, st);
    ui.separator();
    repl(ui, scene, st, selected, log);
    ui.separator();
    watches(ui, st, selected);
    ui.separator();
    pause_when(ui, st);
    ui.separator();
    logpoints(ui, scene, st, log);
}

fn pause_when(ui: &mut egui::Ui, st: &mut ScriptsPanel) {
    ui.horizontal(|ui| {
        let label = ui.label("pause when");
        let edit = ui
            .add(
                egui::TextEdit::singleline(&mut st.pause_input)
                    .hint_text("memory.hunger > 0.9")
                    .desired_width(field_width(ui, 200.0, "set")),
            )
            .labelled_by(label.id);
        let enter = edit.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
        if ui.button("set").clicked() || enter {
            let cond = st.pause_input.clone();
            st.set_pause_when(Some(&cond));
        }
    });
    if let Some(cond) = st.pause_when.clone() {
        ui.horizontal_wrapped(|ui| {
            ui.label(format!("pauses when a fish starts to meet `{cond}`"));
            if ui.small_button("clear").clicked() {
                st.set_pause_when(None);
            }
        });
    }
}

fn module_table(ui: &mut egui::Ui, scene: &mut DynScene, st: &mut ScriptsPanel) {
    if scene.sim().function_sampling() != st.sample_functions {
        scene.sim_mut().set_function_sampling(st.sample_functions);
    }
    if st.profile.is_empty() {
        ui.label("no behaviour has decided yet");
        return;
    }
    ui.horizontal_wrapped(|ui| {
        ui.label("sort by");
        for (label, by) in [
            ("cost", SortBy::Cost),
            ("calls", SortBy::Calls),
            ("errors", SortBy::Errors),
            ("memory", SortBy::Memory),
            ("name", SortBy::Name),
        ] {
            if ui.selectable_label(st.sort == by, label).clicked() {
                st.sort = by;
                st.sort_profile();
            }
        }
    });
    let total: f64 = st.profile.iter().map(|p| p.ms_per_sim_s).sum();
    // Scrolls sideways in a narrow panel instead of holding the panel at the table's width.
    egui::ScrollArea::horizontal()
        .id_salt("script profile scroll")
        .show(ui, |ui| {
            egui::Grid::new("script profile")
                .striped(true)
                .num_columns(6)
                .show(ui, |ui| {
                    for h in [
                        "module",
                        "CPU ms / sim s",
                        "calls",
                        "µs / call",
                        "KiB alloc / sim s",
                        "errors",
                    ] {
                        ui.strong(h);
                    }
                    ui.end_row();
                    for p in &st.profile {
                        ui.label(&p.module);
                        let share = if total > 0.0 {
                            (p.ms_per_sim_s / total) as f32
                        } else {
                            0.0
                        };
                        ui.add(
                            egui::ProgressBar::new(share)
                                .desired_width(110.0)
                                .text(format!("{:.2}", p.ms_per_sim_s)),
                        );
                        ui.label(p.calls.to_string());
                        ui.label(format!("{:.1}", p.us_per_call));
                        ui.label(format!("{:.1}", p.alloc_kib_per_sim_s))
                            .on_hover_text(format!(
                                "{:.0} bytes allocated per decision: garbage the collector sweeps",
                                p.alloc_bytes_per_call
                            ));
                        let bad = p.errors + p.limit_stops;
                        if bad > 0 {
                            ui.colored_label(
                                egui::Color32::from_rgb(255, 110, 90),
                                format!("{} + {} limits", p.errors, p.limit_stops),
                            );
                        } else {
                            ui.label("0");
                        }
                        ui.end_row();
                    }
                });
        });
    if ui.button("reset profile").clicked() {
        scene.sim_mut().reset_profile();
        st.profile.clear();
        st.top_functions.clear();
    }
    ui.add_space(4.0);
    top_functions(ui, st);
    flame_view(ui, st);
}

/// Height of one frame's row in the flame view, points.
const FLAME_ROW: f32 = 16.0;

/// The most sampled stacks of one module as an icicle graph: the outermost function on top,
/// each box as wide as its share of the samples shown, what it called below it.
fn flame_view(ui: &mut egui::Ui, st: &mut ScriptsPanel) {
    let sampled: Vec<&ModuleProfile> = st.profile.iter().filter(|m| m.samples > 0).collect();
    let Some(most) = sampled.iter().max_by_key(|m| m.samples) else {
        return;
    };
    let chosen = st
        .flame_module
        .clone()
        .filter(|n| sampled.iter().any(|m| &m.module == n))
        .unwrap_or_else(|| most.module.clone());
    egui::CollapsingHeader::new("flame view")
        .default_open(false)
        .show(ui, |ui| {
            let mut pick = chosen.clone();
            egui::ComboBox::from_label("module")
                .selected_text(&pick)
                .show_ui(ui, |ui| {
                    for m in &sampled {
                        ui.selectable_value(&mut pick, m.module.clone(), &m.module);
                    }
                });
            let Some(m) = sampled.iter().find(|m| m.module == pick) else {
                return;
            };
            let mut stacks = m.stacks.clone();
            stacks.sort_by(|a, b| a.frames.cmp(&b.frames));
            let shown: u64 = stacks.iter().map(|s| s.samples).sum();
            ui.label(format!(
                "{} of {} samples ({} most sampled stacks); outermost function on top",
                shown,
                m.samples,
                stacks.len()
            ));
            let depth = stacks.iter().map(|s| s.frames.len()).max().unwrap_or(0);
            if shown == 0 || depth == 0 {
                return;
            }
            let width = ui.available_width().max(100.0);
            let (rect, response) = ui.allocate_exact_size(
                egui::vec2(width, FLAME_ROW * depth as f32),
                egui::Sense::hover(),
            );
            let painter = ui.painter_at(rect);
            let per_sample = width / shown as f32;
            let mut hovered = None;
            for row in 0..depth {
                let mut x = 0u64;
                let mut i = 0;
                while i < stacks.len() {
                    let s = &stacks[i];
                    let Some(frame) = s.frames.get(row) else {
                        x += s.samples;
                        i += 1;
                        continue;
                    };
                    // The run of stacks sharing this frame's path from the top.
                    let path = &s.frames[..=row];
                    let mut n = 0;
                    let mut j = i;
                    while j < stacks.len() && stacks[j].frames.get(..=row) == Some(path) {
                        n += stacks[j].samples;
                        j += 1;
                    }
                    let r = egui::Rect::from_min_size(
                        rect.min + egui::vec2(x as f32 * per_sample, row as f32 * FLAME_ROW),
                        egui::vec2(n as f32 * per_sample, FLAME_ROW - 1.0),
                    );
                    let hue = frame
                        .bytes()
                        .fold(7u32, |h, b| h.wrapping_mul(31) ^ u32::from(b));
                    let color = egui::Color32::from_rgb(
                        200 + (hue % 55) as u8,
                        90 + (hue / 55 % 110) as u8,
                        40 + (hue / 6050 % 40) as u8,
                    );
                    painter.rect_filled(r.shrink2(egui::vec2(0.5, 0.0)), 2.0, color);
                    if r.width() > 30.0 {
                        painter.with_clip_rect(r.intersect(rect)).text(
                            r.left_center() + egui::vec2(3.0, 0.0),
                            egui::Align2::LEFT_CENTER,
                            frame,
                            egui::FontId::monospace(10.0),
                            egui::Color32::BLACK,
                        );
                    }
                    if response.hover_pos().is_some_and(|p| r.contains(p)) {
                        hovered = Some(format!(
                            "{frame}: {n} samples, {:.0} % of those shown",
                            100.0 * n as f64 / shown as f64
                        ));
                    }
                    x += n;
                    i = j;
                }
            }
            if let Some(text) = hovered {
                response.on_hover_text(text);
            }
            if pick != chosen {
                st.flame_module = Some(pick);
            }
        });
}

/// The top functions of every module by the stack samples, with file:line.
fn top_functions(ui: &mut egui::Ui, st: &mut ScriptsPanel) {
    ui.horizontal_wrapped(|ui| {
        ui.checkbox(&mut st.sample_functions, "sample functions")
            .on_hover_text(
                "samples the Lua stack about once a millisecond of a decision (no per-instruction \
                 hook) to estimate where each module's time goes",
            );
        let samples: u64 = st.profile.iter().map(|p| p.samples).sum();
        if samples > 0 || st.sample_functions {
            ui.label(format!("{samples} samples"));
        }
    });
    if st.top_functions.is_empty() {
        if st.sample_functions {
            ui.label("no samples yet: the decisions have not run long enough");
        }
        return;
    }
    // Wrapped: this row must not widen the side panel.
    ui.horizontal_wrapped(|ui| {
        ui.label("top functions by");
        for (label, by) in [
            ("self time", FunctionSort::SelfTime),
            ("total time", FunctionSort::TotalTime),
            ("share of module", FunctionSort::Share),
            ("function name", FunctionSort::Name),
        ] {
            if ui.selectable_label(st.function_sort == by, label).clicked() {
                st.function_sort = by;
                st.sort_profile();
            }
        }
    });
    // Scrolls sideways in a narrow panel instead of holding the panel at the table's width.
    egui::ScrollArea::horizontal()
        .id_salt("top functions scroll")
        .show(ui, |ui| {
            egui::Grid::new("top functions")
                .striped(true)
                .num_columns(5)
                .show(ui, |ui| {
                    for h in ["function", "file:line", "share", "ms / sim s", "samples"] {
                        ui.strong(h);
                    }
                    ui.end_row();
                    for t in &st.top_functions {
                        let f = &t.function;
                        ui.label(&f.frame.name)
                            .on_hover_text(format!("in behaviour {}", t.module));
                        // As the logpoint field takes it: relative to the scripts directory.
                        let file = f
                            .frame
                            .file
                            .strip_prefix("scripts/")
                            .unwrap_or(&f.frame.file);
                        ui.label(format!("{file}:{}", f.frame.line))
                            .on_hover_text(&f.frame.file);
                        ui.add(
                            egui::ProgressBar::new(f.self_share as f32)
                                .desired_width(48.0)
                                .text(format!("{:.0} %", 100.0 * f.self_share)),
                        )
                        .on_hover_text(format!("of the samples of behaviour {}", t.module));
                        ui.label(format!("{:.2}", f.self_ms_per_sim_s))
                            .on_hover_text(format!(
                                "its own code; {:.2} ms / sim s with what it calls",
                                f.total_ms_per_sim_s
                            ));
                        ui.label(f.self_samples.to_string());
                        ui.end_row();
                    }
                });
        });
}

fn repl(
    ui: &mut egui::Ui,
    scene: &DynScene,
    st: &mut ScriptsPanel,
    selected: Option<FishId>,
    log: &mut Vec<String>,
) {
    let Some(fish) = selected else {
        ui.label("select a fish to evaluate Lua in its context");
        return;
    };
    ui.label(format!(
        "Lua in fish #{}'s context (fish, fish.memory …)",
        fish.index
    ));
    let mut run = false;
    ui.horizontal(|ui| {
        let label = ui.label("lua");
        let edit = ui
            .add(
                egui::TextEdit::singleline(&mut st.repl_input)
                    .hint_text("fish.memory.hunger")
                    .desired_width(field_width(ui, 200.0, "eval")),
            )
            .labelled_by(label.id);
        run |= edit.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
        run |= ui.button("eval").clicked();
    });
    let code = st.repl_input.trim().to_owned();
    if run && !code.is_empty() {
        log.push(format!("> {code}  (fish #{})", fish.index));
        log.push(match scene.sim().console_eval(fish, &code) {
            Ok(answer) => answer,
            Err(e) => format!("error: {e}"),
        });
    }
}

fn watches(ui: &mut egui::Ui, st: &mut ScriptsPanel, selected: Option<FishId>) {
    ui.label("watches on the selected fish (memory, percepts, intention, params, speed, depth…)");
    ui.horizontal(|ui| {
        let label = ui.label("watch");
        let edit = ui
            .add(
                egui::TextEdit::singleline(&mut st.watch_input)
                    .hint_text("memory.hunger")
                    .desired_width(field_width(ui, 200.0, "add watch")),
            )
            .labelled_by(label.id);
        let enter = edit.lost_focus() && ui.input(|i| i.key_pressed(egui::Key::Enter));
        if ui.button("add watch").clicked() || enter {
            let expr = std::mem::take(&mut st.watch_input);
            st.add_watch(&expr);
        }
    });
    let mut remove = None;
    for (i, w) in st.watches.iter().enumerate() {
        ui.horizontal(|ui| {
            // The button first, so a long value or error is cut at the panel's edge (hover
            // shows it whole) instead of widening the panel.
            if ui.small_button("remove").clicked() {
                remove = Some(i);
            }
            let (text, color) = match (&w.last, selected) {
                (_, None) => (format!("{} (no fish selected)", w.expr), None),
                (Ok(v), _) => (format!("{} = {v}", w.expr), None),
                (Err(e), _) => (
                    format!("{}: {e}", w.expr),
                    Some(egui::Color32::from_rgb(255, 110, 90)),
                ),
            };
            let mut rich = egui::RichText::new(text);
            if let Some(c) = color {
                rich = rich.color(c);
            }
            ui.add(egui::Label::new(rich).truncate());
        });
    }
    if let Some(i) = remove {
        st.watches.remove(i);
    }
    if st.watches.iter().any(|w| !w.points.is_empty()) {
        egui_plot::Plot::new("watches")
            .height(150.0)
            .legend(egui_plot::Legend::default())
            .x_axis_label("simulated time, s")
            .show(ui, |plot| {
                for w in &st.watches {
                    let pts: Vec<[f64; 2]> = w.points.iter().copied().collect();
                    plot.line(egui_plot::Line::new(
                        w.expr.clone(),
                        egui_plot::PlotPoints::from(pts),
                    ));
                }
            });
    }
}

/// The width of a one-line text field that shares its row with a button labelled `button`:
/// `wanted`, or what the row has left beside the button when the panel is narrower, so the
/// field shrinks with the panel instead of holding it wide.
fn field_width(ui: &egui::Ui, wanted: f32, button: &str) -> f32 {
    let spacing = &ui.style().spacing;
    let label = super::widgets::text_width(ui, button, egui::TextStyle::Button);
    // The button's text and padding, the gap before it, and the field's own inner margin.
    let beside = label + 2.0 * spacing.button_padding.x + 2.0 * spacing.item_spacing.x + 8.0;
    (ui.available_width() - beside).clamp(60.0, wanted)
}

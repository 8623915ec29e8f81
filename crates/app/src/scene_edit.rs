//! The window's edits of the running scene: a group's `params`, the rocks, the current zones and
//! the groups' start regions. Each edit is applied at once ([`Showable::apply_scene_edit`]), kept
//! for undo/redo (the whole scene before it, so undo returns exactly the previous state), listed
//! among the unsaved changes, and saved into the scene file through [`shoal_script::edit::save`]:
//! only the changed literals are written, comments and layout stay.

use std::path::{Path, PathBuf};

use shoal_script::edit::{self, Edit, EditError, EditOptions, KeyPath, LuaValue, Seg};
use shoal_script::scene::SceneDesc;

use super::showable::{Showable, SimError};

/// Decimals the scene controls show and step by (positions and radii in world units).
pub(super) const UNIT_DECIMALS: usize = 1;
/// Decimals a `params` number that is not whole shows and steps by.
pub(super) const PARAM_DECIMALS: usize = 2;

/// A question to the designer before a scene save can go on.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum SceneAsk {
    /// The file writes an edited value as an expression (the editor's message).
    Expression(String),
    /// The scene file changed on disk while the window had unsaved edits of it.
    DiskChanged,
}

/// What a scene save did.
#[derive(Debug, PartialEq)]
pub(super) enum SceneSaved {
    /// Nothing was unsaved.
    Nothing,
    /// This many values written.
    Saved(usize),
    /// A question is open ([`SceneEdits::ask`]).
    Asked,
    /// Refused (the message names the file and why).
    Failed(String),
}

/// The running scene as the window edited it, and where each rock and current zone came from
/// in the saved file (`None`: added in the window), so a save removes and appends the right
/// items.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Layout {
    /// The scene.
    pub desc: SceneDesc,
    /// Per rock: its index in the saved scene's `obstacles`.
    rocks: Vec<Option<usize>>,
    /// Per current zone: its index in the saved scene's `currents`.
    zones: Vec<Option<usize>>,
}

impl Layout {
    fn saved(desc: SceneDesc) -> Self {
        Self {
            rocks: (0..desc.obstacles.len()).map(Some).collect(),
            zones: (0..desc.currents.len()).map(Some).collect(),
            desc,
        }
    }
}

/// A rock or current zone to add or delete.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Item {
    /// `obstacles[i]` (0-based).
    Rock(usize),
    /// `currents[i]` (0-based).
    Zone(usize),
    /// `fish[g].region` (0-based group): moved and resized, not added or deleted.
    Region(usize),
}

/// The scene as saved, the edits since, and undo/redo.
#[derive(Debug, Default)]
pub(super) struct SceneEdits {
    /// The scene as last read from or written to its file.
    saved: Option<SceneDesc>,
    /// The file's text then (to notice an edit by hand before saving over it).
    disk: Option<String>,
    /// The running scene as the last edit left it (another value means the scene restarted).
    live: Option<Layout>,
    undo: Vec<Layout>,
    redo: Vec<Layout>,
    /// The question shown in the panel until answered.
    pub ask: Option<SceneAsk>,
    /// A drag's edits go into one undo step until [`SceneEdits::end_drag`].
    drag_open: bool,
}

impl SceneEdits {
    /// The drag in progress ended: the next edit is a new undo step.
    pub fn end_drag(&mut self) {
        self.drag_open = false;
    }

    /// Called each frame with the running scene: a scene that changed under the window (a
    /// restart from the file) is the new saved state, with no undo history.
    pub fn observe(&mut self, live: Option<&SceneDesc>, file: Option<&Path>) {
        if self.live.as_ref().map(|l| &l.desc) == live {
            return;
        }
        self.saved = live.cloned();
        self.live = live.cloned().map(Layout::saved);
        self.disk = file.and_then(|f| std::fs::read_to_string(f).ok());
        self.undo.clear();
        self.redo.clear();
        self.ask = None;
    }

    fn apply(&mut self, sim: &mut dyn Showable, next: Layout, merge: bool) -> Result<(), SimError> {
        let Some(before) = self.live.clone() else {
            return Err(SimError::NoSceneFile);
        };
        if before == next {
            return Ok(());
        }
        sim.apply_scene_edit(next.desc.clone())?;
        if !(merge && self.drag_open) || self.undo.is_empty() {
            self.undo.push(before);
        }
        self.drag_open = merge;
        self.redo.clear();
        self.live = Some(next);
        Ok(())
    }

    /// Makes `desc` (the running scene with values changed, no rock or zone added or removed)
    /// the running scene, undoably. With `merge` it continues the last edit (a drag in
    /// progress): one undo step goes back to before the whole drag.
    pub fn edit(
        &mut self,
        sim: &mut dyn Showable,
        desc: SceneDesc,
        merge: bool,
    ) -> Result<(), SimError> {
        let Some(mut next) = self.live.clone() else {
            return Err(SimError::NoSceneFile);
        };
        if desc.obstacles.len() != next.rocks.len() || desc.currents.len() != next.zones.len() {
            return Err(SimError::SceneEdit(
                "rocks and current zones are added and deleted with their buttons".into(),
            ));
        }
        next.desc = desc;
        self.apply(sim, next, merge)
    }

    /// Adds a rock or current zone (`item`'s index is ignored) at `pos`, undoably; returns its
    /// index.
    pub fn add(
        &mut self,
        sim: &mut dyn Showable,
        item: Item,
        pos: [f32; 3],
        radius: f32,
    ) -> Result<usize, SimError> {
        let Some(mut next) = self.live.clone() else {
            return Err(SimError::NoSceneFile);
        };
        let i = match item {
            Item::Rock(_) => {
                next.desc
                    .obstacles
                    .push(shoal_script::scene::ObstacleDesc { pos, radius });
                next.rocks.push(None);
                next.rocks.len() - 1
            }
            Item::Region(_) => {
                return Err(SimError::SceneEdit(
                    "a start region belongs to its fish group".into(),
                ));
            }
            Item::Zone(_) => {
                next.desc.currents.push(shoal_script::scene::CurrentDesc {
                    pos,
                    radius,
                    velocity: [10.0, 0.0, 0.0],
                });
                next.zones.push(None);
                next.zones.len() - 1
            }
        };
        self.apply(sim, next, false)?;
        Ok(i)
    }

    /// Deletes a rock or current zone, undoably.
    pub fn delete(&mut self, sim: &mut dyn Showable, item: Item) -> Result<(), SimError> {
        let Some(mut next) = self.live.clone() else {
            return Err(SimError::NoSceneFile);
        };
        match item {
            Item::Rock(i) if i < next.rocks.len() => {
                next.desc.obstacles.remove(i);
                next.rocks.remove(i);
            }
            Item::Zone(i) if i < next.zones.len() => {
                next.desc.currents.remove(i);
                next.zones.remove(i);
            }
            _ => return Ok(()),
        }
        self.apply(sim, next, false)
    }

    /// Goes back one edit; false when there is none.
    pub fn undo(&mut self, sim: &mut dyn Showable) -> Result<bool, SimError> {
        let (Some(prev), Some(now)) = (self.undo.last().cloned(), self.live.clone()) else {
            return Ok(false);
        };
        sim.apply_scene_edit(prev.desc.clone())?;
        self.undo.pop();
        self.redo.push(now);
        self.live = Some(prev);
        Ok(true)
    }

    /// Does the last undone edit again; false when there is none.
    pub fn redo(&mut self, sim: &mut dyn Showable) -> Result<bool, SimError> {
        let (Some(next), Some(now)) = (self.redo.last().cloned(), self.live.clone()) else {
            return Ok(false);
        };
        sim.apply_scene_edit(next.desc.clone())?;
        self.redo.pop();
        self.undo.push(now);
        self.live = Some(next);
        Ok(true)
    }

    /// Whether there is an edit to undo.
    pub fn can_undo(&self) -> bool {
        !self.undo.is_empty()
    }

    /// Whether there is an undone edit to redo.
    pub fn can_redo(&self) -> bool {
        !self.redo.is_empty()
    }

    /// The running scene as the window knows it.
    pub fn live(&self) -> Option<&SceneDesc> {
        self.live.as_ref().map(|l| &l.desc)
    }

    /// The edits that would bring the file from its saved state to the running one.
    pub fn changes(&self) -> Vec<Edit> {
        match (&self.saved, &self.live) {
            (Some(saved), Some(live)) => diff(saved, live),
            _ => Vec::new(),
        }
    }

    /// Writes the unsaved edits into `file`. `force` saves although the file changed on disk;
    /// `replace_expressions` replaces values written as expressions.
    pub fn save(&mut self, file: &PathBuf, force: bool, replace_expressions: bool) -> SceneSaved {
        let edits = self.changes();
        if edits.is_empty() {
            return SceneSaved::Nothing;
        }
        let now = std::fs::read_to_string(file).ok();
        if !force && now != self.disk {
            self.ask = Some(SceneAsk::DiskChanged);
            return SceneSaved::Asked;
        }
        match edit::save(
            file,
            &edits,
            EditOptions {
                replace_expressions,
            },
        ) {
            Ok(_) => {
                if let Some(live) = &mut self.live {
                    *live = Layout::saved(live.desc.clone());
                    self.saved = Some(live.desc.clone());
                }
                // The undo history starts over: older states name rocks and zones by their
                // places in the file as it was before this save.
                self.undo.clear();
                self.redo.clear();
                self.disk = std::fs::read_to_string(file).ok();
                self.ask = None;
                SceneSaved::Saved(edits.len())
            }
            Err(e @ EditError::Expression { .. }) => {
                self.ask = Some(SceneAsk::Expression(e.to_string()));
                SceneSaved::Asked
            }
            Err(e) => SceneSaved::Failed(e.to_string()),
        }
    }

    /// Takes the file's scene: goes back to the saved state (undoably).
    pub fn revert(&mut self, sim: &mut dyn Showable) -> Result<(), SimError> {
        self.ask = None;
        match self.saved.clone() {
            Some(saved) => self.apply(sim, Layout::saved(saved), false),
            None => Ok(()),
        }
    }
}

/// `v` rounded to `decimals` places, as the nearest `f32`.
pub(super) fn round_f32(v: f32, decimals: usize) -> f32 {
    format!("{v:.decimals$}").parse().unwrap_or(v)
}

/// `v` rounded to `decimals` places, as the nearest `f64`.
pub(super) fn round_f64(v: f64, decimals: usize) -> f64 {
    format!("{v:.decimals$}").parse().unwrap_or(v)
}

fn path(segs: Vec<Seg>) -> KeyPath {
    KeyPath(segs)
}

fn key(k: &str) -> Seg {
    Seg::Key(k.to_owned())
}

fn vec3(v: [f32; 3]) -> LuaValue {
    LuaValue::List(v.iter().map(|x| LuaValue::from_f32(*x)).collect())
}

/// A JSON value (a scene's `params`) as Lua literal text. A float keeps a decimal point
/// (`3.0`), so the file reads back as the same number kind the running scene holds.
fn json_value(v: &serde_json::Value) -> LuaValue {
    match v {
        serde_json::Value::Bool(b) => LuaValue::Bool(*b),
        serde_json::Value::Number(n) if n.is_f64() => {
            LuaValue::Number(format!("{:?}", n.as_f64().unwrap_or(0.0)))
        }
        serde_json::Value::Number(n) => LuaValue::Number(n.to_string()),
        serde_json::Value::String(s) => LuaValue::string(s),
        serde_json::Value::Array(items) => LuaValue::List(items.iter().map(json_value).collect()),
        serde_json::Value::Object(map) => {
            let fields: Vec<String> = map
                .iter()
                .map(|(k, v)| format!("{k} = {}", json_value(v).text()))
                .collect();
            LuaValue::Table(format!("{{ {} }}", fields.join(", ")))
        }
        serde_json::Value::Null => LuaValue::Table("{}".into()),
    }
}

/// Edits of the leaves of `params` that differ, under `at`.
fn json_diff(at: &[Seg], old: &serde_json::Value, new: &serde_json::Value, out: &mut Vec<Edit>) {
    use serde_json::Value as J;
    match (old, new) {
        (J::Object(a), J::Object(b)) if a.keys().eq(b.keys()) => {
            for (k, v) in b {
                let mut p = at.to_vec();
                p.push(key(k));
                json_diff(&p, &a[k], v, out);
            }
        }
        (J::Array(a), J::Array(b)) if a.len() == b.len() => {
            for (i, (x, y)) in a.iter().zip(b).enumerate() {
                let mut p = at.to_vec();
                p.push(Seg::Index(i + 1));
                json_diff(&p, x, y, out);
            }
        }
        _ if old != new => out.push(Edit {
            path: path(at.to_vec()),
            value: json_value(new),
        }),
        _ => {}
    }
}

/// The edits of one list (`obstacles`, `currents`): changed fields of the items kept (at
/// their places in the file), then the items deleted (last first, so the places before stay
/// right), then the items added, appended.
fn list_diff<T>(
    name: &str,
    saved: &[T],
    live: &[T],
    origins: &[Option<usize>],
    fields: impl Fn(&T, &T) -> Vec<(&'static str, LuaValue)>,
    table: impl Fn(&T) -> String,
    out: &mut Vec<Edit>,
) {
    for (item, origin) in live.iter().zip(origins) {
        if let Some(i) = *origin
            && let Some(was) = saved.get(i)
        {
            for (field, value) in fields(was, item) {
                out.push(Edit {
                    path: path(vec![key(name), Seg::Index(i + 1), key(field)]),
                    value,
                });
            }
        }
    }
    for i in (0..saved.len()).rev() {
        if !origins.contains(&Some(i)) {
            out.push(Edit {
                path: path(vec![key(name), Seg::Index(i + 1)]),
                value: LuaValue::Nil,
            });
        }
    }
    let kept = origins.iter().filter(|o| o.is_some()).count();
    let added = live.iter().zip(origins).filter(|(_, o)| o.is_none());
    for (k, (item, _)) in added.enumerate() {
        out.push(Edit {
            path: path(vec![key(name), Seg::Index(kept + k + 1)]),
            value: LuaValue::Table(table(item)),
        });
    }
}

/// The edits that turn the scene file's `saved` into `live`: each changed literal (params,
/// start positions and regions, rocks, current zones), rocks and zones deleted and added.
pub(super) fn diff(saved: &SceneDesc, live: &Layout) -> Vec<Edit> {
    let mut out = Vec::new();
    for (g, (a, b)) in saved.fish.iter().zip(&live.desc.fish).enumerate() {
        let group = vec![key("fish"), Seg::Index(g + 1)];
        if a.pos != b.pos
            && let Some(p) = b.pos
        {
            out.push(Edit {
                path: path([group.clone(), vec![key("pos")]].concat()),
                value: vec3(p),
            });
        }
        if a.region != b.region
            && let Some(r) = b.region
        {
            let old = a.region;
            for (name, v, was) in [
                ("min", r.min, old.map(|o| o.min)),
                ("max", r.max, old.map(|o| o.max)),
            ] {
                if was != Some(v) {
                    out.push(Edit {
                        path: path([group.clone(), vec![key("region"), key(name)]].concat()),
                        value: vec3(v),
                    });
                }
            }
        }
        if let (Some(x), Some(y)) = (&a.params, &b.params) {
            let mut at = group.clone();
            at.push(key("params"));
            json_diff(&at, x, y, &mut out);
        }
    }
    list_diff(
        "obstacles",
        &saved.obstacles,
        &live.desc.obstacles,
        &live.rocks,
        |was, o| {
            let mut f = Vec::new();
            if was.pos != o.pos {
                f.push(("pos", vec3(o.pos)));
            }
            if was.radius != o.radius {
                f.push(("radius", LuaValue::from_f32(o.radius)));
            }
            f
        },
        |o| format!("{{ pos = {}, radius = {} }}", vec3(o.pos).text(), o.radius),
        &mut out,
    );
    list_diff(
        "currents",
        &saved.currents,
        &live.desc.currents,
        &live.zones,
        |was, c| {
            let mut f = Vec::new();
            if was.pos != c.pos {
                f.push(("pos", vec3(c.pos)));
            }
            if was.radius != c.radius {
                f.push(("radius", LuaValue::from_f32(c.radius)));
            }
            if was.velocity != c.velocity {
                f.push(("velocity", vec3(c.velocity)));
            }
            f
        },
        |c| {
            format!(
                "{{ pos = {}, radius = {}, velocity = {} }}",
                vec3(c.pos).text(),
                c.radius,
                vec3(c.velocity).text()
            )
        },
        &mut out,
    );
    out
}

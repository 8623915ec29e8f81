//! The script host: one Lua state for the fish of one script lane (see [`super::sim`]),
//! behaviour modules loaded once per file, a per-fish table (with its `memory`) kept in the Lua
//! registry, and one protected call per fish decision.
//!
//! A behaviour module is a Lua file in `scripts/behaviors/` returning a table with either the
//! three layers of the paper's section 3.1
//!
//! ```lua
//! local M = {}
//! function M.perceive(fish) ... return percepts end          -- perception layer
//! function M.intend(fish, percepts) ... return "flee" end    -- intention layer
//! function M.behave(fish, intention, percepts) ... end       -- behaviour layer: motion requests
//! return M
//! ```
//!
//! or a single `tick(fish)` (whose return value, if any, is taken as the intention). The host
//! stores what `perceive` returned in `fish.percepts` and the intention in `fish.intention`, so
//! the inspector panel shows them. `fish.memory` persists across ticks and reloads.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use mlua::{Function, Lua, LuaSerdeExt, Table, Value};

use super::error::{DecisionError, EvalError, ScriptError, describe};
use super::log::{LogLevel, ScriptLog};
use super::sandbox::{self, Abort, Budget, LOADED_KEY, Limits, ScriptRoot};
use super::watchdog::{Meter, Metered};
use shoal_core::world::FishId;

/// Registry key of the table of per-fish tables (fish index → fish table).
pub(crate) const FISH_KEY: &str = "shoal.fish";

pub use crate::api::DECISION_KEY;

/// Runs one decision: the layers of a module for one fish. Host-private: scripts never see it.
const DRIVER: &str = r#"
local decision = ...
return function(mod, fish, species)
  decision.species = species
  local tick = mod.tick
  if tick then
    local i = tick(fish)
    if i ~= nil then fish.intention = i end
    return
  end
  local perceive, intend, behave = mod.perceive, mod.intend, mod.behave
  local p, i
  if perceive then p = perceive(fish) end
  fish.percepts = p
  if intend then i = intend(fish, p) end
  fish.intention = i
  if behave then behave(fish, i, p) end
end
"#;

/// Index of a loaded behaviour module in the host.
pub type ModuleIndex = usize;

/// A behaviour module: its file and the last version that loaded.
#[derive(Debug)]
struct Module {
    /// Behaviour name (`forage`).
    name: String,
    /// Canonical path of its file.
    path: PathBuf,
    /// The module table of the last good load; `None` if it never loaded.
    table: Option<Table>,
    /// Failed calls since the last call that succeeded.
    failures_in_a_row: u32,
    /// Calls stopped by the instruction budget, the time limit or the memory limit since the
    /// module loaded.
    limit_hits: u32,
    /// Why the module is switched off, once it is; cleared when its file loads again.
    quarantined: Option<String>,
}

/// Failed calls in a row (no call of the module succeeding in between) after which a behaviour
/// is switched off until its file is saved.
pub const QUARANTINE_AFTER_FAILURES: u32 = 5;
/// Calls stopped by the instruction budget, the time limit or the memory limit after which a
/// behaviour is switched off until its file is saved: each such call costs the tick a whole budget.
pub const QUARANTINE_AFTER_LIMIT_HITS: u32 = 3;

impl Module {
    fn new(name: &str, path: PathBuf) -> Self {
        Self {
            name: name.to_owned(),
            path,
            table: None,
            failures_in_a_row: 0,
            limit_hits: 0,
            quarantined: None,
        }
    }
}

/// What a reload did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Reloaded {
    /// These behaviour modules now run their new code.
    Modules(Vec<String>),
    /// The file failed to load; the last good version keeps running. The message names file:line.
    Failed(String),
    /// The file is not a behaviour module nor required by one.
    NotAModule,
}

/// Why a behaviour module did not load (the last good version keeps running).
#[derive(Debug, thiserror::Error)]
enum LoadError {
    /// The file could not be read or does not compile.
    #[error(transparent)]
    File(#[from] ScriptError),
    /// Running the file raised an error or was stopped by a limit.
    #[error("{message}")]
    Run {
        /// The message as the console shows it (`file:line: message`).
        message: String,
    },
    /// The file returned something other than a table.
    #[error(
        "{file}: a behaviour must return a table with tick(fish) or perceive/intend/behave \
         functions (got {got})"
    )]
    NotATable {
        /// The file as shown.
        file: String,
        /// The Lua type it returned.
        got: &'static str,
    },
    /// The table has none of the layers' functions.
    #[error(
        "{file}: a behaviour must return a table with tick(fish) or perceive/intend/behave \
         functions"
    )]
    NoLayers {
        /// The file as shown.
        file: String,
    },
    /// `min_decision_hz` is not a number in (0, 60].
    #[error(
        "{file}: min_decision_hz must be a number in (0, 60] (decisions per second the level of \
         detail may not go below), got {got}"
    )]
    MinRate {
        /// The file as shown.
        file: String,
        /// What it holds.
        got: String,
    },
}

/// One Lua state: the fish of one script lane.
pub struct ScriptHost {
    lua: Lua,
    budget: Arc<Budget>,
    /// Turns the budget hook on and off around calls.
    meter: Meter,
    limits: Limits,
    root: ScriptRoot,
    driver: Function,
    fish_tables: Table,
    /// Handles on the fish tables by slot index, with the generation they belong to: finding a
    /// fish's table every decision without two registry lookups.
    table_cache: Vec<Option<(u32, Table)>>,
    modules: Vec<Module>,
    by_name: HashMap<String, ModuleIndex>,
    /// Current load failures: file (as displayed) → message. Cleared when the file loads.
    load_errors: BTreeMap<String, String>,
    /// The last error of each fish (by index), for the inspector.
    fish_errors: HashMap<u32, String>,
    /// Every distinct error message, in order, for tests and `shoal test`.
    error_history: Vec<String>,
    /// Whether the last failed decision was stopped by the instruction budget, the time limit or
    /// the memory limit.
    last_call_hit_limit: bool,
    /// The scene's `params` of each fish that has some, by slot index with the generation they
    /// belong to; copied into the fish's table as `fish.params` when the table is made.
    fish_params: HashMap<u32, (u32, Arc<serde_json::Value>)>,
    /// The next decisions run with the debugger's line hook (see [`super::debug`]).
    line_hook: bool,
}

impl ScriptHost {
    /// A host for the scripts under `scripts_dir` (the `scripts/` directory).
    pub fn new(scripts_dir: &Path, limits: Limits) -> Result<Self, ScriptError> {
        let (lua, budget, meter) = sandbox::new_state(scripts_dir, limits)?;
        let root = ScriptRoot::new(scripts_dir)?;
        let lua_err = |e: mlua::Error| ScriptError::Lua(describe(&e));
        let decision = lua.create_table().map_err(lua_err)?;
        lua.set_named_registry_value(DECISION_KEY, &decision)
            .map_err(lua_err)?;
        let driver: Function = lua
            .load(DRIVER)
            .set_name("=shoal driver")
            .call(decision)
            .map_err(lua_err)?;
        let fish_tables = lua.create_table().map_err(lua_err)?;
        lua.set_named_registry_value(FISH_KEY, &fish_tables)
            .map_err(lua_err)?;
        Ok(Self {
            lua,
            budget,
            meter,
            limits,
            root,
            driver,
            fish_tables,
            table_cache: Vec::new(),
            modules: Vec::new(),
            by_name: HashMap::new(),
            load_errors: BTreeMap::new(),
            fish_errors: HashMap::new(),
            error_history: Vec::new(),
            last_call_hit_limit: false,
            fish_params: HashMap::new(),
            line_hook: false,
        })
    }

    /// The Lua state (for registering the `shoal` API and scoped world access).
    pub fn lua(&self) -> &Lua {
        &self.lua
    }

    /// The script root.
    pub fn root(&self) -> &ScriptRoot {
        &self.root
    }

    /// The limits the state runs under.
    pub fn limits(&self) -> Limits {
        self.limits
    }

    /// Records a message in the console log (once per distinct message).
    pub fn log(&mut self, level: LogLevel, message: &str, fish: Option<FishId>, time_s: f64) {
        let new = self
            .lua
            .app_data_mut::<ScriptLog>()
            .map(|mut l| l.push(level, message, fish, time_s))
            .unwrap_or(false);
        if new && level == LogLevel::Error {
            self.error_history.push(message.to_owned());
        }
    }

    /// Takes the console entries logged since the last call.
    pub fn drain_log(&mut self) -> Vec<super::log::LogEntry> {
        self.lua
            .app_data_mut::<ScriptLog>()
            .map(|mut l| l.drain())
            .unwrap_or_default()
    }

    /// How often `message` was logged (repeats included).
    pub fn log_count(&self, message: &str) -> u64 {
        self.lua
            .app_data_ref::<ScriptLog>()
            .map(|l| l.count(message))
            .unwrap_or(0)
    }

    /// Every distinct error logged so far, oldest first.
    pub fn error_messages(&self) -> &[String] {
        &self.error_history
    }

    /// Files that currently fail to load (display name → message), shown until fixed.
    pub fn load_errors(&self) -> &BTreeMap<String, String> {
        &self.load_errors
    }

    /// The module running behaviour `name` (`scripts/behaviors/<name>.lua`), loading it on first
    /// use. `None` if it never loaded (the error is logged and kept in [`Self::load_errors`]).
    pub fn module(&mut self, name: &str, time_s: f64) -> Option<ModuleIndex> {
        if let Some(&i) = self.by_name.get(name) {
            return self.modules[i].table.is_some().then_some(i);
        }
        let i = self.modules.len();
        let path = match self.root.resolve_module(&format!("behaviors/{name}")) {
            Ok(p) => p,
            Err(why) => {
                let msg = format!("behaviour '{name}': {why}");
                self.log(LogLevel::Error, &msg, None, time_s);
                self.load_errors.insert(format!("behaviors/{name}"), msg);
                self.by_name.insert(name.to_owned(), i);
                self.modules.push(Module::new(
                    name,
                    self.root.dir.join("behaviors").join(format!("{name}.lua")),
                ));
                return None;
            }
        };
        self.by_name.insert(name.to_owned(), i);
        self.modules.push(Module::new(name, path));
        self.load_module(i, time_s);
        self.modules[i].table.is_some().then_some(i)
    }

    /// The module's `min_decision_hz` (checked when it loaded), if it asks for one: the
    /// level-of-detail schedule never lets its fish decide less often.
    pub fn min_decision_hz(&self, module: ModuleIndex) -> Option<f64> {
        let t = self.modules.get(module)?.table.as_ref()?;
        match t.raw_get::<Value>("min_decision_hz").ok()? {
            Value::Integer(n) => Some(n as f64),
            Value::Number(x) => Some(x),
            _ => None,
        }
    }

    /// (Re)loads module `i`; on failure keeps the previous table and records the error.
    fn load_module(&mut self, i: ModuleIndex, time_s: f64) -> bool {
        let path = self.modules[i].path.clone();
        let display = self.root.display_of(&path);
        match self.compile_module(&path, &display) {
            Ok(t) => {
                let m = &mut self.modules[i];
                m.table = Some(t);
                m.failures_in_a_row = 0;
                m.limit_hits = 0;
                if m.quarantined.take().is_some() {
                    self.log(
                        LogLevel::Info,
                        &format!("{display}: saved — the behaviour runs again"),
                        None,
                        time_s,
                    );
                }
                if self.load_errors.remove(&display).is_some() {
                    self.log(
                        LogLevel::Info,
                        &format!("{display}: loads again"),
                        None,
                        time_s,
                    );
                }
                if let Some(mut l) = self.lua.app_data_mut::<ScriptLog>() {
                    l.forget_file(&display);
                }
                true
            }
            Err(e) => {
                let msg = e.to_string();
                self.log(LogLevel::Error, &msg, None, time_s);
                self.load_errors.insert(display, msg);
                false
            }
        }
    }

    fn compile_module(&self, path: &Path, display: &str) -> Result<Table, LoadError> {
        let f = sandbox::load_file(&self.lua, path)?;
        let v: Value = {
            let _metered = self.begin_load();
            f.call(()).map_err(|e| LoadError::Run {
                message: self.after_error(&e),
            })?
        };
        let Value::Table(t) = v else {
            return Err(LoadError::NotATable {
                file: display.to_owned(),
                got: v.type_name(),
            });
        };
        let has = |k: &str| matches!(t.raw_get::<Value>(k), Ok(Value::Function(_)));
        if !(has("tick") || has("behave") || has("intend") || has("perceive")) {
            return Err(LoadError::NoLayers {
                file: display.to_owned(),
            });
        }
        match t.raw_get::<Value>("min_decision_hz") {
            Ok(Value::Nil) => {}
            Ok(Value::Integer(n)) if (1..=60).contains(&n) => {}
            Ok(Value::Number(x)) if x > 0.0 && x <= 60.0 => {}
            Ok(v) => {
                return Err(LoadError::MinRate {
                    file: display.to_owned(),
                    got: match v {
                        Value::Integer(n) => n.to_string(),
                        Value::Number(x) => x.to_string(),
                        v => format!("a {}", v.type_name()),
                    },
                });
            }
            Err(e) => {
                return Err(LoadError::Run {
                    message: describe(&e),
                });
            }
        }
        Ok(t)
    }

    /// Formats an error from a call, collecting garbage after a memory error so the next call
    /// has room again.
    fn after_error(&self, e: &mlua::Error) -> String {
        self.recover(e);
        describe(e)
    }

    /// Collects garbage after a memory error so the next call has room again.
    fn recover(&self, e: &mlua::Error) {
        if matches!(e, mlua::Error::MemoryError(_)) || self.budget.aborted() == Some(Abort::Memory)
        {
            let _ = self.lua.gc_collect();
        }
    }

    /// Reloads what `path` (a changed file under `scripts/`) affects: the behaviour module of that
    /// file, or — for a file loaded with `require` — every behaviour module (so they pick up the
    /// new library). Live fish keep their tables and memory.
    pub fn reload_path(&mut self, path: &Path, time_s: f64) -> Reloaded {
        let real = path.canonicalize().unwrap_or_else(|_| path.to_path_buf());
        if let Some(i) = self.modules.iter().position(|m| m.path == real) {
            let name = self.modules[i].name.clone();
            return if self.load_module(i, time_s) {
                Reloaded::Modules(vec![name])
            } else {
                Reloaded::Failed(self.load_errors[&self.root.display_of(&real)].clone())
            };
        }
        let key = real.to_string_lossy().into_owned();
        let required = self
            .lua
            .named_registry_value::<Table>(LOADED_KEY)
            .ok()
            .filter(|t| t.contains_key(key.as_str()).unwrap_or(false));
        if required.is_none() {
            return Reloaded::NotAModule;
        }
        // Check the library compiles before reloading its users.
        let display = self.root.display_of(&real);
        if let Err(e) = sandbox::load_file(&self.lua, &real) {
            let msg = e.to_string();
            self.log(LogLevel::Error, &msg, None, time_s);
            self.load_errors.insert(display, msg.clone());
            return Reloaded::Failed(msg);
        }
        self.load_errors.remove(&display);
        // Every module requires its libraries afresh (each has a `require` cache of its own); a
        // module that fails to load keeps running its old version, built on the old library.
        let mut names = Vec::new();
        let mut failed = None;
        for i in 0..self.modules.len() {
            if self.load_module(i, time_s) {
                names.push(self.modules[i].name.clone());
            } else if failed.is_none() {
                failed =
                    Some(self.load_errors[&self.root.display_of(&self.modules[i].path)].clone());
            }
        }
        if let Some(msg) = failed {
            return Reloaded::Failed(msg);
        }
        Reloaded::Modules(names)
    }

    /// The fish's table, created (with an empty `memory`) the first time the fish runs or when
    /// its slot now holds a new fish.
    pub fn fish_table(
        &mut self,
        id: FishId,
        species: &str,
        behavior: &str,
    ) -> Result<Table, ScriptError> {
        self.ensure_fish_table(id, species, behavior)?;
        self.cached_table(id)
            .cloned()
            .ok_or_else(|| ScriptError::Lua(format!("no table for fish {}", id.index)))
    }

    /// Makes sure the fish's table is in the cache (see [`ScriptHost::fish_table`]).
    fn ensure_fish_table(
        &mut self,
        id: FishId,
        species: &str,
        behavior: &str,
    ) -> Result<(), ScriptError> {
        if self.cached_table(id).is_some() {
            return Ok(());
        }
        if let Some(t) = self.existing_fish_table(id) {
            self.cache_table(id, t);
            return Ok(());
        }
        let err = |e: mlua::Error| ScriptError::Lua(describe(&e));
        let t = self.new_fish_table(id, species, behavior).map_err(err)?;
        self.fish_tables.raw_set(id.index, &t).map_err(err)?;
        self.cache_table(id, t);
        Ok(())
    }

    /// A fish's table as it starts: ids, names, an empty `memory`, its `params`.
    fn new_fish_table(&self, id: FishId, species: &str, behavior: &str) -> mlua::Result<Table> {
        let t = self.lua.create_table()?;
        t.raw_set("id", id.index)?;
        t.raw_set("generation", id.generation)?;
        t.raw_set("species", species)?;
        t.raw_set("behavior", behavior)?;
        t.raw_set("memory", self.lua.create_table()?)?;
        let params = match self.fish_params.get(&id.index) {
            Some((generation, v)) if *generation == id.generation => self.lua.to_value(&**v)?,
            _ => Value::Table(self.lua.create_table()?),
        };
        t.raw_set("params", params)?;
        Ok(t)
    }

    /// The table a scene measure is called with for fish `id`: its own table once it has one
    /// (its `memory`, `intention`, `percepts`), else a fresh one that is not kept (a fish with
    /// no behaviour, or one that has not decided yet).
    pub fn measure_fish_table(
        &self,
        id: FishId,
        species: &str,
        behavior: &str,
    ) -> mlua::Result<Table> {
        match self.existing_fish_table(id) {
            Some(t) => Ok(t),
            None => self.new_fish_table(id, species, behavior),
        }
    }

    /// Calls a scene measure `f` with `fish` under the per-call budget, with `shoal.species()`
    /// answering for species index `species_number - 1`. An error comes back as the console
    /// shows it (`file:line: message`).
    pub fn call_measure(
        &self,
        f: &Function,
        fish: &Table,
        species_number: u16,
    ) -> Result<Value, String> {
        let _metered = self.begin_call();
        let call = || -> mlua::Result<Value> {
            let decision: Table = self.lua.named_registry_value(DECISION_KEY)?;
            decision.raw_set("species", species_number)?;
            f.call::<Value>(fish)
        };
        call().map_err(|e| self.after_error(&e))
    }

    /// Sets the data a fish finds in `fish.params` (from its scene group): in its table at once
    /// when the fish has decided already (the panel's edits of a scene's `params`), else when
    /// the table is made.
    pub fn set_params(
        &mut self,
        id: FishId,
        params: Arc<serde_json::Value>,
    ) -> Result<(), ScriptError> {
        if let Some(t) = self.existing_fish_table(id) {
            let err = |e: mlua::Error| ScriptError::Lua(describe(&e));
            let value = self.lua.to_value(&*params).map_err(err)?;
            t.raw_set("params", value).map_err(err)?;
        }
        self.fish_params.insert(id.index, (id.generation, params));
        Ok(())
    }

    /// The cached handle on the fish's table, if it belongs to this generation of the slot.
    fn cached_table(&self, id: FishId) -> Option<&Table> {
        match self.table_cache.get(id.index as usize) {
            Some(Some((generation, t))) if *generation == id.generation => Some(t),
            _ => None,
        }
    }

    /// Hints the cache to load fish `id`'s table (the Lua object's header: its first lookup
    /// reads it) for a decision a little later. Does nothing for a fish with no table yet.
    pub fn prefetch_fish_table(&self, id: FishId) {
        if let Some(t) = self.cached_table(id) {
            shoal_core::prefetch::prefetch_lines(t.to_pointer().cast::<u8>(), 1);
        }
    }

    fn cache_table(&mut self, id: FishId, t: Table) {
        let slot = id.index as usize;
        if self.table_cache.len() <= slot {
            self.table_cache.resize(slot + 1, None);
        }
        self.table_cache[slot] = Some((id.generation, t));
    }

    /// The fish's table if it has run (or been created) already.
    pub fn existing_fish_table(&self, id: FishId) -> Option<Table> {
        match self.fish_tables.raw_get::<Value>(id.index) {
            Ok(Value::Table(t)) if t.raw_get::<u32>("generation").ok() == Some(id.generation) => {
                Some(t)
            }
            _ => None,
        }
    }

    /// Forgets a fish's table (when it is despawned).
    pub fn forget_fish(&mut self, id: FishId) {
        if self.existing_fish_table(id).is_some() {
            let _ = self.fish_tables.raw_set(id.index, Value::Nil);
        }
        if let Some(c) = self.table_cache.get_mut(id.index as usize) {
            *c = None;
        }
        self.fish_errors.remove(&id.index);
        self.fish_params.remove(&id.index);
    }

    /// Runs one decision of module `module` for the fish whose table is `fish`, within the
    /// per-call instruction budget. An error is logged once (file:line), remembered for the
    /// inspector and returned; the fish keeps whatever motion it had.
    pub fn run(
        &mut self,
        module: ModuleIndex,
        id: FishId,
        fish: &Table,
        time_s: f64,
    ) -> Result<(), DecisionError> {
        let Some(result) = self.call_driver(module, fish, None) else {
            return Ok(());
        };
        self.after_run(result, module, id, time_s)
    }

    /// [`ScriptHost::run`] for the fish's own table, created (from its species and behaviour
    /// names) if it has none yet, and passed by reference (no handle cloned per decision). The
    /// driver tells the `shoal` API the fish's species (`species_id`). An error making the
    /// table is logged and returned too.
    pub fn run_fish(
        &mut self,
        module: ModuleIndex,
        id: FishId,
        (species_id, species): (shoal_core::world::SpeciesId, &str),
        behavior: &str,
        time_s: f64,
    ) -> Result<(), DecisionError> {
        if let Err(e) = self.ensure_fish_table(id, species, behavior) {
            self.log(LogLevel::Error, &e.to_string(), Some(id), time_s);
            return Err(DecisionError::NoTable(e));
        }
        let Some(fish) = self.cached_table(id) else {
            return Ok(());
        };
        let Some(result) = self.call_driver(module, fish, Some(species_id.0 + 1)) else {
            return Ok(());
        };
        self.after_run(result, module, id, time_s)
    }

    /// Arms the per-call budget for a behaviour call, unmetered for [`Limits::metered_after`]
    /// where the watchdog can watch this state; the call is metered while the guard lives.
    fn begin_call(&self) -> Metered<'_> {
        // Under the debugger's line hook, metered from the first instruction: the watchdog's
        // delayed metering would replace the line hook with its own.
        let unmetered = if self.meter.watched() && !self.line_hook {
            self.limits.metered_after
        } else {
            Duration::ZERO
        };
        self.budget
            .arm_after(self.limits.instructions_per_call, unmetered);
        self.budget.limit_time(self.limits.time_per_call);
        self.meter.call(unmetered, self.limits.time_per_call)
    }

    /// Arms the per-load budget, counted from the first instruction, while the guard lives.
    fn begin_load(&self) -> Metered<'_> {
        self.budget.arm(self.limits.instructions_per_load);
        self.budget.limit_time(self.limits.time_per_load);
        self.meter.call(Duration::ZERO, self.limits.time_per_load)
    }

    /// Runs a decision under the per-call budget; `None` if the module never loaded.
    /// `species_number` is the fish's species index + 1, for `shoal.species()`.
    fn call_driver(
        &self,
        module: ModuleIndex,
        fish: &Table,
        species_number: Option<u16>,
    ) -> Option<mlua::Result<()>> {
        let table = self.modules.get(module)?.table.as_ref()?;
        let _metered = self.begin_call();
        if self.line_hook {
            super::watchdog::add_line_hook(&self.lua);
        }
        Some(self.driver.call::<()>((table, fish, species_number)))
    }

    /// Logs and remembers the error of a decision, if it failed.
    fn after_run(
        &mut self,
        result: mlua::Result<()>,
        module: ModuleIndex,
        id: FishId,
        time_s: f64,
    ) -> Result<(), DecisionError> {
        match result {
            Ok(()) => {
                self.last_call_hit_limit = false;
                Ok(())
            }
            Err(e) => {
                let stopped =
                    matches!(e, mlua::Error::MemoryError(_)) || self.budget.aborted().is_some();
                self.last_call_hit_limit = stopped;
                let mut msg = self.after_error(&e);
                if !super::lua_error::has_location(&msg) && !msg.starts_with(&self.root.display) {
                    // Errors without a position (out of memory) at least name the file.
                    let file = self.root.display_of(&self.modules[module].path);
                    msg = format!("{file}: {msg}");
                }
                self.log(LogLevel::Error, &msg, Some(id), time_s);
                if self.fish_errors.get(&id.index) != Some(&msg) {
                    self.fish_errors.insert(id.index, msg.clone());
                }
                Err(if stopped {
                    DecisionError::Stopped { message: msg }
                } else {
                    DecisionError::Raised { message: msg }
                })
            }
        }
    }

    /// Counts the outcome of a decision of `module` for the simulation's quarantine: a success
    /// clears the failures in a row; past [`QUARANTINE_AFTER_FAILURES`] failures in a row or
    /// [`QUARANTINE_AFTER_LIMIT_HITS`] budget or memory stops (the last call's, see
    /// [`ScriptHost::run`]), the module is switched off until its file loads again, with a
    /// warning in the console. The host itself still runs a switched-off module when asked;
    /// the simulation asks [`ScriptHost::is_switched_off`] first.
    pub fn count_outcome(&mut self, module: ModuleIndex, failed: bool, time_s: f64) {
        let limit_hit = failed && self.last_call_hit_limit;
        let Some(m) = self.modules.get_mut(module) else {
            return;
        };
        if !failed {
            m.failures_in_a_row = 0;
            return;
        }
        if m.quarantined.is_some() {
            return;
        }
        m.failures_in_a_row += 1;
        m.limit_hits += u32::from(limit_hit);
        let why = if m.limit_hits >= QUARANTINE_AFTER_LIMIT_HITS {
            format!(
                "{} calls stopped by its instruction budget, time limit or memory limit",
                m.limit_hits
            )
        } else if m.failures_in_a_row >= QUARANTINE_AFTER_FAILURES {
            format!("{} failed calls in a row", m.failures_in_a_row)
        } else {
            return;
        };
        let display = self.root.display_of(&m.path);
        let msg = format!(
            "{display}: behaviour '{}' switched off after {why}; its fish keep their last motion \
             until the file is saved",
            m.name
        );
        m.quarantined = Some(why);
        self.log(LogLevel::Warning, &msg, None, time_s);
    }

    /// Whether the last failed decision was stopped by the instruction budget, the time limit
    /// or the memory limit.
    pub fn last_call_hit_limit(&self) -> bool {
        self.last_call_hit_limit
    }

    /// The file of behaviour module `module` (canonical).
    pub fn module_path(&self, module: ModuleIndex) -> Option<&Path> {
        self.modules.get(module).map(|m| m.path.as_path())
    }

    /// Runs the next decisions with the debugger's line hook (`true`) or without (see
    /// [`super::debug`]).
    pub(crate) fn set_line_hook(&mut self, on: bool) {
        self.line_hook = on;
    }

    /// The state's instruction budget (the debugger meters evaluations with it).
    pub(crate) fn budget(&self) -> &Arc<Budget> {
        &self.budget
    }

    /// The behaviour name of module `module`.
    pub fn module_name(&self, module: ModuleIndex) -> Option<&str> {
        self.modules.get(module).map(|m| m.name.as_str())
    }

    /// True when module `module` is switched off (see [`ScriptHost::quarantine_of`]).
    pub fn is_switched_off(&self, module: ModuleIndex) -> bool {
        self.modules
            .get(module)
            .is_some_and(|m| m.quarantined.is_some())
    }

    /// Why behaviour module `name` is switched off (see [`ScriptHost::run`]), if it is.
    pub fn quarantine_of(&self, name: &str) -> Option<&str> {
        let &i = self.by_name.get(name)?;
        self.modules[i].quarantined.as_deref()
    }

    /// Opens (`Some`) or closes (`None`) a behaviour stage on the Lua side of the API (see
    /// [`super::api::set_stage`]), under a fresh call budget.
    pub fn set_stage(&self, stage: Option<(f64, &shoal_core::world::World)>) -> mlua::Result<()> {
        let _metered = self.begin_call();
        super::api::set_stage(&self.lua, stage)
    }

    /// The last error a fish's script raised, if any.
    pub fn fish_error(&self, id: FishId) -> Option<&str> {
        self.fish_errors.get(&id.index).map(String::as_str)
    }

    /// A copy of every fish table of this lane (see [`super::fish_state`]).
    pub fn save_fish_state(
        &self,
    ) -> Result<super::fish_state::LaneState, super::fish_state::FishStateError> {
        super::fish_state::save(&self.fish_tables)
    }

    /// Puts back the fish tables of [`ScriptHost::save_fish_state`]'s copy.
    pub fn restore_fish_state(
        &mut self,
        state: &super::fish_state::LaneState,
    ) -> Result<(), super::fish_state::FishStateError> {
        self.table_cache.clear();
        let lua = &self.lua;
        let params = |index: u32, generation: u32| match self.fish_params.get(&index) {
            Some((g, v)) if *g == generation => lua.to_value(&**v),
            _ => lua.create_table().map(Value::Table),
        };
        super::fish_state::restore(lua, &self.fish_tables, state, params)
    }

    /// A fish's memory table as JSON (functions and other non-data values become null).
    pub fn memory_json(&self, id: FishId) -> serde_json::Value {
        let Some(t) = self.existing_fish_table(id) else {
            return serde_json::Value::Null;
        };
        match t.raw_get::<Value>("memory") {
            Ok(v) => value_to_json(&v, 0),
            Err(_) => serde_json::Value::Null,
        }
    }

    /// Runs a snippet of Lua in a fresh sandboxed environment (for the console and tests),
    /// within the per-load budget. Returns the value converted to JSON.
    pub fn eval(&self, name: &str, code: &str) -> Result<serde_json::Value, EvalError> {
        let env = sandbox::module_env(&self.lua).map_err(EvalError::Setup)?;
        self.eval_in(env, name, code)
    }

    /// This state's logpoints.
    pub fn logpoints(&self) -> Option<super::logpoints::Logpoints> {
        self.lua
            .app_data_ref::<super::logpoints::Logpoints>()
            .map(|l| l.clone())
    }

    /// Sets this state's logpoints (they apply when a file is next loaded).
    pub fn set_logpoints(&self, points: super::logpoints::Logpoints) {
        self.lua.set_app_data(points);
    }

    /// Whether `source` compiles as Lua (the error says why not).
    pub fn check_compiles(&self, name: &str, source: &str) -> Result<(), EvalError> {
        self.lua
            .load(source)
            .set_name(format!("@{name}"))
            .set_mode(mlua::chunk::ChunkMode::Text)
            .into_function()
            .map(|_| ())
            .map_err(EvalError::Syntax)
    }

    /// Like [`ScriptHost::eval`], with the fish's table as `fish` (its `memory`, `intention`,
    /// `percepts`…): what the console's REPL runs for the selected fish. An expression
    /// (`fish.memory.hunger * 2`) gives its value; a statement (`fish.memory.hunger = 0`) runs and
    /// gives null. The sandbox and the per-load budget apply. `shoal.*` sensor and motion calls
    /// are not available here (they act only inside a decision).
    pub fn eval_fish(&self, id: FishId, code: &str) -> Result<serde_json::Value, EvalError> {
        let fish = self
            .existing_fish_table(id)
            .ok_or(EvalError::NotDecided(id))?;
        let env = sandbox::module_env(&self.lua).map_err(EvalError::Setup)?;
        env.raw_set("fish", fish).map_err(EvalError::Setup)?;
        let name = format!("console (fish #{})", id.index);
        // An expression first; if it does not parse as one, a statement.
        let as_expr = format!("return {code}");
        let code = if self.is_expression(code) {
            as_expr.as_str()
        } else {
            code
        };
        self.eval_in(env, &name, code)
    }

    /// Whether `code` parses as a Lua expression (`fish.memory.hunger`), not only as a
    /// statement (`fish.memory.hunger = 1`): the console shows a value for the one, and only
    /// that it ran for the other.
    pub fn is_expression(&self, code: &str) -> bool {
        self.lua
            .load(format!("return {code}"))
            .set_mode(mlua::chunk::ChunkMode::Text)
            .into_function()
            .is_ok()
    }

    fn eval_in(&self, env: Table, name: &str, code: &str) -> Result<serde_json::Value, EvalError> {
        let f = self
            .lua
            .load(code)
            .set_name(format!("@{name}"))
            .set_mode(mlua::chunk::ChunkMode::Text)
            .set_environment(env)
            .into_function()
            .map_err(EvalError::Syntax)?;
        let v: Value = {
            let _metered = self.begin_load();
            f.call(()).map_err(|e| {
                self.recover(&e);
                EvalError::Runtime(e)
            })?
        };
        Ok(value_to_json(&v, 0))
    }

    /// Runs a data file (species, scene) in a fresh sandboxed environment within the per-load
    /// budget and returns its value.
    pub fn load_data_file(&self, path: &Path) -> Result<Value, ScriptError> {
        let f = sandbox::load_file(&self.lua, path)?;
        let _metered = self.begin_load();
        f.call::<Value>(())
            .map_err(|e| ScriptError::Lua(self.after_error(&e)))
    }

    /// [`Self::load_data_file`] for text not yet on disk, named `display` in messages.
    pub fn load_data_source(&self, display: &str, source: &str) -> Result<Value, ScriptError> {
        let f = sandbox::load_source(&self.lua, display, source)?;
        let _metered = self.begin_load();
        f.call::<Value>(())
            .map_err(|e| ScriptError::Lua(self.after_error(&e)))
    }

    /// Converts a Lua value to JSON through mlua's serde support (for species and scene data).
    pub fn from_lua<T: serde::de::DeserializeOwned>(&self, v: Value) -> mlua::Result<T> {
        self.lua.from_value(v)
    }

    /// The state's meter: its stack sampler, allocation count and profile tag (see
    /// [`super::profiler`]).
    pub fn meter(&self) -> &Meter {
        &self.meter
    }
}

impl Drop for ScriptHost {
    fn drop(&mut self) {
        // While the state is still open (the fields drop after this).
        self.meter.stop_counting_allocations();
    }
}

/// A Lua value as JSON, tables up to a few levels deep; arrays stay arrays.
pub fn value_to_json(v: &Value, depth: usize) -> serde_json::Value {
    use serde_json::Value as J;
    match v {
        Value::Nil => J::Null,
        Value::Boolean(b) => J::Bool(*b),
        Value::Integer(i) => J::from(*i),
        Value::Number(n) => serde_json::Number::from_f64(*n).map_or(J::Null, J::Number),
        Value::String(s) => J::String(s.to_string_lossy()),
        Value::Table(t) if depth < 4 => {
            let len = t.raw_len();
            let mut entries: Vec<(Value, Value)> = t.pairs::<Value, Value>().flatten().collect();
            if len > 0 && entries.len() == len {
                entries.sort_by_key(|(k, _)| k.as_integer().unwrap_or(0));
                J::Array(
                    entries
                        .iter()
                        .map(|(_, v)| value_to_json(v, depth + 1))
                        .collect(),
                )
            } else {
                let mut m = serde_json::Map::new();
                for (k, v) in entries {
                    let key = match &k {
                        Value::String(s) => s.to_string_lossy(),
                        other => other.to_string().unwrap_or_default(),
                    };
                    m.insert(key, value_to_json(&v, depth + 1));
                }
                J::Object(m)
            }
        }
        _ => J::Null,
    }
}
